import { AnimationMixer, type Bone, LoopOnce } from 'three';
import { BVHLoader } from 'three/examples/jsm/loaders/BVHLoader.js';
import { describe, expect, it } from 'vitest';
import { writeBVH } from '../../src/export/bvh';
import { forwardKinematics } from '../../src/motion/ik';
import type { Motion } from '../../src/motion/types';
import { fixtureExists, loadCase, manifestSkeleton, randomPoseQuats } from './coreFixtures';

const sk = manifestSkeleton();
const J = sk.joints.length;

/** World joint positions (metres) of a BVH text at a given frame index, as three.js reads it. */
function bvhPositions(text: string, frameTimes: number[]): Float32Array[] {
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
      out.set([p.x / 100, p.y / 100, p.z / 100], j * 3);
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
    const text = writeBVH(m, sk, { fps: 60 });
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
});
