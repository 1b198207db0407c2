import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { writeBVH } from '../../src/export/bvh';
import { forwardKinematics, solveIK } from '../../src/motion/ik';
import { PARITY_DIR, fixtureExists, loadCase, manifestSkeleton, maxAbsDiff, maxJointDist, modelFixtures, randomPoseQuats } from './coreFixtures';

const sk = manifestSkeleton();
const J = sk.joints.length;

function restJoints(frames: number): Float32Array {
  const q = new Float32Array(frames * J * 4);
  for (let i = 3; i < q.length; i += 4) q[i] = 1;
  const root = new Float32Array(frames * 3);
  for (let f = 0; f < frames; f++) root.set(sk.offsets[0], f * 3);
  return forwardKinematics(root, q, frames, sk);
}

describe('IK (joints → root + local quaternions with twist from body planes)', () => {
  it('the rest pose gives identity rotations', () => {
    const { quats } = solveIK(restJoints(1), 1, sk);
    for (let j = 0; j < J; j++) expect(Math.abs(quats[4 * j + 3]), sk.joints[j]).toBeGreaterThan(1 - 1e-9);
  });

  it('FK(IK(joints)) reproduces posed joints of the reference skeleton within 1 mm', () => {
    const frames = 30;
    const root = new Float32Array(frames * 3);
    for (let f = 0; f < frames; f++) root.set([0.02 * f, 0.9, -0.01 * f], f * 3);
    const joints = forwardKinematics(root, randomPoseQuats(frames, J, 11), frames, sk);
    const ik = solveIK(joints, frames, sk);
    expect(maxJointDist(forwardKinematics(ik.rootPos, ik.quats, frames, sk, ik.offsets), joints)).toBeLessThan(1e-3);
    // joints made by the reference skeleton itself: the adapted offsets equal the reference ones
    ik.offsets.forEach((o, j) => o.forEach((v, c) => expect(v).toBeCloseTo(sk.offsets[j][c], 6)));
  });

  it('turning the whole body 90° about Y turns the pelvis by 90° and leaves the rest local', () => {
    const frames = 1;
    const q = new Float32Array(J * 4);
    for (let j = 0; j < J; j++) q[4 * j + 3] = 1;
    q.set([0, Math.SQRT1_2, 0, Math.SQRT1_2], 0);
    const joints = forwardKinematics(Float32Array.from(sk.offsets[0]), q, frames, sk);
    const ik = solveIK(joints, frames, sk);
    [0, Math.SQRT1_2, 0, Math.SQRT1_2].forEach((v, c) => expect(ik.quats[c]).toBeCloseTo(v, 5));
    for (let j = 1; j < J; j++) expect(Math.abs(ik.quats[4 * j + 3]), sk.joints[j]).toBeGreaterThan(1 - 1e-6);
  });

  it('a bent knee and elbow become pure hinges (no twist in the child joint)', () => {
    const frames = 1;
    const q = new Float32Array(J * 4);
    for (let j = 0; j < J; j++) q[4 * j + 3] = 1;
    const knee = sk.joints.indexOf('l_knee');
    const hip = sk.joints.indexOf('l_hip');
    const elbow = sk.joints.indexOf('r_elbow');
    const a = 0.6;
    q.set([Math.sin(a / 2), 0, 0, Math.cos(a / 2)], knee * 4); // flex about X
    q.set([0, 0.3, 0.1, 1].map((v, i) => (i < 3 ? v : Math.sqrt(1 - 0.1))) as number[], hip * 4); // hip swing + twist
    q.set([0, Math.sin(0.5), 0, Math.cos(0.5)], elbow * 4); // flex about Y (right arm hinge axis)
    const joints = forwardKinematics(Float32Array.from(sk.offsets[0]), q, frames, sk);
    const ik = solveIK(joints, frames, sk);
    // the knee turns only about the rest leg's own bend normal (hinge), never twists
    const k = Array.from(ik.quats.slice(knee * 4, knee * 4 + 4));
    const [o1, o2] = [sk.offsets[knee], sk.offsets[sk.joints.indexOf('l_ankle')]];
    const c0 = [o1[1] * o2[2] - o1[2] * o2[1], o1[2] * o2[0] - o1[0] * o2[2], o1[0] * o2[1] - o1[1] * o2[0]];
    const cx = [k[1] * c0[2] - k[2] * c0[1], k[2] * c0[0] - k[0] * c0[2], k[0] * c0[1] - k[1] * c0[0]];
    expect(Math.hypot(...cx) / Math.hypot(...c0)).toBeLessThan(1e-6);
    expect(2 * Math.acos(Math.abs(k[3]))).toBeGreaterThan(a - 0.15);
    const e = Array.from(ik.quats.slice(elbow * 4, elbow * 4 + 4));
    expect(Math.abs(e[0])).toBeLessThan(1e-6);
    expect(Math.abs(e[2])).toBeLessThan(1e-6);
    // and the hip's twist is recovered from the knee's bend plane
    expect(maxJointDist(forwardKinematics(ik.rootPos, ik.quats, frames, sk), joints)).toBeLessThan(1e-5);
  });

  it('twist stays continuous when a limb straightens (no 180° flips between frames)', () => {
    const frames = 40;
    const root = new Float32Array(frames * 3);
    const q = new Float32Array(frames * J * 4);
    const knee = sk.joints.indexOf('r_knee');
    for (let f = 0; f < frames; f++) {
      root.set(sk.offsets[0], f * 3);
      for (let j = 0; j < J; j++) q[(f * J + j) * 4 + 3] = 1;
      const a = 0.3 * (1 + Math.cos((f / frames) * 2 * Math.PI)) - 0.13; // bent → straight (the rest leg is bent ~0.13 rad) → bent
      q.set([Math.sin(a / 2), 0, 0, Math.cos(a / 2)], (f * J + knee) * 4);
    }
    const ik = solveIK(forwardKinematics(root, q, frames, sk), frames, sk);
    for (let f = 1; f < frames; f++) {
      for (let j = 0; j < J; j++) {
        let d = 0;
        for (let c = 0; c < 4; c++) d += ik.quats[(f * J + j) * 4 + c] * ik.quats[((f - 1) * J + j) * 4 + c];
        expect(d, `${sk.joints[j]} frame ${f}`).toBeGreaterThan(Math.cos(0.35 / 2)); // < 0.35 rad per frame
      }
    }
  });

  it('FK(IK(joints)) is within 1 cm on a real clip (recover fixture)', (ctx) => {
    if (!fixtureExists('recover')) return ctx.skip('tests/fixtures/parity/recover.json absent: run `python -m emdm.fixtures` after preparing the dataset');
    const fx = loadCase('recover');
    const joints = fx.get('joints');
    const frames = fx.meta.frames;
    const ref = solveIK(joints, frames, sk, { adaptOffsets: false });
    const ik = solveIK(joints, frames, sk);
    const errRef = maxJointDist(forwardKinematics(ref.rootPos, ref.quats, frames, sk), joints);
    const err = maxJointDist(forwardKinematics(ik.rootPos, ik.quats, frames, sk, ik.offsets), joints);
    // the retargeted clip's pelvis/chest geometry differs from the reference rest pose (cm-level);
    // the adapted offsets absorb it
    expect(errRef).toBeGreaterThan(0.01);
    expect(err).toBeLessThan(0.01);
  });

  const generated = modelFixtures();
  if (!generated.length) it.skip('FK(IK(joints)) on generated motions: no model parity fixtures yet (run `python -m emdm.fixtures`)', () => {});
  for (const name of generated) {
    it(`FK(IK(joints)) follows a generated motion up to its own non-rigidity (${name})`, () => {
      // Generated joints are not a rigid skeleton: bone lengths vary over a motion, and so does the shape
      // of the bodies a joint with several children forms with them (pelvis with the hips and spine1,
      // spine3 with the neck and collars), which no rigid rig can follow. With each bone pointing the
      // right way, a joint can be off by at most the summed length differences of the bones on its chain
      // (triangle inequality), plus, below a multi-child joint, how far that body is from the rig's (the
      // change in the child's distance to its siblings: the parent's rotation splits the difference); the
      // bar is that bound + 1 cm for 95% of joint-frames.
      const fx = loadCase(name);
      const joints = fx.get('joints');
      const frames = fx.meta.frames;
      const ik = solveIK(joints, frames, sk);
      const fk = forwardKinematics(ik.rootPos, ik.quats, frames, sk, ik.offsets);
      const rigLen = ik.offsets.map((o) => Math.hypot(o[0], o[1], o[2]));
      const dist = (a: ArrayLike<number>, i: number, k: number) => Math.hypot(a[i] - a[k], a[i + 1] - a[k + 1], a[i + 2] - a[k + 2]);
      // per joint: its siblings s and their distance on the rig (constant over the motion)
      const siblings = sk.parents.map((p, j) => sk.parents.flatMap((q, s) => (j > 0 && s !== j && q === p
        ? [{ s, rig: Math.hypot(...[0, 1, 2].map((c) => ik.offsets[j][c] - ik.offsets[s][c])) }] : [])));
      let within = 0;
      let total = 0;
      for (let f = 0; f < frames; f++) {
        const base = f * J * 3;
        const slack = new Array<number>(J).fill(0);
        for (let j = 1; j < J; j++) {
          const p = sk.parents[j];
          const len = dist(joints, base + 3 * j, base + 3 * p);
          const shape = Math.max(0, ...siblings[j].map(({ s, rig }) => Math.abs(dist(joints, base + 3 * j, base + 3 * s) - rig)));
          slack[j] = slack[p] + Math.abs(len - rigLen[j]) + shape;      // parents precede children (SMPL order)
        }
        for (let j = 0; j < J; j++) {
          const i = base + 3 * j;
          const d = Math.hypot(fk[i] - joints[i], fk[i + 1] - joints[i + 1], fk[i + 2] - joints[i + 2]);
          within += d <= slack[j] + 0.01 ? 1 : 0;
          total += 1;
        }
      }
      expect(within / total, 'joint-frames within their bone-length slack + 1 cm').toBeGreaterThanOrEqual(0.95);
      // what remains is the motion's own non-rigidity: on its rigid version FK(IK(·)) is exact
      const ik2 = solveIK(fk, frames, { ...sk, offsets: ik.offsets });
      expect(maxJointDist(forwardKinematics(ik2.rootPos, ik2.quats, frames, sk, ik2.offsets), fk)).toBeLessThan(1e-3);
    });
  }
});

/** Angle (radians) between two unit quaternions, well conditioned near 0: 2·atan2(|a − b|, |a + b|), b sign-aligned. */
function quatAngle(a: ArrayLike<number>, b: ArrayLike<number>): number {
  const s = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3] < 0 ? -1 : 1;
  let d = 0;
  let m = 0;
  for (let c = 0; c < 4; c++) {
    d += (a[c] - s * b[c]) ** 2;
    m += (a[c] + s * b[c]) ** 2;
  }
  return 2 * Math.atan2(Math.sqrt(d), Math.sqrt(m));
}

// tests/fixtures/parity/ik.* is written by `python -m emdm.motion.ik_fixture` (emdm.motion.ik.solve_ik and
// emdm.mocap.bvh_writer): the BVH of `emdm.sample` and of the page must come from the same IK.
describe('the same IK as Python (emdm.motion.ik, fixture tests/fixtures/parity/ik.*)', () => {
  const fx = loadCase('ik');
  const cases = fx.meta.cases as Record<string, { frames: number; source: string }>;

  for (const [name, { frames }] of Object.entries(cases)) {
    it(`solveIK gives Python's local rotations, root and offsets (${name}, ${frames} frames)`, () => {
      const ik = solveIK(fx.get(`${name}_joints`), frames, sk);
      const want = fx.get(`${name}_quats`);
      let worst = 0;
      for (let i = 0; i < want.length; i += 4) worst = Math.max(worst, quatAngle(ik.quats.subarray(i, i + 4), want.subarray(i, i + 4)));
      // float32 storage on both sides (~1e-7 rad); a changed rule (e.g. no twist, another bend blend) is ≥ 1e-2
      expect(worst, `max angle difference, rad`).toBeLessThan(2e-6);
      expect(maxAbsDiff(ik.rootPos, fx.get(`${name}_root`))).toBeLessThan(1e-7);
      expect(maxAbsDiff(ik.offsets.flat(), fx.get(`${name}_offsets`))).toBeLessThan(1e-6);
    });
  }

  it("writeBVH writes Python's BVH (emdm.mocap.bvh_writer) line for line, numbers within rounding", () => {
    const name = fx.meta.bvhCase as string;
    const frames = cases[name].frames;
    const mine = writeBVH({ frames, fps: fx.meta.fps as number, joints: fx.get(`${name}_joints`), features: new Float32Array(0) }, sk, { units: 'cm' }).split('\n'); // ik.bvh is in cm (ik_fixture)
    const theirs = fs.readFileSync(path.join(PARITY_DIR, fx.meta.bvh as string), 'utf8').split('\n');
    expect(mine.length).toBe(theirs.length);
    let worst = 0;
    mine.forEach((line, i) => {
      const a = line.trim().split(/\s+/);
      const b = theirs[i].trim().split(/\s+/);
      expect(a.length, `line ${i + 1}`).toBe(b.length);
      a.forEach((tok, k) => {
        const [x, y] = [Number(tok), Number(b[k])];
        if (Number.isNaN(x) || Number.isNaN(y)) expect(tok, `line ${i + 1}`).toBe(b[k]);
        else worst = Math.max(worst, Math.abs(x - y));
      });
    });
    expect(worst, 'largest difference of a number (cm or degrees, 4 decimals written)').toBeLessThanOrEqual(2e-4);
  });
});
