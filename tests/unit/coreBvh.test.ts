import { AnimationMixer, type Bone, LoopOnce } from 'three';
import { BVHLoader } from 'three/examples/jsm/loaders/BVHLoader.js';
import { describe, expect, it } from 'vitest';
import { bvhFileName, writeBVH } from '../../src/export/bvh';
import { forwardKinematics } from '../../src/motion/ik';
import type { Motion } from '../../src/motion/types';
import { fixtureExists, loadCase, manifestSkeleton, randomPoseQuats } from './coreFixtures';

const sk = manifestSkeleton();
const J = sk.joints.length;

/** World joint positions of a BVH text at given times, as three.js reads it, in file units ÷ `perMetre`
 * (1 for a file in metres, 100 for one in centimetres). */
function bvhPositions(text: string, frameTimes: number[], perMetre = 1): Float32Array[] {
  const { skeleton, clip } = new BVHLoader().parse(text);
  const root = skeleton.bones[0];
  const mixer = new AnimationMixer(root);
  const action = mixer.clipAction(clip);
  action.setLoop(LoopOnce, 1);
  action.clampWhenFinished = true; // sample the last frame instead of wrapping to the first
  action.play();
  const byName = new Map(skeleton.bones.map((b: Bone) => [b.name, b]));
  return frameTimes.map((t) => {
    mixer.setTime(t);
    root.updateMatrixWorld(true);
    const out = new Float32Array(J * 3);
    sk.joints.forEach((n, j) => {
      const b = byName.get(n);
      if (!b) throw new Error(`BVH has no joint ${n}`);
      const p = b.getWorldPosition(b.position.clone());
      out.set([p.x / perMetre, p.y / perMetre, p.z / perMetre], j * 3);
    });
    return out;
  });
}

function maxDist(a: Float32Array, b: Float32Array): number {
  let m = 0;
  for (let i = 0; i < a.length; i += 3) m = Math.max(m, Math.hypot(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2]));
  return m;
}

function posedMotion(frames: number): Motion {
  const root = new Float32Array(frames * 3);
  for (let f = 0; f < frames; f++) root.set([0.03 * f, 0.92 + 0.02 * Math.sin(f / 3), 0.05 * f], f * 3);
  const joints = forwardKinematics(root, randomPoseQuats(frames, J, 3, 0.5), frames, sk);
  return { frames, fps: 20, joints, features: new Float32Array(0) };
}

describe('BVH writer', () => {
  it('declares the hierarchy, channel order and frame time', () => {
    const text = writeBVH(posedMotion(5), sk);
    expect(text.startsWith('HIERARCHY\nROOT pelvis\n{')).toBe(true);
    expect(text).toContain('CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation');
    expect(text.match(/JOINT /g)).toHaveLength(J - 1);
    expect(text.match(/End Site/g)).toHaveLength(5);
    expect(text).toContain('Frames: 5\nFrame Time: 0.0500000');
  });

  for (const fps of [20, 30, 60] as const) {
    it(`three.js BVHLoader reads it back to the same joints within 1 cm at ${fps} fps`, () => {
      const m = posedMotion(21); // 1 s
      const text = writeBVH(m, sk, { fps });
      const n = Number(/Frames: (\d+)/.exec(text)![1]);
      expect(n).toBe(fps + 1);
      // compare at the 20 fps source frames (every fps/20-th output frame)
      const src = [0, 4, 7, 10, 20];
      const got = bvhPositions(text, src.map((f) => f / 20));
      src.forEach((f, i) => {
        expect(maxDist(got[i], m.joints.subarray(f * J * 3, (f + 1) * J * 3)), `frame ${f}`).toBeLessThan(0.01);
      });
    });
  }

  it('resampling interpolates between source frames (60 fps midpoints lie between neighbours)', () => {
    const m = posedMotion(3);
    const text = writeBVH(m, sk, { fps: 60, units: 'cm' });
    const rows = text.trim().split('\n').slice(-7).map((r) => r.split(' ').slice(0, 3).map(Number));
    // root x at 60 fps frames 0..6 = 0, 1, 2, ... cm steps of 3/3 cm
    rows.forEach((r, i) => expect(r[0]).toBeCloseTo(i, 3));
  });

  it('a real clip survives the round trip within 1 cm (recover fixture)', (ctx) => {
    if (!fixtureExists('recover')) return ctx.skip('tests/fixtures/parity/recover.json absent: run `python -m emdm.fixtures`');
    const fx = loadCase('recover');
    const frames = fx.meta.frames;
    const m: Motion = { frames, fps: 20, joints: fx.get('joints'), features: fx.get('features') };
    // at 30 fps every 2nd source frame falls on an output frame (the others are interpolated)
    const even = (f: number) => f - (f % 2);
    const picks = [0, even(Math.floor(frames / 2)), even(frames - 1)];
    const got = bvhPositions(writeBVH(m, sk, { fps: 30 }), picks.map((f) => f / 20));
    picks.forEach((f, i) => expect(maxDist(got[i], m.joints.subarray(f * J * 3, (f + 1) * J * 3)), `frame ${f}`).toBeLessThan(0.01));
  });

  // Blender's importer (scale 1.0) and three.js take BVH numbers as scene units = metres: a file in
  // centimetres puts the pelvis ~90 m up there. Metres are the default; the file name says the unit.
  it('writes metres by default (three.js reads the pelvis ~0.9 m up) and centimetres on request (~90)', () => {
    const fx = loadCase('recover'); // a real clip (Bandai kick), 120 frames
    const frames = fx.meta.frames;
    const m: Motion = { frames, fps: 20, joints: fx.get('joints'), features: new Float32Array(0) };
    const picks = [0, 60, frames - 1];
    const want = picks.map((f) => m.joints[f * J * 3 + 1]); // pelvis y, metres
    for (const w of want) expect(w).toBeGreaterThan(0.7), expect(w).toBeLessThan(1.1);
    const inMetres = bvhPositions(writeBVH(m, sk), picks.map((f) => f / 20), 1);
    const inCm = bvhPositions(writeBVH(m, sk, { units: 'cm' }), picks.map((f) => f / 20), 1); // read as-is: cm
    picks.forEach((f, i) => {
      expect(Math.abs(inMetres[i][1] - want[i]), `frame ${f}, metres file`).toBeLessThan(1e-3);
      expect(Math.abs(inCm[i][1] - 100 * want[i]), `frame ${f}, centimetres file`).toBeLessThan(0.1);
      expect(maxDist(inMetres[i], m.joints.subarray(f * J * 3, (f + 1) * J * 3)), `frame ${f}`).toBeLessThan(0.01);
    });
  });

  it('the metres file is the centimetres file with every length ÷ 100 (same rotations, same lines)', () => {
    const m = posedMotion(7);
    const a = writeBVH(m, sk, { fps: 30 }).split('\n');
    const b = writeBVH(m, sk, { fps: 30, units: 'cm' }).split('\n');
    expect(a.length).toBe(b.length);
    const motionStart = a.indexOf('MOTION');
    let worst = 0;
    a.forEach((line, i) => {
      const x = line.trim().split(/\s+/);
      const y = b[i].trim().split(/\s+/);
      expect(x.length, `line ${i + 1}`).toBe(y.length);
      const isOffset = x[0] === 'OFFSET';
      const isFrame = i > motionStart + 2;
      x.forEach((tok, k) => {
        const [u, v] = [Number(tok), Number(y[k])];
        if (Number.isNaN(u)) return expect(tok, `line ${i + 1}`).toBe(y[k]);
        const length = isOffset || (isFrame && k < 3); // OFFSETs and the root position channels
        worst = Math.max(worst, length ? Math.abs(u * 100 - v) : Math.abs(u - v));
      });
    });
    expect(worst, 'cm vs m×100 (4 vs 6 decimals written)').toBeLessThanOrEqual(1e-4 + 1e-9);
    for (const l of a.filter((l) => l.includes('OFFSET'))) expect(l).toMatch(/^\s*OFFSET( -?\d+\.\d{6}){3}$/); // 1 µm in metres too
  });

  it('names the unit in the file name and refuses other units', () => {
    expect(bvhFileName('emdm-a-person-walks-seed7')).toBe('emdm-a-person-walks-seed7-metres.bvh');
    expect(bvhFileName('emdm-a-person-walks-seed7', 'cm')).toBe('emdm-a-person-walks-seed7-centimetres.bvh');
    expect(() => writeBVH(posedMotion(2), sk, { units: 'mm' as 'm' })).toThrow(/units must be 'm' or 'cm', got mm/);
  });
});
