/**
 * Continuing a motion with a new segment, and pinning a kept later part in place (docs/ARCHITECTURE.md
 * "Sampling with constraints", issue 14 "Root handling"). Python twin: `emdm.motion.stitch`.
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
 * `ref` (default `next`): the joints that move is measured on, e.g. the recovered joints when `next` is their
 * decoded (smoothed) version, which then moves exactly as they do.
 */
export function alignSegment(prev: ArrayLike<number>, prevFrames: number, next: ArrayLike<number>, nextFrames: number, overlap: number, ref: ArrayLike<number> = next): Float32Array {
  checkJoints(prev, prevFrames, 'alignSegment: prev');
  checkJoints(next, nextFrames, 'alignSegment: next');
  checkJoints(ref, nextFrames, 'alignSegment: ref');
  if (!Number.isInteger(overlap) || overlap < 1 || overlap > Math.min(prevFrames, nextFrames)) {
    throw new RangeError(`alignSegment: overlap must be an integer in 1…${Math.min(prevFrames, nextFrames)} (frames of next that repeat prev's last frames), got ${overlap}`);
  }
  const p = (prevFrames - 1) * J * 3;
  const q = (overlap - 1) * J * 3;
  const dTheta = headingAt(prev, prevFrames - 1) - headingAt(ref, overlap - 1);
  const c = Math.cos(dTheta);
  const s = Math.sin(dTheta);
  const out = new Float32Array(next.length);
  for (let i = 0; i < next.length; i += 3) {
    const x = next[i] - ref[q];
    const z = next[i + 2] - ref[q + 2];
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

/** The recovered root of frame t of (frames × dim) features: x/z (metres) and heading θ (radians, about +Y,
 * as `recoverJoints` integrates it; equal to `headingAt` of the recovered joints for a real clip). */
export function rootPose(features: ArrayLike<number>, frames: number, t: number, dim = 263): { x: number; z: number; heading: number } {
  if (features.length !== frames * dim) throw new RangeError(`rootPose: features has ${features.length} values, expected frames (${frames}) × ${dim}`);
  if (!Number.isInteger(t) || t < 0 || t >= frames) throw new RangeError(`rootPose: frame ${t} outside 0…${frames - 1}`);
  let a = 0;
  let x = 0;
  let z = 0;
  for (let k = 1; k <= t; k++) {
    a += features[(k - 1) * dim];
    const th = -2 * a;
    const vx = features[(k - 1) * dim + 1];
    const vz = features[(k - 1) * dim + 2];
    x += Math.cos(th) * vx + Math.sin(th) * vz;
    z += -Math.sin(th) * vx + Math.cos(th) * vz;
  }
  return { x, z, heading: -2 * a };
}

/**
 * Pin a kept later part of a motion to its place in the world (in-betweening, loops): features whose frames
 * `free` = [start, end) were generated between kept frames integrate to a different root path, so the kept
 * frames from `at` on would land elsewhere than in the known motion. This spreads the missing turn evenly over
 * the free frames' angular velocity [0], then the missing x/z travel over their linear velocity [1:3] (each in
 * its frame's root frame), so that `rootPose(result, at)` equals `target` (e.g. `rootPose(known, at)`). Only the
 * free frames' root channels change; a new array is returned.
 */
export function pinRoot(features: ArrayLike<number>, frames: number, free: [number, number], at: number, target: { x: number; z: number; heading: number }, dim = 263): Float32Array {
  const [s, e] = free;
  if (!Number.isInteger(s) || !Number.isInteger(e) || s < 0 || e <= s || !Number.isInteger(at) || e > at || at >= frames) {
    throw new RangeError(`pinRoot: free frames [${s}, ${e}) must be a non-empty range ending at or before frame ${at}, which must be < ${frames}`);
  }
  const out = Float32Array.from(features);
  const n = e - s;
  const now = rootPose(out, frames, at, dim);
  const dTheta = Math.atan2(Math.sin(target.heading - now.heading), Math.cos(target.heading - now.heading));
  for (let k = s; k < e; k++) out[k * dim] += -dTheta / 2 / n; // θ = −2·Σ f[·,0]
  const turned = rootPose(out, frames, at, dim);
  const dx = (target.x - turned.x) / n;
  const dz = (target.z - turned.z) / n;
  let a = 0;
  for (let k = 0; k < e; k++) {
    a += out[k * dim]; // a_{k+1}: f[k, 1:3] is rotated by θ_{k+1} = −2·a_{k+1}
    if (k < s) continue;
    const th = -2 * a;
    // world step (dx, dz) in the root frame of k+1: Ry(−θ)
    out[k * dim + 1] += Math.cos(th) * dx - Math.sin(th) * dz;
    out[k * dim + 2] += Math.sin(th) * dx + Math.cos(th) * dz;
  }
  return out;
}

/**
 * `pinRoot` for every stretch of frames whose root velocities [0:3] are free (no channel kept) and that is
 * followed by a frame whose root is kept: that frame is pinned to `rootPose(known, ·)`. So every kept frame
 * decodes where `recoverJoints(known)` has it. `keep` and `known` as given to `generate({known})`
 * (frames × dim, de-normalised); frames before the first free stretch and after the last kept one are untouched.
 */
export function pinKeptRoot(features: ArrayLike<number>, frames: number, keep: ArrayLike<number>, known: ArrayLike<number>, dim = 263): Float32Array {
  for (const [a, what] of [[features, 'features'], [keep, 'keep'], [known, 'known']] as const) {
    if (a.length !== frames * dim) throw new RangeError(`pinKeptRoot: ${what} has ${a.length} values, expected frames (${frames}) × ${dim}`);
  }
  const rootKept = (t: number) => keep[t * dim] === 1 || keep[t * dim + 1] === 1 || keep[t * dim + 2] === 1;
  let out: Float32Array = Float32Array.from(features);
  for (let t = 0; t < frames; ) {
    if (rootKept(t)) {
      t++;
      continue;
    }
    let e = t;
    while (e < frames && !rootKept(e)) e++;
    if (e < frames) out = pinRoot(out, frames, [t, e], e, rootPose(known, frames, e, dim), dim);
    t = e;
  }
  return out;
}
