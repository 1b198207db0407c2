/**
 * Continuing a motion with a new segment (docs/ARCHITECTURE.md "Sampling with constraints", issue 14 "Root
 * handling"). Python twin: `emdm.motion.stitch`.
 *
 * ```ts
 * // next was generated with its first `overlap` frames kept from prev's last `overlap` frames (keepMask)
 * const nextJoints = recoverJoints(next.features, nextFrames);            // starts at the origin, facing +Z
 * const whole = appendSegment(prevJoints, prevFrames, nextJoints, nextFrames, overlap);
 * ```
 *
 * The features' root is relative (angular and linear velocity), so `recoverJoints` integrates every segment
 * from heading 0 at the origin. Integrating the new segment from the previous one's pose instead turns every
 * frame about +Y by the heading difference and shifts it in x/z: that rigid move is what `alignSegment`
 * applies, chosen so that the new segment's frame `overlap − 1` (the copy of the previous segment's last
 * frame) has the previous last frame's root x/z and heading. Heights stay as recovered (they are absolute).
 * Heading is measured as `emdm.motion.features.heading_angles` does: forward = up × ((r_hip − l_hip) +
 * (r_shoulder − l_shoulder)), θ = atan2(forward.x, forward.z).
 */
import { JOINT_NAMES } from '../skeleton';

const J = JOINT_NAMES.length;
const L_HIP = JOINT_NAMES.indexOf('l_hip');
const R_HIP = JOINT_NAMES.indexOf('r_hip');
const L_SHOULDER = JOINT_NAMES.indexOf('l_shoulder');
const R_SHOULDER = JOINT_NAMES.indexOf('r_shoulder');

function checkJoints(joints: ArrayLike<number>, frames: number, what: string): void {
  if (!Number.isInteger(frames) || frames < 1) throw new RangeError(`${what}: frames must be a positive integer, got ${frames}`);
  if (joints.length !== frames * J * 3) throw new RangeError(`${what}: ${joints.length} values, expected frames (${frames}) × ${J} × 3`);
}

/** θ of frame f: the angle about +Y that turns +Z into the body's forward direction. */
export function headingAt(joints: ArrayLike<number>, f: number): number {
  const o = f * J * 3;
  const ax = joints[o + 3 * R_HIP] - joints[o + 3 * L_HIP] + joints[o + 3 * R_SHOULDER] - joints[o + 3 * L_SHOULDER];
  const az = joints[o + 3 * R_HIP + 2] - joints[o + 3 * L_HIP + 2] + joints[o + 3 * R_SHOULDER + 2] - joints[o + 3 * L_SHOULDER + 2];
  return Math.atan2(az, -ax); // forward = (across.z, 0, −across.x)
}

/**
 * `next` (nextFrames × 22 × 3) turned about +Y and shifted in x/z so that its frame `overlap − 1` sits at
 * `prev`'s last frame's root x/z with its heading (a new array; `overlap` ≥ 1 frames of next repeat prev's last).
 */
export function alignSegment(prev: ArrayLike<number>, prevFrames: number, next: ArrayLike<number>, nextFrames: number, overlap: number): Float32Array {
  checkJoints(prev, prevFrames, 'alignSegment: prev');
  checkJoints(next, nextFrames, 'alignSegment: next');
  if (!Number.isInteger(overlap) || overlap < 1 || overlap > Math.min(prevFrames, nextFrames)) {
    throw new RangeError(`alignSegment: overlap must be an integer in 1…${Math.min(prevFrames, nextFrames)} (frames of next that repeat prev's last frames), got ${overlap}`);
  }
  const p = (prevFrames - 1) * J * 3;
  const q = (overlap - 1) * J * 3;
  const dTheta = headingAt(prev, prevFrames - 1) - headingAt(next, overlap - 1);
  const c = Math.cos(dTheta);
  const s = Math.sin(dTheta);
  const out = new Float32Array(next.length);
  for (let i = 0; i < next.length; i += 3) {
    const x = next[i] - next[q];
    const z = next[i + 2] - next[q + 2];
    out[i] = c * x + s * z + prev[p];
    out[i + 1] = next[i + 1];
    out[i + 2] = -s * x + c * z + prev[p + 2];
  }
  return out;
}

/** One motion: `prev`, then `next` aligned by `alignSegment` without its first `overlap` frames. */
export function appendSegment(prev: ArrayLike<number>, prevFrames: number, next: ArrayLike<number>, nextFrames: number, overlap: number): { joints: Float32Array; frames: number } {
  const aligned = alignSegment(prev, prevFrames, next, nextFrames, overlap);
  const frames = prevFrames + nextFrames - overlap;
  const joints = new Float32Array(frames * J * 3);
  joints.set(prev, 0);
  joints.set(aligned.subarray(overlap * J * 3), prevFrames * J * 3);
  return { joints, frames };
}
