/**
 * De-normalised features → the joints a motion is shown with: recovered (./recover.ts), smoothed along time
 * (σ = 1 frame) and the feet held where they touch the floor (./footContact.ts). generate()'s decoding of one
 * motion with `smooth` / `footCleanup`, and a stitched timeline's, are this one function.
 */
import { cleanupFootContacts, contactsFromFeatures } from './footContact';
import { FEATURE_DIM, recoverJoints } from './recover';
import { smoothJoints } from './smooth';

export interface DecodeOptions {
  /** Gaussian smoothing of the joints along time, σ = 1 frame */
  smooth?: boolean;
  /** feet held still where the contact channels say they touch the floor */
  footCleanup?: boolean;
}

/** (frames × dim) de-normalised features → (frames × 22 × 3) joints, smoothed and feet cleaned up as asked. */
export function decodeJoints(features: Float32Array, frames: number, rig: { parents: number[]; footJoints: number[] }, o: DecodeOptions, dim = FEATURE_DIM): Float32Array {
  let joints = recoverJoints(features, frames, dim);
  if (o.smooth) joints = smoothJoints(joints, frames, 1);
  if (o.footCleanup) joints = cleanupFootContacts(joints, frames, contactsFromFeatures(features, frames, dim), { parents: rig.parents, footJoints: rig.footJoints });
  return joints;
}
