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
