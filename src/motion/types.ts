/** A generated (or loaded) motion: 22 SMPL-order joints per frame, metres, Y up. */
export interface Motion {
  frames: number;
  fps: number;
  /** frames × 22 × 3 world joint positions */
  joints: Float32Array;
  /** frames × 263 de-normalised features (empty when the motion did not come from features) */
  features: Float32Array;
}
