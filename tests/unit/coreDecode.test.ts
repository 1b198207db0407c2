import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { cleanupFootContacts, contactsFromFeatures, footSkate, plantContacts, plantRuns } from '../../src/motion/footContact';
import { forwardKinematics } from '../../src/motion/ik';
import { denormalize, parseMeanStd, recoverJoints } from '../../src/motion/recover';
import { smoothJoints } from '../../src/motion/smooth';
import { ROOT, fixtureExists, loadCase, modelFixtures, manifestSkeleton, maxJointDist, randomPoseQuats } from './coreFixtures';

const sk = manifestSkeleton();
const J = 22;

describe('recover joints (port of emdm.motion.features.recover_joints)', () => {
  it('equals Python on a real clip within 1e-5 m', (ctx) => {
    if (!fixtureExists('recover')) return ctx.skip('tests/fixtures/parity/recover.json absent: prepare the dataset, then run `python -m emdm.fixtures`');
    const fx = loadCase('recover');
    const joints = recoverJoints(fx.get('features'), fx.meta.frames);
    expect(maxJointDist(joints, fx.get('joints'))).toBeLessThan(1e-5);
  });

  it('equals the data engineer\'s committed fixture (tests/fixtures/data/recover_joints.json) within 1e-5 m', () => {
    const p = path.join(ROOT, 'tests', 'fixtures', 'data', 'recover_joints.json');
    const fx = JSON.parse(fs.readFileSync(p, 'utf8')) as { features: number[][]; joints: number[][][] };
    const frames = fx.features.length;
    const joints = recoverJoints(Float32Array.from(fx.features.flat()), frames);
    expect(maxJointDist(joints, fx.joints.flat(2))).toBeLessThan(1e-5);
  });

  it('integrates heading and root velocity (a quarter turn while walking forward)', () => {
    const frames = 11;
    const f = new Float32Array(frames * 263);
    for (let t = 0; t < frames; t++) {
      f[t * 263 + 0] = -Math.PI / 4 / 10; // half-angle convention: θ grows by π/2 over 10 frames
      f[t * 263 + 2] = 0.1; // forward (root-frame +Z) 10 cm per frame
      f[t * 263 + 3] = 0.9;
      f[t * 263 + 4 + 2] = 0.2; // joint 1 20 cm in front of the root
    }
    const j = recoverJoints(f, frames);
    const last = (frames - 1) * J * 3;
    // after 10 frames facing has turned +90° (towards +X): joint 1 is 20 cm along +X from the root
    expect(j[last + 3] - j[last]).toBeCloseTo(0.2, 5);
    expect(j[last + 5] - j[last + 2]).toBeCloseTo(0, 5);
    expect(j[last + 1]).toBeCloseTo(0.9, 6);
  });

  it('de-normalises with mean/std and parses the manifest meanStd layout', () => {
    const buf = new ArrayBuffer(2 * 3 * 4);
    const dv = new DataView(buf);
    [1, 2, 3, 10, 20, 30].forEach((v, i) => dv.setFloat32(4 * i, v, true));
    const { mean, std } = parseMeanStd(buf, 3, 'm.meanstd.f32');
    expect(Array.from(denormalize(Float32Array.from([1, 1, 1, 0, 0, -1]), mean, std))).toEqual([11, 22, 33, 1, 2, -27]);
    expect(() => parseMeanStd(new ArrayBuffer(8), 3, 'm.meanstd.f32')).toThrow(/m\.meanstd\.f32: 8 bytes, expected 24/);
  });
});

describe('smoothing and foot-contact clean-up', () => {
  it('smoothing removes jitter but keeps a steady motion', () => {
    const frames = 50;
    const x = new Float32Array(frames);
    for (let f = 0; f < frames; f++) x[f] = 0.01 * f + (f % 2 ? 0.005 : -0.005);
    const s = smoothJoints(x, frames, 1.5);
    let jitter = 0;
    for (let f = 10; f < 40; f++) jitter = Math.max(jitter, Math.abs(s[f] - 0.01 * f));
    expect(jitter).toBeLessThan(0.001);
    expect(smoothJoints(x, frames, 0)).toEqual(x);
  });

  function skatingWalk(frames: number) {
    // standing pose translated forward; the left foot "skates" forward while marked in contact
    const root = new Float32Array(frames * 3);
    for (let f = 0; f < frames; f++) root.set([0, 0.88, 0.004 * f], f * 3);
    const q = randomPoseQuats(frames, J, 5, 0.05);
    for (let f = 0; f < frames; f++) {
      for (const knee of [4, 5]) q.set([Math.sin(0.25), 0, 0, Math.cos(0.25)], (f * J + knee) * 4); // knees bent 0.5 rad
    }
    const joints = forwardKinematics(root, q, frames, sk);
    for (let f = 0; f < frames; f++) joints[(f * J + sk.footJoints[1]) * 3 + 1] -= 0.03; // left ball sinks 3 cm
    const contacts = new Float32Array(frames * 4);
    for (let f = 5; f < 25; f++) contacts[f * 4] = contacts[f * 4 + 1] = 1;
    return { joints, contacts };
  }

  it('pins feet in contact (no skating), keeps them above the floor and the leg bones rigid', () => {
    const frames = 30;
    const { joints, contacts } = skatingWalk(frames);
    const rig = { parents: sk.parents, footJoints: sk.footJoints };
    const before = footSkate(joints, frames, contacts, rig);
    const out = cleanupFootContacts(joints, frames, contacts, rig);
    expect(before).toBeGreaterThan(0.003);
    expect(footSkate(out, frames, contacts, rig)).toBeLessThan(1e-4); // < 0.1 mm per frame (was > 3 mm)
    let minY = Infinity;
    for (let f = 0; f < frames; f++) for (const j of sk.footJoints) minY = Math.min(minY, out[(f * J + j) * 3 + 1]);
    expect(minY).toBeGreaterThan(-1e-6);
    const len = (a: Float32Array, f: number, i: number, k: number) =>
      Math.hypot(...[0, 1, 2].map((c) => a[(f * J + i) * 3 + c] - a[(f * J + k) * 3 + c]));
    const [hip, knee, ankle] = [1, 4, 7];
    for (let f = 0; f < frames; f++) {
      expect(len(out, f, hip, knee)).toBeCloseTo(len(joints, f, hip, knee), 5);
      expect(len(out, f, knee, ankle)).toBeCloseTo(len(joints, f, knee, ankle), 5);
    }
  });

  it('hands a foot over between two plants a short swing apart without a jump; a plant keeps its own pin (as Python)', () => {
    // the case of tests/python/test_motion_decode.py: planted at z 0 (frames 4–9), a 4-frame swing, planted at z 1.2
    const frames = 24;
    const joints = new Float32Array(frames * J * 3);
    const z = (f: number) => (f < 10 ? 0 : f < 14 ? 0.24 * (f - 9) : 1.2);
    for (let f = 0; f < frames; f++) {
      for (let j = 0; j < J; j++) joints.set([0, 0.9, z(f)], (f * J + j) * 3);
      for (const j of [4, 5]) joints[(f * J + j) * 3 + 1] = 0.5;
      for (const j of sk.footJoints) joints[(f * J + j) * 3 + 1] = 0.02;
      for (const j of [10, 11]) joints[(f * J + j) * 3 + 2] += 0.15;
      for (const j of [7, 10]) joints[(f * J + j) * 3 + 2] += 0.01 * Math.sin(f);
    }
    const contacts = new Float32Array(frames * 4);
    for (const f of [4, 5, 6, 7, 8, 9, 14, 15, 16, 17, 18, 19]) contacts[f * 4] = contacts[f * 4 + 1] = 1;
    const rig = { parents: sk.parents, footJoints: sk.footJoints };
    const zOf = (a: Float32Array, f: number) => a[(f * J + 7) * 3 + 2];
    const out = cleanupFootContacts(joints, frames, contacts, rig);
    let step = 0;
    for (let f = 1; f < frames; f++) step = Math.max(step, Math.abs(zOf(out, f) - zOf(out, f - 1)));
    expect(step).toBeLessThan(0.45); // switching from one target to the other: 0.70
    const wide = cleanupFootContacts(joints, frames, contacts, rig, { blend: 6 });
    for (const [s, e, at] of [[4, 9, 0], [14, 19, 1.2]]) {
      for (let f = s; f <= e; f++) expect(Math.abs(zOf(wide, f) - zOf(wide, s))).toBeLessThan(1e-5);
      expect(Math.abs(zOf(wide, s) - at)).toBeLessThan(0.02);
    }
  });

  it('reduces skating on a generated motion (model fixture)', (ctx) => {
    const name = modelFixtures()[0];
    if (!name) return ctx.skip('no model parity fixture yet: run `python -m emdm.fixtures` once models are shipped');
    const fx = loadCase(name);
    const frames = fx.meta.frames;
    const joints = fx.get('joints');
    const contacts = contactsFromFeatures(fx.get('features'), frames);
    const rig = { parents: sk.parents, footJoints: sk.footJoints };
    const out = cleanupFootContacts(joints, frames, contacts, rig);
    // on the runs that are plants (the foot strays ≤ 10 cm, a stance ≤ 20 cm): held still; the rest is the model's own
    const planted = plantContacts(joints, frames, contacts, rig);
    expect(footSkate(out, frames, planted, rig)).toBeLessThan(1e-3);
    expect(footSkate(out, frames, planted, rig)).toBeLessThanOrEqual(footSkate(joints, frames, planted, rig) * 0.5 + 1e-6);
  });

  it('leaves a sliding "contact" alone instead of holding the foot and throwing it a metre (flickering runs joined)', () => {
    const frames = 30;
    const { joints } = skatingWalk(frames);
    const rig = { parents: sk.parents, footJoints: sk.footJoints };
    // the left foot slides 8 cm a frame (a walk) while the model says "contact", with a one-frame flicker
    for (let f = 0; f < frames; f++) for (const j of [7, 10]) joints[(f * J + j) * 3 + 2] += 0.08 * f;
    const contacts = new Float32Array(frames * 4);
    for (let f = 5; f < 25; f++) if (f !== 14) contacts[f * 4] = contacts[f * 4 + 1] = 1;
    const out = cleanupFootContacts(joints, frames, contacts, rig);
    let worst = 0;
    for (let f = 1; f < frames; f++) worst = Math.max(worst, Math.abs(out[(f * J + 7) * 3 + 2] - out[((f - 1) * J + 7) * 3 + 2]));
    expect(worst).toBeLessThan(0.1); // the foot keeps its own 8 cm steps (pinned: held, then 0.7 m in one frame)
    expect(Array.from(plantContacts(joints, frames, contacts, rig)).every((v) => v === 0)).toBe(true);
    // a real plant with the same flicker is one run, pinned through the flicker
    const still = skatingWalk(frames);
    const out2 = cleanupFootContacts(still.joints, frames, contacts, rig);
    expect(footSkate(out2, frames, plantContacts(still.joints, frames, contacts, rig), rig)).toBeLessThan(1e-4);
    expect(Math.abs(out2[(14 * J + 7) * 3 + 2] - out2[(13 * J + 7) * 3 + 2])).toBeLessThan(1e-6);
  });
  /** A run as the model makes it (twin of test_motion_decode.py ``sliding_run``): the body travels 3.8 m/s, the left
   *  foot swings 0.3 m a frame and, in its stances (frames 4–9, 14–19, contacts on), still slides 5 cm a frame. */
  function slidingRun(frames = 24) {
    const joints = new Float32Array(frames * J * 3);
    const z: number[] = [];
    for (let k = 0, at = 0; k < frames; k++) {
      z.push(at);
      at += (k >= 4 && k < 9) || (k >= 14 && k < 19) ? 0.05 : 0.3;
    }
    for (let f = 0; f < frames; f++) {
      const body = (z[frames - 1] * f) / (frames - 1);
      for (let j = 0; j < J; j++) joints.set([0, 0.9, body], (f * J + j) * 3);
      for (const j of [4, 5]) joints[(f * J + j) * 3 + 1] = 0.5;
      for (const j of sk.footJoints) joints[(f * J + j) * 3 + 1] = 0.02;
      joints[(f * J + 7) * 3 + 2] = z[f];
      joints[(f * J + 10) * 3 + 2] = z[f] + 0.15;
    }
    const contacts = new Float32Array(frames * 4);
    for (let f = 0; f < frames; f++) if ((f >= 4 && f <= 9) || (f >= 14 && f <= 19)) contacts[f * 4] = contacts[f * 4 + 1] = 1;
    return { joints, contacts };
  }

  it("holds a run's stance that slides 25 cm (a stance may stray 20 cm, a longer contact 10 cm), as Python", () => {
    const rig = { parents: sk.parents, footJoints: sk.footJoints };
    const { joints, contacts } = slidingRun();
    const spans = (o = {}) => plantRuns(joints, 24, contacts, rig, o)[0].map(({ first, last }) => [first, last]);
    expect(spans({ stanceDrift: 0.1 })).toEqual([]); // the 10 cm limit of before left it sliding
    expect(spans()).toEqual([[4, 9], [14, 19]]);
    const out = cleanupFootContacts(joints, 24, contacts, rig);
    const z = (a: Float32Array, f: number) => a[(f * J + 7) * 3 + 2];
    for (const [s, e] of [[4, 9], [14, 19]]) {
      const held = Array.from({ length: e - s + 1 }, (_, i) => z(out, s + i));
      expect(Math.max(...held) - Math.min(...held)).toBeLessThan(0.01); // raw: 25 cm
    }
    const slid = cleanupFootContacts(joints, 24, contacts, rig, { stanceDrift: 0.1 }); // the option is passed through
    expect(Math.max(...[4, 5, 6, 7, 8, 9].map((f) => z(slid, f))) - Math.min(...[4, 5, 6, 7, 8, 9].map((f) => z(slid, f)))).toBeGreaterThan(0.2);
    let step = 0;
    for (let f = 1; f < 24; f++) step = Math.max(step, Math.hypot(...[0, 1, 2].map((c) => out[(f * J + 7) * 3 + c] - out[((f - 1) * J + 7) * 3 + c])));
    expect(step).toBeLessThan(0.65); // the swing makes up the 25 cm it no longer slides: 0.30 → up to 0.60
    // a pivot over 3 s (60 frames, 30 cm) is the body moving its foot: not held; the same 30 cm within 20 frames is
    const pivot = (n: number) => {
      const j = new Float32Array(n * J * 3);
      for (let f = 0; f < n; f++) {
        for (let k = 0; k < J; k++) j[(f * J + k) * 3 + 1] = 0.9;
        for (const k of sk.footJoints) j[(f * J + k) * 3 + 1] = 0.02;
        for (const k of [7, 10]) j[(f * J + k) * 3 + 2] = (0.3 * f) / (n - 1);
      }
      return plantRuns(j, n, new Float32Array(n * 4).fill(1), rig)[0].map(({ first, last }) => [first, last]);
    };
    expect(pivot(60)).toEqual([]);
    expect(pivot(20)).toEqual([[0, 19]]);
  });
});
