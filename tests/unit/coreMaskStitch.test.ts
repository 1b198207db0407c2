// Continuing a motion (src/motion/stitch.ts): a real clip (the recover parity fixture) cut into two segments
// whose overlap frames are the same features — as a segment inpainted from the previous one's last frames is —
// each recovered on its own from the origin, then stitched.
import { describe, expect, it } from 'vitest';
import { recoverJoints } from '../../src/motion/recover';
import { alignSegment, appendSegment, headingAt, pinKeptRoot, pinRoot, rootPose } from '../../src/motion/stitch';
import { keepMask, parseKeep } from '../../src/sampler/mask';
import { fixtureExists, loadCase, maxAbsDiff } from './coreFixtures';

const D = 263;
const J3 = 22 * 3;
const real = loadCase('recover').get('features'); // (120, 263)
const F = real.length / D;
const rows = (f: Float32Array, a: number, b: number) => f.subarray(a * D, b * D);
const concat = (...parts: Float32Array[]) => {
  const out = new Float32Array(parts.reduce((n, p) => n + p.length, 0));
  let o = 0;
  for (const p of parts) out.set(p, (o += p.length) - p.length);
  return out;
};
const wrap = (a: number) => Math.atan2(Math.sin(a), Math.cos(a));
const rootStep = (j: Float32Array, f: number) => Math.hypot(j[(f + 1) * J3] - j[f * J3], j[(f + 1) * J3 + 2] - j[f * J3 + 2]);

describe('stitching a continued segment', () => {
  const cut = 70;
  const overlap = 20;
  const prev = recoverJoints(rows(real, 0, cut), cut);

  it('puts a real clip cut in two back together (≤ 0.1 mm), the overlap on the previous frames', () => {
    const whole = recoverJoints(real, F);
    const next = recoverJoints(rows(real, cut - overlap, F), F - cut + overlap);
    expect(Math.hypot(next[0] - whole[50 * J3], next[2] - whole[50 * J3 + 2])).toBeGreaterThan(0.1); // it starts elsewhere
    const joined = appendSegment(prev, cut, next, F - cut + overlap, overlap);
    expect(joined.frames).toBe(F);
    expect(maxAbsDiff(joined.joints, whole)).toBeLessThan(1e-4);
    const aligned = alignSegment(prev, cut, next, F - cut + overlap, overlap);
    expect(maxAbsDiff(aligned.subarray(0, overlap * J3), prev.subarray((cut - overlap) * J3))).toBeLessThan(1e-4);
  });

  it('no jump in root position or heading at the seam when the segment goes on differently', () => {
    // after the overlap: a generated motion's features (the emdm-t2m-web parity run), else the clip's start
    const other = fixtureExists('model-emdm-t2m-web') ? loadCase('model-emdm-t2m-web').get('features') : rows(real, 0, 40);
    const nextFeatures = concat(rows(real, cut - overlap, cut), other);
    const nF = nextFeatures.length / D;
    const next = recoverJoints(nextFeatures, nF);
    const { joints, frames } = appendSegment(prev, cut, next, nF, overlap);
    const seam = cut - 1; // from prev's last frame to the first new one
    const steps = Array.from({ length: frames - 1 }, (_, f) => rootStep(joints, f)).filter((_, f) => f !== seam).sort((a, b) => a - b);
    expect(rootStep(joints, seam)).toBeLessThanOrEqual(1.5 * steps[Math.floor(0.95 * steps.length)] + 1e-3);
    expect(Math.abs(wrap(headingAt(joints, seam + 1) - headingAt(joints, seam)))).toBeLessThan(0.05);
    // without stitching the new segment restarts at the origin facing +Z: a jump of both
    const naive = concat(prev, next.subarray(overlap * J3));
    expect(rootStep(naive, seam)).toBeGreaterThan(10 * Math.max(rootStep(joints, seam), 1e-2));
    expect(Math.abs(wrap(headingAt(naive, seam + 1) - headingAt(naive, seam)))).toBeGreaterThan(1);
  });

  it('refuses a bad overlap or a wrong size', () => {
    const next = recoverJoints(rows(real, 50, F), F - 50);
    expect(() => alignSegment(prev, cut, next, F - 50, 0)).toThrow(/overlap must be an integer in 1…70/);
    expect(() => alignSegment(prev, cut + 1, next, F - 50, 5)).toThrow(/prev: 4620 values, expected frames \(71\) × 22 × 3/);
  });
});

describe('pinning the kept end of an in-between', () => {
  it('puts the kept frames back where the known motion has them (≤ 1 mm); only the free frames\' root channels change', () => {
    // keep frames 0..29 and 70..119 of the real clip; the middle is another motion
    const other = fixtureExists('model-emdm-t2m-web') ? loadCase('model-emdm-t2m-web').get('features').subarray(0, 40 * D) : rows(real, 0, 40);
    const inb = concat(rows(real, 0, 30), other, rows(real, 70, F));
    const want = recoverJoints(real, F);
    expect(maxAbsDiff(recoverJoints(inb, F).subarray(70 * J3), want.subarray(70 * J3))).toBeGreaterThan(0.1);
    const pinned = pinRoot(inb, F, [30, 70], 70, rootPose(real, F, 70));
    const got = recoverJoints(pinned, F);
    expect(maxAbsDiff(got.subarray(0, 30 * J3), want.subarray(0, 30 * J3))).toBe(0);
    expect(maxAbsDiff(got.subarray(70 * J3), want.subarray(70 * J3))).toBeLessThan(1e-3);
    for (let i = 0; i < inb.length; i++) {
      if (pinned[i] !== inb[i]) {
        expect(i % D).toBeLessThan(3);
        expect(Math.floor(i / D)).toBeGreaterThanOrEqual(30);
        expect(Math.floor(i / D)).toBeLessThan(70);
      }
    }
    const realSteps = Array.from({ length: F - 1 }, (_, f) => rootStep(want, f)).sort((a, b) => a - b);
    for (let f = 0; f < F - 1; f++) expect(rootStep(got, f)).toBeLessThanOrEqual(1.5 * realSteps[Math.floor(0.95 * realSteps.length)]);
    expect(() => pinRoot(inb, F, [30, 71], 70, { x: 0, z: 0, heading: 0 })).toThrow(/free frames \[30, 71\) must be a non-empty range ending at or before frame 70/);
  });

  it('pinKeptRoot finds the free stretch from the mask and pins the next kept frame (= pinRoot)', () => {
    const other = rows(real, 0, 40);
    const inb = concat(rows(real, 0, 30), other, rows(real, 70, F));
    const keep = keepMask(F, [parseKeep('frames:0-29,70-'), parseKeep('group:legs,upper')]);
    const byMask = pinKeptRoot(inb, F, keep, real);
    expect(maxAbsDiff(byMask, pinRoot(inb, F, [30, 70], 70, rootPose(real, F, 70)))).toBe(0);
    expect(maxAbsDiff(recoverJoints(byMask, F).subarray(70 * J3), recoverJoints(real, F).subarray(70 * J3))).toBeLessThan(1e-3);
    // nothing kept after the free frames (a continuation): nothing to pin
    const prefix = keepMask(F, [parseKeep('frames:0-29')]);
    expect(maxAbsDiff(pinKeptRoot(inb, F, prefix, real), inb)).toBe(0);
  });

  it('rootPose is the root recoverJoints integrates', () => {
    const j = recoverJoints(real, F);
    for (const t of [0, 1, 37, F - 1]) {
      const p = rootPose(real, F, t);
      expect(Math.abs(p.x - j[t * J3]) + Math.abs(p.z - j[t * J3 + 2])).toBeLessThan(1e-5);
      expect(Math.abs(wrap(p.heading - headingAt(j, t)))).toBeLessThan(1e-3);
    }
  });
});
