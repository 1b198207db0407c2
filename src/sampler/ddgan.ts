/**
 * The DDGAN posterior update of EMDM models (objective "ddgan"; docs/ARCHITECTURE.md "Sampling"):
 *
 *   x_k = coef1[k]·x̂0 + coef2[k]·x_{k+1} + sigma[k]·ε      (ε drawn only where sigma[k] ≠ 0: not at the last step)
 *
 * in float64, stored as float32, as numpy does it in emdm.sampler.sample_features.
 */
import type { Schedule } from './schedule';
import type { SamplerRule, StepNoise } from './update';

/** Replace x (x_{k+1}) in place with x_k, given the model's prediction x0 (same length). */
export function ddganUpdate(x: Float32Array, x0: ArrayLike<number>, k: number, s: Schedule, noise: StepNoise): void {
  const c1 = s.coef1[k];
  const c2 = s.coef2[k];
  const sig = s.sigma[k];
  const eps = sig !== 0 ? noise.eps() : null;
  for (let i = 0; i < x.length; i++) {
    let v = c1 * x0[i] + c2 * x[i];
    if (eps) v += sig * eps[i];
    x[i] = v;
  }
}

export const ddgan: SamplerRule = { name: 'ddgan', update: ddganUpdate, reads: { time: 'steps', coef1: 'steps', coef2: 'steps', sigma: 'steps' }, usesZ: true };
