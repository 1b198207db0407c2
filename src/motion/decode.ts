/**
 * De-normalised features → the joints a motion is shown with: recovered (./recover.ts), smoothed along time
 * (σ = 1 frame) and the feet held where they touch the floor (./footContact.ts). generate()'s decoding of one
 * motion with `smooth` / `footCleanup`, and a stitched timeline's, are this one function.
 *
 * A looping clip (`loop: true`, a loop's clip: its frame 0 follows its last) is decoded as the loop plays: with
 * LOOP_PAD frames of its other end on each side, so the smoothing and the foot clean-up see across the wrap (decoded
 * alone, the in-place walk's wrap stepped up to 0.38 m against in-loop steps of 0.28 m: `python -m emdm.eval.seams`),
 * then set back to start at the origin facing +Z. Python twin: `emdm.motion.decode`.
 */
import { cleanupFootContacts, contactsFromFeatures } from './footContact';
import { FEATURE_DIM, recoverJoints } from './recover';
import { smoothJoints } from './smooth';
import { rootPose } from './stitch';

export interface DecodeOptions {
  /** Gaussian smoothing of the joints along time, σ = 1 frame */
  smooth?: boolean;
  /** feet held still where the contact channels say they touch the floor */
  footCleanup?: boolean;
  /** the features are a looping clip: decoded across the wrap (see the header) */
  loop?: boolean;
}

/** Frames of a looping clip's other end decoded on each side (σ = 1 smoothing, 3-frame fades, gaps of 2). */
export const LOOP_PAD = 10;

/** (frames × dim) de-normalised features → (frames × 22 × 3) joints, smoothed and feet cleaned up as asked. */
export function decodeJoints(features: Float32Array, frames: number, rig: { parents: number[]; footJoints: number[] }, o: DecodeOptions, dim = FEATURE_DIM): Float32Array {
  if (o.loop) return decodeLoop(features, frames, rig, o, dim);
  let joints = recoverJoints(features, frames, dim);
  if (o.smooth) joints = smoothJoints(joints, frames, 1);
  if (o.footCleanup) joints = cleanupFootContacts(joints, frames, contactsFromFeatures(features, frames, dim), { parents: rig.parents, footJoints: rig.footJoints });
  return joints;
}

/** decodeJoints of [last P frames, clip, first P frames] (P = min(LOOP_PAD, frames)), the clip's frames taken back
 * and turned/shifted so that its frame 0's root is at the origin with heading 0 (as recoverJoints of the clip has it). */
function decodeLoop(features: Float32Array, frames: number, rig: { parents: number[]; footJoints: number[] }, o: DecodeOptions, dim: number): Float32Array {
  const p = Math.min(LOOP_PAD, frames);
  const ext = new Float32Array((frames + 2 * p) * dim);
  ext.set(features.subarray((frames - p) * dim, frames * dim), 0);
  ext.set(features.subarray(0, frames * dim), p * dim);
  ext.set(features.subarray(0, p * dim), (frames + p) * dim);
  const all = decodeJoints(ext, frames + 2 * p, rig, { ...o, loop: false }, dim);
  const { x: rx, z: rz, heading } = rootPose(ext, frames + 2 * p, p, dim);
  const c = Math.cos(heading);
  const s = -Math.sin(heading); // turned by −heading
  const out = new Float32Array(frames * 22 * 3);
  for (let i = 0, k = p * 22 * 3; i < out.length; i += 3, k += 3) {
    const x = all[k] - rx;
    const z = all[k + 2] - rz;
    out[i] = c * x + s * z;
    out[i + 1] = all[k + 1];
    out[i + 2] = -s * x + c * z;
  }
  return out;
}
