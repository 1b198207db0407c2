/** Sentence pooling (pure): masked mean over token vectors, L2 normalisation. Mirrors emdm/text/pooling.py. */

/** Mean of the rows of `hidden` ([tokens × dim], row-major) where `mask[t]` is non-zero. */
export function meanPool(hidden: ArrayLike<number>, tokens: number, dim: number, mask?: ArrayLike<number | bigint>): Float32Array {
  if (hidden.length !== tokens * dim) {
    throw new RangeError(`meanPool: hidden has ${hidden.length} values, expected tokens*dim = ${tokens}*${dim}`);
  }
  const out = new Float64Array(dim);
  let count = 0;
  for (let t = 0; t < tokens; t++) {
    if (mask && Number(mask[t]) === 0) continue;
    count++;
    const o = t * dim;
    for (let d = 0; d < dim; d++) out[d] += hidden[o + d];
  }
  const res = new Float32Array(dim);
  const c = Math.max(count, 1e-9);
  for (let d = 0; d < dim; d++) res[d] = out[d] / c;
  return res;
}

/** `v` scaled to unit length (a zero vector stays zero). */
export function l2Normalize(v: Float32Array): Float32Array {
  let s = 0;
  for (let i = 0; i < v.length; i++) s += v[i] * v[i];
  const n = Math.max(Math.sqrt(s), 1e-12);
  const out = new Float32Array(v.length);
  for (let i = 0; i < v.length; i++) out[i] = v[i] / n;
  return out;
}

/** Cosine similarity of two equal-length vectors. */
export function cosine(a: ArrayLike<number>, b: ArrayLike<number>): number {
  if (a.length !== b.length) throw new RangeError(`cosine: lengths ${a.length} and ${b.length} differ`);
  let ab = 0;
  let aa = 0;
  let bb = 0;
  for (let i = 0; i < a.length; i++) {
    ab += a[i] * b[i];
    aa += a[i] * a[i];
    bb += b[i] * b[i];
  }
  return ab / Math.max(Math.sqrt(aa * bb), 1e-30);
}
