/**
 * Foot-contact clean-up: the model predicts per-frame contacts for l_ankle, l_foot, r_ankle, r_foot
 * (features [259:263]); where a joint is in contact it should neither skate nor sink.
 *
 *  1. Floor: each frame whose lowest foot joint is below y = 0 is lifted as a whole by that depth.
 *  2. Pinning: every contact run (≥ 2 frames with contact > 0.5) of a foot joint is held at the
 *     run's mean position (y clamped to ≥ 0); the correction fades in/out linearly over `blend`
 *     frames on both sides, so there are no pops.
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
}

/** The 4 contact channels of de-normalised features (frames × dim) → frames × 4. */
export function contactsFromFeatures(features: Float32Array, frames: number, dim = 263): Float32Array {
  if (features.length !== frames * dim) throw new RangeError(`contactsFromFeatures: ${features.length} values, expected ${frames} × ${dim}`);
  const out = new Float32Array(frames * 4);
  for (let f = 0; f < frames; f++) for (let c = 0; c < 4; c++) out[f * 4 + c] = features[f * dim + dim - 4 + c];
  return out;
}

function runs(contact: (f: number) => boolean, frames: number): [number, number][] {
  const out: [number, number][] = [];
  let s = -1;
  for (let f = 0; f <= frames; f++) {
    const on = f < frames && contact(f);
    if (on && s < 0) s = f;
    if (!on && s >= 0) {
      if (f - s >= 2) out.push([s, f - 1]);
      s = -1;
    }
  }
  return out;
}

/** Two-bone IK (hip, target ankle, pole knee, thigh and shin lengths) → knee and reached ankle. */
export const solveKnee = twoBoneIK;

export function cleanupFootContacts(
  joints: Float32Array,
  frames: number,
  contacts: Float32Array,
  rig: FootRig,
  { threshold = 0.5, blend = 3 }: FootCleanupOptions = {},
): Float32Array {
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

  // 2. pinned targets per foot joint: target[f] and weight[f] in [0, 1]
  const targets = rig.footJoints.map((j, c) => {
    const tgt: (V3 | null)[] = new Array(frames).fill(null);
    const wgt = new Float64Array(frames);
    for (const [s, e] of runs((f) => contacts[f * 4 + c] > threshold, frames)) {
      let m: V3 = [0, 0, 0];
      for (let f = s; f <= e; f++) m = add(m, at(f, j));
      m = scale(m, 1 / (e - s + 1));
      m[1] = Math.max(0, m[1]);
      for (let f = Math.max(0, s - blend); f <= Math.min(frames - 1, e + blend); f++) {
        const w = f < s ? 1 - (s - f) / (blend + 1) : f > e ? 1 - (f - e) / (blend + 1) : 1;
        if (w > wgt[f]) {
          wgt[f] = w;
          tgt[f] = m;
        }
      }
    }
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
