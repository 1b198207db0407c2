/**
 * One deterministic DDIM update (η = 0) for models trained with the plain x0 objective
 * (`python -m emdm.train --objective diffusion`), docs/ARCHITECTURE.md "DDIM sampling":
 *
 *   ε̂ = (x_{k+1} − aCum[k+1]·x̂0) / sCum[k+1]
 *   x_k = aCum[k]·x̂0 + sCum[k]·ε̂          (k > 0)
 *   x_0 = x̂0                              (k = 0: the last step returns the prediction)
 *
 * Arithmetic is float32 operation by operation (Math.fround), as numpy does it in
 * emdm.sampler.sample_features, so the two agree to the last bit or two.
 */
import type { DdimSchedule } from './schedule';
import type { SamplerRule } from './update';

const f = Math.fround;

/** Replace x (x_{k+1}, length n) in place with x_k, given the model's prediction x0 (length n). */
export function ddimUpdate(x: Float32Array, x0: ArrayLike<number>, k: number, s: DdimSchedule): void {
  if (!Number.isInteger(k) || k < 0 || k >= s.steps) throw new RangeError(`ddimUpdate: step index ${k} outside 0…${s.steps - 1}`);
  if (x0.length !== x.length) throw new RangeError(`ddimUpdate: x0 has ${x0.length} values, x has ${x.length}`);
  if (k === 0) {
    for (let i = 0; i < x.length; i++) x[i] = x0[i];
    return;
  }
  const aNext = f(s.aCum[k + 1]);
  const sNext = f(s.sCum[k + 1]);
  const a = f(s.aCum[k]);
  const sd = f(s.sCum[k]);
  for (let i = 0; i < x.length; i++) {
    const eps = f(f(x[i] - f(aNext * x0[i])) / sNext);
    x[i] = f(f(a * x0[i]) + f(sd * eps));
  }
}

/** z is drawn (the draw order stays the DDGAN one) but fed as zeros; no ε. */
export const ddim: SamplerRule = { name: 'ddim', update: ddimUpdate, reads: { time: 'steps', aCum: 'steps+1', sCum: 'steps+1' }, usesZ: false };
