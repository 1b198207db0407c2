/**
 * Foot-contact clean-up: the model predicts per-frame contacts for l_ankle, l_foot, r_ankle, r_foot
 * (features [259:263]); where a joint is in contact it should neither skate nor sink.
 *
 *  1. Floor: each frame whose lowest foot joint is below y = 0 is lifted as a whole by that depth.
 *  2. Pinning: every contact run (≥ 2 frames with contact > 0.5, gaps of up to `gap` frames closed:
 *     the model's contacts flicker) of a foot joint is held at the run's mean position (y clamped to
 *     ≥ 0); the correction fades in/out over `blend` frames on both sides (smoothstep), so there are no
 *     pops; where a fade-out and the next plant's fade-in overlap, the target is their weighted mean. A
 *     run whose joint strays more than `maxDrift` m (horizontally) from that mean is no plant but a contact the model got wrong (a foot sliding at walking speed): pinning it would hold the
 *     foot and then throw it up to a metre in one frame, so it is left as it is. A *stance* (a run of at most
 *     `stanceFrames` frames: a step's foot is down for under a second) may stray up to `stanceDrift` m: generated
 *     runs' stances slide 20–40 cm (the model's runs outpace their strides), which 10 cm left sliding (runs' foot
 *     skate 94 cm/s, real 37; 47 with it, no joint step past the real clips' largest). A longer contact that strays
 *     is the body moving its foot (a pivot, a shuffle); held, its leg could not reach and the foot was dragged.
 *  3. Legs follow: a moved ankle re-solves its knee with two-bone IK (hip fixed, thigh and shin
 *     lengths of that frame kept, bending in the original knee's plane); the ball-of-foot joint is
 *     then placed at its original distance from the ankle, towards its pinned target; step 1 is
 *     repeated at the end (vertical lifts only).
 */
import type { Skeleton } from '../skeleton';
import { type V3, add, norm, normalize, scale, sub, twoBoneIK } from './math3';

/** The part of the manifest skeleton the clean-up reads (footJoints: l_ankle, l_foot, r_ankle, r_foot). */
export type FootRig = Pick<Skeleton, 'parents' | 'footJoints'>;

export interface FootCleanupOptions {
  threshold?: number;
  blend?: number;
  /** contact gaps of up to this many frames are closed (flicker) */
  gap?: number;
  /** a run whose joint strays farther than this (m, horizontally) from its mean is not pinned */
  maxDrift?: number;
  /** ... unless it is a stance (at most `stanceFrames` frames long): then the larger of `maxDrift` and this */
  stanceDrift?: number;
  stanceFrames?: number;
}

/** Defaults of the clean-up (emdm.motion.foot_contact has the same). */
export const FOOT_CLEANUP = { threshold: 0.5, blend: 3, gap: 2, maxDrift: 0.1, stanceDrift: 0.2, stanceFrames: 20 } as const;

/** The 4 contact channels of de-normalised features (frames × dim) → frames × 4. */
export function contactsFromFeatures(features: Float32Array, frames: number, dim = 263): Float32Array {
  if (features.length !== frames * dim) throw new RangeError(`contactsFromFeatures: ${features.length} values, expected ${frames} × ${dim}`);
  const out = new Float32Array(frames * 4);
  for (let f = 0; f < frames; f++) for (let c = 0; c < 4; c++) out[f * 4 + c] = features[f * dim + dim - 4 + c];
  return out;
}

/** [first, last] of each run of contact frames, gaps of up to `gap` frames closed, runs of ≥ 2 frames. */
function runs(contact: (f: number) => boolean, frames: number, gap: number): [number, number][] {
  const raw: [number, number][] = [];
  let s = -1;
  for (let f = 0; f <= frames; f++) {
    const on = f < frames && contact(f);
    if (on && s < 0) s = f;
    if (!on && s >= 0) {
      const last = raw[raw.length - 1];
      if (last && s - last[1] - 1 <= gap) last[1] = f - 1;
      else raw.push([s, f - 1]);
      s = -1;
    }
  }
  return raw.filter(([a, b]) => b - a + 1 >= 2);
}

/** Two-bone IK (hip, target ankle, pole knee, thigh and shin lengths) → knee and reached ankle. */
export const solveKnee = twoBoneIK;

/** Per foot joint (l_ankle, l_foot, r_ankle, r_foot), the contact runs the clean-up pins: [first, last] and the
 *  joint's mean position over the run. */
export function plantRuns(
  joints: Float32Array,
  frames: number,
  contacts: Float32Array,
  rig: FootRig,
  {
    threshold = FOOT_CLEANUP.threshold,
    gap = FOOT_CLEANUP.gap,
    maxDrift = FOOT_CLEANUP.maxDrift,
    stanceDrift = FOOT_CLEANUP.stanceDrift,
    stanceFrames = FOOT_CLEANUP.stanceFrames,
  }: FootCleanupOptions = {},
): { first: number; last: number; mean: V3 }[][] {
  const J = rig.parents.length;
  return rig.footJoints.map((j, c) => {
    const out: { first: number; last: number; mean: V3 }[] = [];
    for (const [s, e] of runs((f) => contacts[f * 4 + c] > threshold, frames, gap)) {
      let m: V3 = [0, 0, 0];
      for (let f = s; f <= e; f++) m = add(m, [joints[(f * J + j) * 3], joints[(f * J + j) * 3 + 1], joints[(f * J + j) * 3 + 2]]);
      m = scale(m, 1 / (e - s + 1));
      let drift = 0;
      for (let f = s; f <= e; f++) drift = Math.max(drift, Math.hypot(joints[(f * J + j) * 3] - m[0], joints[(f * J + j) * 3 + 2] - m[2]));
      const limit = e - s + 1 <= stanceFrames ? Math.max(maxDrift, stanceDrift) : maxDrift;
      if (drift <= limit) out.push({ first: s, last: e, mean: m });
    }
    return out;
  });
}

/**
 * The contacts (frames × 4, 0/1) of the runs the clean-up pins: what a character's retargeting holds still, so it
 * pins the same frames as our skeleton (contacts the model got wrong, on a sliding foot, are not pinned there either).
 */
export function plantContacts(joints: Float32Array, frames: number, contacts: Float32Array, rig: FootRig, o: FootCleanupOptions = {}): Float32Array {
  if (contacts.length !== frames * 4) throw new RangeError(`plantContacts: contacts has ${contacts.length} values, expected ${frames} × 4`);
  const out = new Float32Array(frames * 4);
  plantRuns(joints, frames, contacts, rig, o).forEach((rs, c) => {
    for (const { first, last } of rs) for (let f = first; f <= last; f++) out[f * 4 + c] = 1;
  });
  return out;
}

/** A pin's weight over its fade (u: 0 → 1 linearly): smoothstep, so the correction starts and ends without a kick. */
export const fadeWeight = (u: number): number => u * u * (3 - 2 * u);

export function cleanupFootContacts(
  joints: Float32Array,
  frames: number,
  contacts: Float32Array,
  rig: FootRig,
  options: FootCleanupOptions = {},
): Float32Array {
  const blend = options.blend ?? FOOT_CLEANUP.blend;
  const J = rig.parents.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`cleanupFootContacts: joints has ${joints.length} values, expected ${frames} × ${J} × 3`);
  if (contacts.length !== frames * 4) throw new RangeError(`cleanupFootContacts: contacts has ${contacts.length} values, expected ${frames} × 4`);
  if (rig.footJoints.length !== 4) throw new RangeError('cleanupFootContacts: footJoints must list l_ankle, l_foot, r_ankle, r_foot');
  const out = joints.slice();
  const at = (f: number, j: number): V3 => [out[(f * J + j) * 3], out[(f * J + j) * 3 + 1], out[(f * J + j) * 3 + 2]];
  const put = (f: number, j: number, p: V3) => out.set(p, (f * J + j) * 3);

  // 1. floor
  const floor = () => {
    for (let f = 0; f < frames; f++) {
      let low = Infinity;
      for (const j of rig.footJoints) low = Math.min(low, out[(f * J + j) * 3 + 1]);
      if (low < 0) for (let j = 0; j < J; j++) out[(f * J + j) * 3 + 1] -= low;
    }
  };
  floor();

  // 2. pinned targets per foot joint: target[f] and weight[f] in [0, 1]; where one plant's fade-out meets the next's
  // fade-in (a run's short swing) the target is their weight-mixed mean, so it never jumps a stride in one frame
  const planted = plantRuns(out, frames, contacts, rig, options); // which runs are plants: its options, its defaults
  const targets = rig.footJoints.map((j, c) => {
    const tgt: (V3 | null)[] = new Array(frames).fill(null);
    const wgt = new Float64Array(frames);
    const sum = new Float64Array(frames * 3);
    const wsum = new Float64Array(frames);
    const pins = planted[c].map(({ first: s, last: e, mean }) => ({ s, e, m: [mean[0], Math.max(0, mean[1]), mean[2]] as V3 }));
    for (const { s, e, m } of pins) {
      for (let f = Math.max(0, s - blend); f <= Math.min(frames - 1, e + blend); f++) {
        const w = fadeWeight(f < s ? 1 - (s - f) / (blend + 1) : f > e ? 1 - (f - e) / (blend + 1) : 1);
        for (let k = 0; k < 3; k++) sum[f * 3 + k] += w * m[k];
        wsum[f] += w;
        wgt[f] = Math.max(wgt[f], w);
      }
    }
    for (let f = 0; f < frames; f++) if (wsum[f] > 0) tgt[f] = [sum[f * 3] / wsum[f], sum[f * 3 + 1] / wsum[f], sum[f * 3 + 2] / wsum[f]];
    // a run's own frames keep its pin (a neighbour's fade reaches them only when blend > gap + 1)
    for (const { s, e, m } of pins) for (let f = s; f <= e; f++) tgt[f] = m;
    return { j, tgt, wgt };
  });

  // 3. apply per leg: ankle (knee follows), then ball of foot
  for (const [ci, fi] of [[0, 1], [2, 3]]) {
    const ank = targets[ci];
    const ball = targets[fi];
    const knee = rig.parents[ank.j];
    const hip = rig.parents[knee];
    for (let f = 0; f < frames; f++) {
      const A0 = at(f, ank.j);
      const B0 = at(f, ball.j);
      let A = A0;
      if (ank.wgt[f] > 0) {
        const want = add(A0, scale(sub(ank.tgt[f]!, A0), ank.wgt[f]));
        const H = at(f, hip);
        const K = at(f, knee);
        const r = solveKnee(H, want, K, norm(sub(K, H)), norm(sub(A0, K)));
        put(f, knee, r.knee);
        A = r.ankle;
        put(f, ank.j, A);
      }
      const footLen = norm(sub(B0, A0));
      let Bt = add(B0, sub(A, A0)); // carried along with the ankle
      if (ball.wgt[f] > 0) Bt = add(Bt, scale(sub(ball.tgt[f]!, Bt), ball.wgt[f]));
      if (ank.wgt[f] > 0 || ball.wgt[f] > 0) put(f, ball.j, add(A, scale(normalize(sub(Bt, A), sub(B0, A0)), footLen)));
    }
  }
  floor(); // a re-placed ball of foot can dip below y = 0: lift again (vertical only: no skating)
  return out;
}

/** Mean horizontal speed (m/frame) of foot joints during their contact frames: the skate measure. */
export function footSkate(joints: Float32Array, frames: number, contacts: Float32Array, rig: FootRig, threshold = 0.5): number {
  const J = rig.parents.length;
  let sum = 0;
  let n = 0;
  rig.footJoints.forEach((j, c) => {
    for (let f = 1; f < frames; f++) {
      if (contacts[f * 4 + c] > threshold && contacts[(f - 1) * 4 + c] > threshold) {
        const a = (f * J + j) * 3;
        const b = ((f - 1) * J + j) * 3;
        sum += Math.hypot(joints[a] - joints[b], joints[a + 2] - joints[b + 2]);
        n++;
      }
    }
  });
  return n ? sum / n : 0;
}
