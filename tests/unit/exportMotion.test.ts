// The page's downloads of a generated motion on the built-in character (src/export/): the glTF binary
// (skinned character + the motion as its one animation) and the joints JSON. Their bytes for one fixed
// motion are pinned by sha256, taken from web/ui/downloads.ts before this code moved to src/export/ (issue
// 31: the move keeps every download byte for byte); the structure of both is read back as a client would.
import { createHash } from 'node:crypto';
import { AnimationMixer, Vector3 } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';
import { afterAll, beforeAll, describe, expect, it } from 'vitest';
import { forwardKinematics, solveIK, solvePose } from '../../src/motion/ik';
import { createCharacter, type PoseTrack } from '../../src/three';
import { motionToGLB } from '../../src/export/builtinGlb';
import { motionToJSON } from '../../src/export/jointsJson';
import { manifestSkeleton, randomPoseQuats } from './coreFixtures';

const sk = manifestSkeleton();
const J = sk.joints.length;
const FRAMES = 12;

function posedJoints(): Float32Array {
  const root = new Float32Array(FRAMES * 3);
  for (let f = 0; f < FRAMES; f++) root.set([0.03 * f, 0.92 + 0.02 * Math.sin(f / 3), 0.05 * f], f * 3);
  return forwardKinematics(root, randomPoseQuats(FRAMES, J, 5, 0.5), FRAMES, sk);
}

function track(joints: Float32Array): PoseTrack {
  const ik = solveIK(joints, FRAMES, sk);
  return { frames: FRAMES, fps: 20, joints: J, rootPos: ik.rootPos, quats: ik.quats };
}

const sha = (b: ArrayBuffer | string) => createHash('sha256').update(typeof b === 'string' ? b : new Uint8Array(b)).digest('hex');

// GLTFExporter reads its binary back through FileReader, which Node lacks: the smallest one it needs.
class NodeFileReader {
  result: ArrayBuffer | null = null;
  onloadend: (() => void) | null = null;
  readAsArrayBuffer(blob: Blob) {
    void blob.arrayBuffer().then((b) => {
      this.result = b;
      this.onloadend?.();
    });
  }
}
const g = globalThis as { FileReader?: unknown };
let hadReader: unknown;
beforeAll(() => {
  hadReader = g.FileReader;
  g.FileReader ??= NodeFileReader;
});
afterAll(() => {
  g.FileReader = hadReader;
});

describe('motion downloads on the built-in character', () => {
  it('writes the joints JSON: frames × joints × xyz rounded to 0.1 mm, the same bytes as before the move', () => {
    const joints = posedJoints();
    const text = motionToJSON(sk, joints, FRAMES, 20, { model: 'test', seed: 5 });
    const doc = JSON.parse(text);
    expect(doc.format).toBe('emdm-joints/1');
    expect([doc.frames, doc.positions.length, doc.positions[0].length]).toEqual([FRAMES, FRAMES, J]);
    expect(doc.positions[7][4][1]).toBeCloseTo(joints[(7 * J + 4) * 3 + 1], 4);
    expect(sha(text)).toBe('9f69707899e6b253d4899b8a58eb05024138b4841329cc30ae807289500397ab');
  });

  it('refuses joints that do not match the frame count, naming both', () => {
    expect(() => motionToJSON(sk, new Float32Array(5), FRAMES, 20, {})).toThrow(/5 values, expected 12×22×3/);
  });

  it('writes a GLB with one skinned mesh, 22 bones and one animation of 23 tracks, the same bytes as before the move', async () => {
    const glb = await motionToGLB(sk, track(posedJoints()));
    const gltf = await new GLTFLoader().parseAsync(glb, '');
    let skinned = 0;
    let bones = 0;
    gltf.scene.traverse((o) => {
      if ((o as { isSkinnedMesh?: boolean }).isSkinnedMesh) skinned++;
      if ((o as { isBone?: boolean }).isBone) bones++;
    });
    expect([skinned, bones, gltf.animations.length, gltf.animations[0].tracks.length]).toEqual([1, J, 1, J + 1]);
    for (const t of gltf.animations[0].tracks) expect(t.times.length).toBe(FRAMES);
    expect(sha(glb)).toBe('ea7c02ced251c799896374c5b8315d14fc7261a3a78152d943d8f4849c3df152');
  });

  it("puts the bones at the offsets the track's rotations go with: the GLB's joints are the motion's (feet on its floor)", async () => {
    // a body of other proportions than the reference skeleton's, as the dataset's are: hips 5 cm higher, shins 10 % longer
    const body = sk.offsets.map((o) => [...o]);
    for (const n of ['l_hip', 'r_hip']) body[sk.joints.indexOf(n)][1] += 0.05;
    for (const n of ['l_ankle', 'r_ankle']) body[sk.joints.indexOf(n)] = body[sk.joints.indexOf(n)].map((v) => v * 1.1);
    const root = new Float32Array(FRAMES * 3);
    for (let f = 0; f < FRAMES; f++) root.set([0.03 * f, 0.95, 0.05 * f], f * 3);
    const joints = forwardKinematics(root, randomPoseQuats(FRAMES, J, 5, 0.3), FRAMES, sk, body);
    const ik = solveIK(joints, FRAMES, sk);
    const worst = async (t: PoseTrack): Promise<number> => {
      const gltf = await new GLTFLoader().parseAsync(await motionToGLB(sk, t), '');
      const mixer = new AnimationMixer(gltf.scene);
      mixer.clipAction(gltf.animations[0]).play();
      let err = 0;
      for (let f = 0; f < FRAMES; f++) {
        mixer.setTime(f / 20);
        gltf.scene.updateMatrixWorld(true);
        for (let j = 0; j < J; j++) {
          const p = gltf.scene.getObjectByName(sk.joints[j])!.getWorldPosition(new Vector3());
          err = Math.max(err, p.distanceTo(new Vector3().fromArray(joints, (f * J + j) * 3)));
        }
      }
      return err;
    };
    const placed = await worst({ ...track(joints), offsets: new Float32Array(ik.offsets.flat()) });
    const reference = await worst(track(joints));                 // the bones at the reference offsets, as before
    expect(placed).toBeLessThan(0.01);
    expect(reference).toBeGreaterThan(0.04);
    // the library's character playing the motion (its pose from solvePose, as createGenerator's results carry it)
    const ch = createCharacter(sk);
    ch.play({ frames: FRAMES, fps: 20, joints, features: new Float32Array(FRAMES * 263), pose: solvePose(joints, FRAMES, sk) });
    ch.object.updateMatrixWorld(true);
    const off = ch.bones.map((b, j) => b.getWorldPosition(new Vector3()).distanceTo(new Vector3().fromArray(joints, j * 3)));
    expect(Math.max(...off)).toBeLessThan(0.01);
    ch.dispose();
  });
});
