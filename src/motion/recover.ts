/**
 * Features → joints: a line-by-line port of `emdm.motion.features.recover_joints` (read its
 * docstring for the conventions). Only features [0:67] are used. float64 internally.
 *
 *   a_0 = 0, a_t = Σ_{k<t} f[k,0];  θ_t = −2 a_t
 *   root_xz_0 = 0, root_xz_t = root_xz_{t−1} + Ry(θ_t)·(f[t−1,1], 0, f[t−1,2]);  root_y_t = f[t,3]
 *   joint_j,t = Ry(θ_t)·f[t, 4+3(j−1) : 7+3(j−1)] + (root_x_t, 0, root_z_t),  j = 1..21
 * with Ry(a): (x, y, z) → (cos a·x + sin a·z, y, −sin a·x + cos a·z).
 */

export const FEATURE_DIM = 263;
export const NUM_JOINTS = 22;

/** (frames × dim) features → (frames × 22 × 3) joints (float32). */
export function recoverJoints(features: Float32Array | Float64Array, frames: number, dim = FEATURE_DIM): Float32Array {
  if (dim < 67) throw new RangeError(`recoverJoints: feature dim must be ≥ 67, got ${dim}`);
  if (features.length !== frames * dim) {
    throw new RangeError(`recoverJoints: features has ${features.length} values, expected frames (${frames}) × ${dim}`);
  }
  const out = new Float32Array(frames * NUM_JOINTS * 3);
  let a = 0;
  let rx = 0;
  let rz = 0;
  for (let t = 0; t < frames; t++) {
    const f = t * dim;
    if (t > 0) a += features[f - dim];
    const theta = -2 * a;
    const c = Math.cos(theta);
    const s = Math.sin(theta);
    if (t > 0) {
      const vx = features[f - dim + 1];
      const vz = features[f - dim + 2];
      rx += c * vx + s * vz;
      rz += -s * vx + c * vz;
    }
    const o = t * NUM_JOINTS * 3;
    out[o] = rx;
    out[o + 1] = features[f + 3];
    out[o + 2] = rz;
    for (let j = 1; j < NUM_JOINTS; j++) {
      const k = f + 4 + 3 * (j - 1);
      const x = features[k];
      const y = features[k + 1];
      const z = features[k + 2];
      out[o + 3 * j] = c * x + s * z + rx;
      out[o + 3 * j + 1] = y;
      out[o + 3 * j + 2] = -s * x + c * z + rz;
    }
  }
  return out;
}

/** (x − mean) / std, per feature channel (frames × dim): denormalize's inverse, how a known motion enters the sampler. */
export function normalizeFeatures(x: Float32Array, mean: Float32Array, std: Float32Array): Float32Array {
  const dim = mean.length;
  return x.map((v, i) => (v - mean[i % dim]) / std[i % dim]);
}

/** x·std + mean, per feature channel (frames × dim). */
export function denormalize(x: Float32Array, mean: Float32Array, std: Float32Array): Float32Array {
  const dim = mean.length;
  if (std.length !== dim) throw new RangeError(`denormalize: mean has ${dim} values but std has ${std.length}`);
  if (x.length % dim !== 0) throw new RangeError(`denormalize: ${x.length} values is not a multiple of ${dim}`);
  const out = new Float32Array(x.length);
  for (let i = 0; i < x.length; i++) {
    const c = i % dim;
    out[i] = x[i] * std[c] + mean[c];
  }
  return out;
}

/** Parse a `meanStd` file of the manifest: float32 little-endian, mean[dim] then std[dim]. */
export function parseMeanStd(buf: ArrayBuffer, dim: number, where: string): { mean: Float32Array; std: Float32Array } {
  if (buf.byteLength !== 2 * dim * 4) {
    throw new Error(`${where}: ${buf.byteLength} bytes, expected ${2 * dim * 4} (float32 mean[${dim}] then std[${dim}])`);
  }
  const dv = new DataView(buf);
  const mean = new Float32Array(dim);
  const std = new Float32Array(dim);
  for (let i = 0; i < dim; i++) {
    mean[i] = dv.getFloat32(4 * i, true);
    std[i] = dv.getFloat32(4 * (dim + i), true);
  }
  for (let i = 0; i < dim; i++) {
    if (!Number.isFinite(mean[i]) || !Number.isFinite(std[i])) throw new Error(`${where}: channel ${i} has a non-finite mean or std`);
  }
  return { mean, std };
}
