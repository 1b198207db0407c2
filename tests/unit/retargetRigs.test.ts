// Retargeting onto characters of other conventions (tests/unit/retargetRigs.ts builds them as GLB):
// load → automatic map → retarget a real generated motion (model parity fixtures) and a real mocap clip
// (recover fixture) → every driven bone's world direction within 10° of our skeleton's, feet on the
// floor on contact frames, no NaN → GLB export reloads in three's GLTFLoader with skin and animation
// and plays the same motion → BVH on the rig's names.
import { AnimationMixer, LoopOnce, type AnimationClip, type Object3D, Quaternion, Vector3 } from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { describe, expect, it } from 'vitest';
import { loadCharacter, readGlb, withoutTextures } from '../../src/character/retarget/load';
import { type GltfJson, writeGlb } from '../../src/export/glb';
import type { BoneMapping } from '../../src/character/retarget/mapping';
import { type RetargetMotion, type RetargetResult, retargetMotion } from '../../src/character/retarget/retarget';
import { characterToBVH, characterToGLB, fileBoneNames } from '../../src/export/characterGlb';
import { cleanupFootContacts, contactsFromFeatures, plantContacts } from '../../src/motion/footContact';
import { restPositions } from '../../src/character/rig';
import { JOINT_NAMES, type JointName } from '../../src/skeleton';
import fs from 'node:fs';
import path from 'node:path';
import { ROOT, fixtureExists, loadCase, manifestSkeleton } from './coreFixtures';
import { RIGS, buildRigGlb, withSkin } from './retargetRigs';

const sk = manifestSkeleton();
const J = sk.joints.length;

function motionOf(name: string): RetargetMotion & { label: string } {
  const fx = loadCase(name);
  const frames = fx.meta.frames;
  const raw = contactsFromFeatures(fx.get('features'), frames);
  // as the page generates them (generate({ footCleanup: true })): contact joints pinned on our skeleton, and the
  // character told the runs that were pinned (plantContacts), as the page's character picker does
  const joints = cleanupFootContacts(fx.get('joints'), frames, raw, sk);
  return { label: name, joints, frames, fps: sk.fps, contacts: plantContacts(joints, frames, raw, sk) };
}
// generated motions (what the page puts on a character) and a real mocap clip (a kick: long one-leg
// stances on a nearly straight leg, where holding the foot exactly would swing the leg past 10°)
const MOTIONS = ['model-emdm-t2m-web', 'model-emdm-a2m-web', 'recover'].filter(fixtureExists).map(motionOf);

/** The pairs whose direction the retargeting follows, with the across vectors of hips and chest. */
const PRIMARY: Partial<Record<JointName, JointName>> = {
  pelvis: 'spine1', spine1: 'spine2', spine2: 'spine3', spine3: 'neck', neck: 'head',
  l_hip: 'l_knee', l_knee: 'l_ankle', l_ankle: 'l_foot', r_hip: 'r_knee', r_knee: 'r_ankle', r_ankle: 'r_foot',
  l_collar: 'l_shoulder', l_shoulder: 'l_elbow', l_elbow: 'l_wrist', r_collar: 'r_shoulder', r_shoulder: 'r_elbow', r_elbow: 'r_wrist',
};
function pairs(m: BoneMapping): [JointName, JointName][] {
  const out: [JointName, JointName][] = [];
  for (const j of JOINT_NAMES) {
    if (!m[j]) continue;
    let k = PRIMARY[j];
    while (k && !m[k]) k = PRIMARY[k];
    if (k) out.push([j, k]);
  }
  out.push(['r_hip', 'l_hip']);
  out.push(m.l_collar && m.r_collar ? ['r_collar', 'l_collar'] : ['r_shoulder', 'l_shoulder']);
  return out;
}

interface Measure {
  maxDeg: number;
  meanDeg: number;
  medianDeg: number;
  worst: string;
  footMaxCm: number;
  /** the same on our own motion (our skeleton's rest heights) */
  ourFootMaxCm: number;
  ourSlideMaxCm: number;
  slideMaxCm: number;
  positions: Vector3[][];
}

/** Play `clip` on `root` frame by frame and compare the mapped bones with our joints. */
function measure(root: Object3D, clip: AnimationClip, mapping: BoneMapping, motion: RetargetMotion, yaw: number): Measure {
  const byName = new Map<string, Object3D>();
  root.traverse((o) => {
    if (!byName.has(o.name)) byName.set(o.name, o);
  });
  const bone = (j: JointName) => byName.get(mapping[j]!)!;
  root.updateMatrixWorld(true);
  const inv = root.matrixWorld.clone().invert();
  const at = (j: JointName) => new Vector3().setFromMatrixPosition(bone(j).matrixWorld).applyMatrix4(inv);
  const feet: [JointName, JointName][] = [['l_ankle', 'l_foot'], ['r_ankle', 'r_foot']];
  const rest = Object.fromEntries(feet.flat().filter((j) => mapping[j]).map((j) => [j, at(j)]));
  const C = new Quaternion().setFromAxisAngle(new Vector3(0, 1, 0), yaw);
  const P = (f: number, j: JointName) => {
    const o = (f * J + sk.joints.indexOf(j)) * 3;
    return new Vector3(motion.joints[o], motion.joints[o + 1], motion.joints[o + 2]);
  };
  const mixer = new AnimationMixer(root);
  const action = mixer.clipAction(clip);
  action.setLoop(LoopOnce, 1);
  action.clampWhenFinished = true; // the last frame stays (LoopRepeat would wrap it to frame 0)
  action.play();
  const prs = pairs(mapping);
  const errs: number[] = [];
  let worst = '';
  let maxDeg = 0;
  let footMax = 0;
  let ourFootMax = 0;
  let ourSlideMax = 0;
  const ourStart: Record<string, Vector3 | null> = {};
  const ourRest = restPositions(sk);
  let slideMax = 0;
  const positions: Vector3[][] = [];
  const runStart: Record<string, Vector3 | null> = { l_ankle: null, r_ankle: null };
  for (let f = 0; f < motion.frames; f++) {
    mixer.setTime(f / motion.fps);
    root.updateMatrixWorld(true);
    const pos = Object.fromEntries(JOINT_NAMES.filter((j) => mapping[j]).map((j) => [j, at(j)])) as Record<JointName, Vector3>;
    positions.push(JOINT_NAMES.filter((j) => mapping[j]).map((j) => pos[j]));
    for (const [a, b] of prs) {
      const mine = pos[b].clone().sub(pos[a]);
      const ours = P(f, b).sub(P(f, a)).applyQuaternion(C);
      const deg = (mine.angleTo(ours) * 180) / Math.PI;
      expect(Number.isFinite(deg), `${a}→${b} frame ${f}`).toBe(true);
      errs.push(deg);
      if (deg > maxDeg) {
        maxDeg = deg;
        worst = `${a}→${b} @${f}`;
      }
    }
    // a foot in contact has its heel (ankle) or its ball (toe) on the floor: the lower of the two is
    // at its rest height (the character stands on y = 0 at rest); the ankle does not slide
    feet.forEach(([ank, toe], side) => {
      const cA = motion.contacts![f * 4 + side * 2] > 0.5;
      const cT = motion.contacts![f * 4 + side * 2 + 1] > 0.5;
      if (cA || cT) {
        const dy = Math.min(pos[ank].y - rest[ank].y, mapping[toe] ? pos[toe].y - rest[toe].y : Infinity);
        footMax = Math.max(footMax, Math.abs(dy));
        const ourDy = Math.min(P(f, ank).y - ourRest[sk.joints.indexOf(ank)].y, P(f, toe).y - ourRest[sk.joints.indexOf(toe)].y);
        ourFootMax = Math.max(ourFootMax, Math.abs(ourDy));
      }
      if (cA) {
        if (runStart[ank]) {
          slideMax = Math.max(slideMax, Math.hypot(pos[ank].x - runStart[ank]!.x, pos[ank].z - runStart[ank]!.z));
          ourSlideMax = Math.max(ourSlideMax, Math.hypot(P(f, ank).x - ourStart[ank]!.x, P(f, ank).z - ourStart[ank]!.z));
        } else {
          runStart[ank] = pos[ank].clone();
          ourStart[ank] = P(f, ank);
        }
      } else runStart[ank] = null;
    });
  }
  mixer.stopAllAction();
  mixer.uncacheRoot(root);
  errs.sort((a, b) => a - b);
  return { maxDeg, meanDeg: errs.reduce((a, b) => a + b, 0) / errs.length, medianDeg: errs[Math.floor(errs.length / 2)], worst, footMaxCm: footMax * 100, ourFootMaxCm: ourFootMax * 100, ourSlideMaxCm: ourSlideMax * 100, slideMaxCm: slideMax * 100, positions };
}

/** Three's GLTFLoader reads the download back (Node decodes no images: textures are left out for it, after checking they are all there). */
async function reload(glb: Uint8Array, ch: { json: GltfJson }) {
  const { json, bin } = readGlb(glb, 'download.glb');
  expect((json.images ?? []).length).toBe((ch.json.images ?? []).length);
  expect((json.textures ?? []).length).toBe((ch.json.textures ?? []).length);
  expect((json.materials ?? []).length).toBe((ch.json.materials ?? []).length);
  const again = writeGlb(json.images?.length ? withoutTextures(json) : json, bin!);
  return new GLTFLoader().parseAsync(again.buffer.slice(again.byteOffset, again.byteOffset + again.byteLength) as ArrayBuffer, '');
}

/** Load → map → retarget every motion → check, export GLB (reload, replay) and BVH. */
async function checkCharacter(label: string, file: string, glb: Uint8Array, unmapped: string[], source: string, vrm?: string, facingDeg?: number) {
      const t0 = performance.now();
      const ch = await loadCharacter([{ name: file, data: glb }]);
      const loadMs = performance.now() - t0;
      expect(ch.unmapped, 'joints the automatic map missed').toEqual(unmapped);
      expect(ch.mappingSource).toBe(source);
      const spec = { label, vrm };
      for (const motion of MOTIONS) {
        const t1 = performance.now();
        const res: RetargetResult = retargetMotion(ch.root, ch.mapping, motion, sk);
        const retargetMs = performance.now() - t1;
        for (const r of res.rotations) expect(r.every(Number.isFinite)).toBe(true);
        expect(res.rootPositions.every(Number.isFinite)).toBe(true);
        const m = measure(ch.root, res.clip, ch.mapping, motion, res.yaw);
        // heights and slides in the character's units are also given at our size (÷ its leg-length
        // ratio `scale`): a character twice our size (RobotExpressive) is held to the same 3 cm at our size
        const foot = m.footMaxCm / res.scale;
        const slide = m.slideMaxCm / res.scale;
        console.log(`[retarget] ${spec.label.split(',')[0]} × ${motion.label}: mapped ${22 - ch.unmapped.length}/22, limb direction max ${m.maxDeg.toFixed(2)}° (${m.worst}) mean ${m.meanDeg.toFixed(3)}° median ${m.medianDeg.toFixed(3)}°, foot height on contact frames ≤ ${m.footMaxCm.toFixed(2)} cm in its units, ${foot.toFixed(2)} cm at our size (ours ${m.ourFootMaxCm.toFixed(2)} cm), slide ≤ ${slide.toFixed(2)} cm at our size (ours ${m.ourSlideMaxCm.toFixed(2)} cm), scale ${res.scale.toFixed(3)}, yaw ${((res.yaw * 180) / Math.PI).toFixed(0)}°, load ${loadMs.toFixed(0)} ms, retarget ${retargetMs.toFixed(0)} ms`);
        expect(m.maxDeg, m.worst).toBeLessThan(10);
        // the rest facing found from the hips (VRM 0.x faces −Z: 180°, what three-vrm's rotateVRM0 turns)
        if (facingDeg !== undefined) expect(Math.abs(Math.abs((res.yaw * 180) / Math.PI) - facingDeg)).toBeLessThan(1);
        // feet on the floor on every contact frame, the real kick clip included (long one-leg stances on
        // a nearly straight leg: the root goes down to the lower foot, the other leg bends)
        expect(foot).toBeLessThan(3);
        // the generated clips' heels hold still; the kick's stances roll heel → toe (printed only)
        if (motion.label.startsWith('model-')) expect(slide).toBeLessThan(1);


        // the GLB download: the character's own document + the clip; three reads it back with skin and animation
        const out = characterToGLB(ch, res);
        const back = await reload(out, ch);
        const skinned = (r: Object3D) => {
          let n = 0;
          r.traverse((o) => {
            if ((o as { isSkinnedMesh?: boolean }).isSkinnedMesh) n++;
          });
          return n;
        };
        expect(skinned(back.scene)).toBeGreaterThan(0);
        expect(skinned(back.scene)).toBe(skinned(ch.root));
        expect(back.animations.length).toBe(ch.gltf.animations.length + 1); // its own animations are kept
        const anim = back.animations.find((a) => a.name === 'emdm')!;
        expect(anim).toBeTruthy();
        expect(anim.tracks.length).toBe(res.bones.length + 1 + res.positions.length);
        expect(anim.duration).toBeCloseTo((motion.frames - 1) / motion.fps, 5);
        if (spec.vrm) {
          expect(JSON.stringify(back.parser.json.extensions)).toContain(spec.vrm === '1.0' ? 'VRMC_vrm' : '"VRM"');
          // still a VRM three-vrm reads, with the same humanoid map
          const again = await loadCharacter([{ name: file, data: out }]);
          expect([again.vrm, again.mapping]).toEqual([ch.vrm, ch.mapping]);
        }
        const again = measure(back.scene, anim, ch.mapping, motion, res.yaw);
        let moved = 0;
        again.positions.forEach((row, f) => row.forEach((p, k) => (moved = Math.max(moved, p.distanceTo(m.positions[f][k])))));
        expect(moved, 'the reloaded GLB plays the same motion').toBeLessThan(1e-4);

        // the BVH download on the rig's names
        const bvh = characterToBVH(ch.root, res, fileBoneNames(ch));
        const lines = bvh.split('\n');
        // metres by default, like writeBVH; centimetres on request: every number ×100 but the angles
        const cm = characterToBVH(ch.root, res, fileBoneNames(ch), 'cm').split('\n');
        const off = (l: string[]) => l.find((x) => /^\s+OFFSET/.test(x) && !/OFFSET 0\.0+ 0\.0+ 0\.0+$/.test(x.trim()))!.trim().split(/\s+/).slice(1).map(Number);
        off(cm).forEach((v, k) => expect(v).toBeCloseTo(off(lines)[k] * 100, 2));
        expect(lines[1]).toBe(`ROOT ${ch.json.nodes[ch.nodeIndex.get(res.bones[0])!].name.replace(/\s+/g, '_')}`);
        const channels = (bvh.match(/CHANNELS (\d)/g) ?? []).reduce((a, c) => a + Number(c.slice(-1)), 0);
        const motionLines = lines.slice(lines.indexOf('MOTION') + 3).filter(Boolean);
        expect(motionLines.length).toBe(motion.frames);
        for (const l of motionLines) {
          const v = l.split(' ').map(Number);
          expect(v.length).toBe(channels);
          expect(v.every(Number.isFinite)).toBe(true);
        }
      }
}

describe('retargeting onto rigs of other conventions', () => {
  if (!MOTIONS.length) it.skip('no motion fixtures (tests/fixtures/parity/model-*.json, recover.json)', () => {});
  for (const spec of RIGS) {
    it(spec.label, () =>
      checkCharacter(spec.label, `${spec.label.split(' ')[0]}.${spec.vrm ? 'vrm' : 'glb'}`, buildRigGlb(sk, spec), spec.vrm === '1.0' ? ['spine2'] : [], spec.vrm ? 'vrm' : 'names', spec.vrm));
  }
});

describe('retargeting onto real characters (tests/fixtures/rigs)', () => {
  it("three.js's RobotExpressive (CC0): Blender names, feet as IK targets, rigid parts, its own 14 animations", async () => {
    const file = path.join(ROOT, 'tests', 'fixtures', 'rigs', 'RobotExpressive.glb');
    await checkCharacter('RobotExpressive', 'RobotExpressive.glb', new Uint8Array(fs.readFileSync(file)), ['l_foot', 'r_foot', 'l_wrist', 'r_wrist'], 'names');
  });
  it('cryptovoxels.vrm (VRM 0.x from UniVRM, skinned, faces −Z): through three-vrm, its humanoid map', async () => {
    const file = path.join(ROOT, 'tests', 'fixtures', 'rigs', 'cryptovoxels.vrm');
    await checkCharacter('cryptovoxels.vrm', 'cryptovoxels.vrm', new Uint8Array(fs.readFileSync(file)), ['spine2'], 'vrm', '0.x', 180);
  });
  it("VRM 1.0 sample from the VRM specification (Blender VRM add-on armature, rolled bone axes), given a skin", async () => {
    // the file's meshes are unskinned quads (a material sample): withSkin binds a small mesh to its armature
    const name = 'VRMC_materials_mtoon_UV_Animation_Test.vrm';
    const file = path.join(ROOT, 'tests', 'fixtures', 'rigs', name);
    await checkCharacter('VRM 1.0 mtoon sample', name, withSkin(new Uint8Array(fs.readFileSync(file)), name), ['spine2'], 'vrm', '1.0', 0);
  });
});
