/**
 * The contract of one sampler's update rule, in the manner of diffusers' schedulers' `step()`: the loop
 * (src/sampler/sampler.ts) calls the model, forms x̂0 (guidance, smoothing, the kept part) and hands it to the
 * rule, which turns x_{k+1} into x_k in place. A rule is one file (ddgan.ts, ddim.ts) and one line in
 * src/sampler/registry.ts.
 */
import type { Schedule } from './schedule';

/** The noise a rule may draw at its step: ε for the frames it updates, drawn in the documented order (after z). */
export interface StepNoise {
  eps(): Float32Array;
}

/** x (x_{k+1}, the frames the model saw) := x_k, given the prediction x0 of the same length, at step index k. */
export type UpdateFn = (x: Float32Array, x0: Float32Array, k: number, schedule: Schedule, noise: StepNoise) => void;

export interface SamplerRule {
  /** what `SamplingSettings.method` calls it */
  name: string;
  update: UpdateFn;
  /** the schedule arrays it reads, each with T values (`steps`) or T + 1 (`steps+1`); the loop checks them first */
  reads: Partial<Record<keyof Omit<Schedule, 'steps'>, 'steps' | 'steps+1'>>;
  /** false: the model gets z = 0 (z is still drawn every step, so the draw order is every rule's) */
  usesZ: boolean;
}
