/**
 * The variance-preserving diffusion schedule for T steps as ONE object the sampler reads
 * (docs/ARCHITECTURE.md "Diffusion schedule" and "DDIM sampling"), like Python's
 * `emdm.sampler.schedule.make_schedule`:
 *
 * ```ts
 * const schedule = scheduleFor(manifest.models[name], 10, name);   // checks supportedSteps (and DDIM's grid)
 * await sample({ method: 'ddgan', schedule, ... });                 // reads time, coef1, coef2, sigma
 * await sample({ method: 'ddim', schedule, ... });                  // reads time, aCum, sCum
 * ```
 *
 * - the DDGAN posterior q(x_k | x_{k+1}, x0): x_k = coef1[k]·x0 + coef2[k]·x_{k+1} + sigma[k]·ε;
 * - the DDIM marginals x_i = aCum[i]·x0 + sCum[i]·ε (i = 0..T) on the same time grid.
 * Pure float64 math. The manifest carries the posterior numbers per step count and `scheduleFor`
 * prefers them; the marginals are computed here from the same formula and tested against the numbers
 * emdm.sampler.schedule writes into the parity fixtures, and for a DDIM model `scheduleFor` checks that
 * the manifest's time grid is the one they were computed for.
 */

import { type SamplerName, methodOf } from './settings';

export interface Schedule {
  /** number of denoising steps T */
  steps: number;
  /** time[k] = t_{k+1}: the continuous time given to the generator at step index k (input x_{k+1}) */
  time: Float64Array;
  /** DDGAN posterior (T values each) */
  coef1: Float64Array;
  coef2: Float64Array;
  /** posterior standard deviation; sigma[0] = 0 (the last step adds no noise) */
  sigma: Float64Array;
  /**
   * DDIM marginals (T + 1 values each, i = 0 is the data): x_i given x_0 is N(aCum[i]·x_0, sCum[i]²·I);
   * aCum[0] = sqrt(1 − 1e-8), sCum[0] = 1e-4, as emdm.sampler.schedule's β_0 = 1e-8
   */
  aCum: Float64Array;
  sCum: Float64Array;
}

/** The part of a Schedule the DDIM update reads. */
export type DdimSchedule = Pick<Schedule, 'steps' | 'time' | 'aCum' | 'sCum'>;

export const VP_DEFAULTS = { betaMin: 0.1, betaMax: 20, eps: 1e-3 } as const;
type VpParams = { betaMin: number; betaMax: number; eps: number };

/** t_i = (i/T)(1−ε)+ε */
const gridTime = (i: number, T: number, eps: number) => (i / T) * (1 - eps) + eps;

/** The schedule for T steps computed from the formula (float64): posterior and marginals. */
export function computeSchedule(steps: number, params: VpParams = VP_DEFAULTS): Schedule {
  if (!Number.isInteger(steps) || steps < 1) {
    throw new RangeError(`computeSchedule: steps must be a positive integer, got ${steps}`);
  }
  const time = Float64Array.from({ length: steps }, (_, k) => gridTime(k + 1, steps, params.eps));
  return { steps, time, ...posterior(steps, params), ...marginals(steps, params) };
}

function posterior(T: number, { betaMin, betaMax, eps }: VpParams): Pick<Schedule, 'coef1' | 'coef2' | 'sigma'> {
  const alphaBar = new Float64Array(T + 1);
  for (let i = 0; i <= T; i++) {
    const t = gridTime(i, T, eps);
    const logMean = -0.25 * t * t * (betaMax - betaMin) - 0.5 * t * betaMin;
    alphaBar[i] = Math.exp(2 * logMean); // = 1 - var
  }
  const coef1 = new Float64Array(T);
  const coef2 = new Float64Array(T);
  const sigma = new Float64Array(T);
  for (let k = 0; k < T; k++) {
    const beta = 1 - alphaBar[k + 1] / alphaBar[k];
    const cum = alphaBar[k + 1] / alphaBar[0];
    const cumPrev = k === 0 ? 1 : alphaBar[k] / alphaBar[0];
    coef1[k] = (beta * Math.sqrt(cumPrev)) / (1 - cum);
    coef2[k] = ((1 - cumPrev) * Math.sqrt(1 - beta)) / (1 - cum);
    sigma[k] = k === 0 ? 0 : Math.sqrt((beta * (1 - cumPrev)) / (1 - cum));
  }
  return { coef1, coef2, sigma };
}

/** DDIM marginals, mirroring emdm.sampler.schedule.make_schedule's a_cum / s_cum. */
function marginals(T: number, { betaMin, betaMax, eps }: VpParams): Pick<Schedule, 'aCum' | 'sCum'> {
  const alphaBar = new Float64Array(T + 1);
  for (let i = 0; i <= T; i++) {
    const t = gridTime(i, T, eps);
    const variance = 1 - Math.exp(2 * (-0.25 * t * t * (betaMax - betaMin) - 0.5 * t * betaMin));
    alphaBar[i] = 1 - variance; // written as in Python (1 − var), so the float64 roundings agree
  }
  const aCum = new Float64Array(T + 1);
  const sCum = new Float64Array(T + 1);
  // a_step[i] = sqrt(1 − β_i) with β_0 = 1e-8 and β_i = 1 − ᾱ_i / ᾱ_{i−1}; aCum = cumulative product
  let a = 1;
  for (let i = 0; i <= T; i++) {
    const beta = i === 0 ? 1e-8 : 1 - alphaBar[i] / alphaBar[i - 1];
    a *= Math.sqrt(1 - beta);
    aCum[i] = a;
    sCum[i] = Math.sqrt(1 - a * a);
  }
  return { aCum, sCum };
}

export interface ScheduleEntry {
  time: number[];
  coef1: number[];
  coef2: number[];
  sigma: number[];
}

/**
 * A schedule from one manifest schedule entry (the posterior as listed, the marginals from the
 * formula); `where` names the entry in errors.
 */
export function scheduleFromEntry(entry: ScheduleEntry, steps: number, where: string): Schedule {
  const out: Schedule = computeSchedule(steps);
  for (const key of ['time', 'coef1', 'coef2', 'sigma'] as const) {
    const v = (entry as unknown as Record<string, unknown>)[key];
    if (!Array.isArray(v) || v.length !== steps || !v.every((n) => typeof n === 'number' && Number.isFinite(n))) {
      throw new Error(`${where}.${key}: expected ${steps} finite numbers`);
    }
    out[key] = Float64Array.from(v as number[]);
  }
  return out;
}

/** The part of a manifest model entry a schedule is made from. */
export interface ScheduleSource {
  supportedSteps?: number[];
  schedules?: Record<string, ScheduleEntry>;
  objective?: string;
}

/**
 * The schedule for `steps` denoising steps of a manifest model entry, for the update rule `method`
 * (by default the one its `objective` calls for: "diffusion" → 'ddim', else 'ddgan'). Only for a step
 * count the model declares in `supportedSteps`, since the generator was trained on those.
 * - 'ddgan': the manifest's `schedules[steps]` posterior when present, else computed;
 * - 'ddim': computed; a manifest `schedules[steps].time` must be the grid the marginals belong to.
 */
export function scheduleFor(model: ScheduleSource, steps: number, modelName = 'model',
  method: SamplerName = methodOf(model.objective)): Schedule {
  const supported = model.supportedSteps ?? [];
  if (!supported.includes(steps)) {
    throw new RangeError(
      `manifest models.${modelName}: ${steps} steps not supported (supportedSteps = [${supported.join(', ')}])`,
    );
  }
  const entry = model.schedules?.[String(steps)];
  const where = `manifest models.${modelName}.schedules["${steps}"]`;
  if (!entry) return computeSchedule(steps);
  if (method === 'ddgan') return scheduleFromEntry(entry, steps, where);
  const s = computeSchedule(steps);
  const t = entry.time;
  if (!Array.isArray(t) || t.length !== steps) throw new Error(`${where}.time: expected ${steps} finite numbers`);
  for (let k = 0; k < steps; k++) {
    if (!(Math.abs(t[k] - s.time[k]) <= 1e-6)) {
      throw new Error(`${where}.time[${k}] = ${t[k]} is not the VP grid's ${s.time[k]} (β_min 0.1, β_max 20, ε 1e-3): DDIM cannot sample this model`);
    }
  }
  return s;
}

/** `scheduleFor(model, steps, modelName, 'ddim')`: the schedule of a model trained with `--objective diffusion`. */
export function ddimScheduleFor(model: ScheduleSource, steps: number, modelName = 'model'): Schedule {
  return scheduleFor(model, steps, modelName, 'ddim');
}
