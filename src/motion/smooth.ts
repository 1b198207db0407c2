/**
 * Temporal smoothing of joint trajectories: a Gaussian filter along time (σ in frames), applied to
 * every coordinate, with the kernel renormalised at the ends (no padding artefacts, endpoints kept
 * close to the data). σ = 0 returns a copy.
 */
export function smoothJoints(joints: Float32Array, frames: number, sigma = 1): Float32Array {
  if (frames < 1 || joints.length % frames !== 0) throw new RangeError(`smoothJoints: ${joints.length} values is not frames (${frames}) × n`);
  if (!(sigma >= 0)) throw new RangeError(`smoothJoints: sigma must be ≥ 0, got ${sigma}`);
  const n = joints.length / frames;
  if (sigma === 0 || frames < 3) return joints.slice();
  const r = Math.max(1, Math.ceil(3 * sigma));
  const w = Array.from({ length: 2 * r + 1 }, (_, k) => Math.exp(-((k - r) ** 2) / (2 * sigma * sigma)));
  const out = new Float32Array(joints.length);
  for (let f = 0; f < frames; f++) {
    const lo = Math.max(0, f - r);
    const hi = Math.min(frames - 1, f + r);
    let wsum = 0;
    for (let g = lo; g <= hi; g++) wsum += w[g - f + r];
    for (let i = 0; i < n; i++) {
      let acc = 0;
      for (let g = lo; g <= hi; g++) acc += w[g - f + r] * joints[g * n + i];
      out[f * n + i] = acc / wsum;
    }
  }
  return out;
}

/**
 * The pose channels of the HumanML3D layout, [from, to): the 21 root-relative joint positions [4:67] and their 6D
 * rotations [67:193]. x̂0 smoothing touches these only: smoothing the root channels, the local velocities or the foot
 * contacts of x̂0 made the sampler choose faster motion (docs/MODELS.md "Smoothing x̂0"). emdm.motion.smooth.POSE_CHANNELS.
 */
export const POSE_CHANNELS = [4, 193] as const;

/** `smoothJoints` on the pose channels of (frames × dim) features only, the other channels copied (emdm smooth_pose). */
export function smoothPose(x: Float32Array, frames: number, sigma: number): Float32Array {
  if (frames < 1 || x.length % frames !== 0) throw new RangeError(`smoothPose: ${x.length} values is not frames (${frames}) × dim`);
  const dim = x.length / frames;
  const [a, b] = POSE_CHANNELS;
  if (dim < b) throw new RangeError(`smoothPose: ${dim} channels; the pose channels are [${a}, ${b})`);
  const w = b - a;
  const pose = new Float32Array(frames * w);
  for (let f = 0; f < frames; f++) pose.set(x.subarray(f * dim + a, f * dim + b), f * w);
  const sm = smoothJoints(pose, frames, sigma);
  const out = Float32Array.from(x);
  for (let f = 0; f < frames; f++) out.set(sm.subarray(f * w, (f + 1) * w), f * dim + a);
  return out;
}
