/**
 * The variance-preserving diffusion schedule: the DDGAN posterior q(x_{k} | x_{k+1}, x0) and the
 * DDIM marginals x_i = a_cum[i]·x0 + s_cum[i]·ε (docs/ARCHITECTURE.md "Diffusion schedule"). Pure
 * float64 math; the manifest carries the posterior numbers per step count and `scheduleFor` prefers
 * them; the DDIM marginals are computed here from the same formula and tested against the numbers
 * emdm.model.schedule writes into the parity fixtures, and `ddimScheduleFor` checks that a manifest's
 * time grid is the one they were computed for.
 */

export interface Schedule {
  /** number of denoising steps T */
  steps: number;
  /** time[k] = t_{k+1}: the continuous time given to the generator at step index k (input x_{k+1}) */
  time: Float64Array;
  coef1: Float64Array;
  coef2: Float64Array;
  /** posterior standard deviation; sigma[0] = 0 (the last step adds no noise) */
  sigma: Float64Array;
}

export const VP_DEFAULTS = { betaMin: 0.1, betaMax: 20, eps: 1e-3 } as const;

/** Schedule for T steps computed from the formula (float64). */
export function computeSchedule(
  steps: number,
  { betaMin, betaMax, eps }: { betaMin: number; betaMax: number; eps: number } = VP_DEFAULTS,
): Schedule {
  if (!Number.isInteger(steps) || steps < 1) {
    throw new RangeError(`computeSchedule: steps must be a positive integer, got ${steps}`);
  }
  const T = steps;
  const alphaBar = new Float64Array(T + 1);
  for (let i = 0; i <= T; i++) {
    const t = (i / T) * (1 - eps) + eps;
    const logMean = -0.25 * t * t * (betaMax - betaMin) - 0.5 * t * betaMin;
    alphaBar[i] = Math.exp(2 * logMean); // = 1 - var
  }
  const time = new Float64Array(T);
  const coef1 = new Float64Array(T);
  const coef2 = new Float64Array(T);
  const sigma = new Float64Array(T);
  for (let k = 0; k < T; k++) {
    const beta = 1 - alphaBar[k + 1] / alphaBar[k];
    const cum = alphaBar[k + 1] / alphaBar[0];
    const cumPrev = k === 0 ? 1 : alphaBar[k] / alphaBar[0];
    time[k] = ((k + 1) / T) * (1 - eps) + eps;
    coef1[k] = (beta * Math.sqrt(cumPrev)) / (1 - cum);
    coef2[k] = ((1 - cumPrev) * Math.sqrt(1 - beta)) / (1 - cum);
    sigma[k] = k === 0 ? 0 : Math.sqrt((beta * (1 - cumPrev)) / (1 - cum));
  }
  return { steps: T, time, coef1, coef2, sigma };
}

export interface ScheduleEntry {
  time: number[];
  coef1: number[];
  coef2: number[];
  sigma: number[];
}

/** Parse and check one manifest schedule entry; `where` names it in errors. */
export function scheduleFromEntry(entry: ScheduleEntry, steps: number, where: string): Schedule {
  const out: Partial<Schedule> = { steps };
  for (const key of ['time', 'coef1', 'coef2', 'sigma'] as const) {
    const v = (entry as unknown as Record<string, unknown>)[key];
    if (!Array.isArray(v) || v.length !== steps || !v.every((n) => typeof n === 'number' && Number.isFinite(n))) {
      throw new Error(`${where}.${key}: expected ${steps} finite numbers`);
    }
    out[key] = Float64Array.from(v as number[]);
  }
  return out as Schedule;
}

/**
 * The schedule for `steps` denoising steps of a manifest model entry: the manifest's
 * `schedules[steps]` when present, else computed (only for a step count the model declares in
 * `supportedSteps`, since the generator was trained on those).
 */
export function scheduleFor(
  model: { supportedSteps?: number[]; schedules?: Record<string, ScheduleEntry> },
  steps: number,
  modelName = 'model',
): Schedule {
  const supported = model.supportedSteps ?? [];
  if (!supported.includes(steps)) {
    throw new RangeError(
      `manifest models.${modelName}: ${steps} steps not supported (supportedSteps = [${supported.join(', ')}])`,
    );
  }
  const entry = model.schedules?.[String(steps)];
  if (entry) return scheduleFromEntry(entry, steps, `manifest models.${modelName}.schedules["${steps}"]`);
  return computeSchedule(steps);
}

/**
 * The DDIM view of the same T-step grid: x_i given x_0 is N(aCum[i]·x_0, sCum[i]²·I) for i = 0..T
 * (i = 0 is the data; aCum[0] = sqrt(1 − 1e-8), sCum[0] = 1e-4, as emdm.model.schedule's β_0 = 1e-8).
 */
export interface DdimSchedule {
  steps: number;
  /** time[k] = t_{k+1}, the continuous time given to the generator at step index k (same as Schedule.time) */
  time: Float64Array;
  /** T + 1 values: sqrt(ᾱ) of x_i relative to x_0 */
  aCum: Float64Array;
  /** T + 1 values: the standard deviation of x_i given x_0, sqrt(1 − aCum²) */
  sCum: Float64Array;
}

/** DDIM marginals for T steps (float64), mirroring emdm.model.schedule.make_schedule's a_cum / s_cum. */
export function computeDdimSchedule(
  steps: number,
  { betaMin, betaMax, eps }: { betaMin: number; betaMax: number; eps: number } = VP_DEFAULTS,
): DdimSchedule {
  if (!Number.isInteger(steps) || steps < 1) {
    throw new RangeError(`computeDdimSchedule: steps must be a positive integer, got ${steps}`);
  }
  const T = steps;
  const alphaBar = new Float64Array(T + 1);
  for (let i = 0; i <= T; i++) {
    const t = (i / T) * (1 - eps) + eps;
    const variance = 1 - Math.exp(2 * (-0.25 * t * t * (betaMax - betaMin) - 0.5 * t * betaMin));
    alphaBar[i] = 1 - variance; // written as in Python (1 − var), so the float64 roundings agree
  }
  const aCum = new Float64Array(T + 1);
  const sCum = new Float64Array(T + 1);
  const time = new Float64Array(T);
  // a_step[i] = sqrt(1 − β_i) with β_0 = 1e-8 and β_i = 1 − ᾱ_i / ᾱ_{i−1}; aCum = cumulative product
  let a = 1;
  for (let i = 0; i <= T; i++) {
    const beta = i === 0 ? 1e-8 : 1 - alphaBar[i] / alphaBar[i - 1];
    a *= Math.sqrt(1 - beta);
    aCum[i] = a;
    sCum[i] = Math.sqrt(1 - a * a);
    if (i > 0) time[i - 1] = (i / T) * (1 - eps) + eps;
  }
  return { steps: T, time, aCum, sCum };
}

/**
 * The DDIM schedule for `steps` steps of a manifest model entry (a model trained with
 * `--objective diffusion`): only for a step count the model declares in `supportedSteps`; when the
 * manifest lists `schedules[steps]`, its time grid must be the one the marginals are computed for.
 */
export function ddimScheduleFor(
  model: { supportedSteps?: number[]; schedules?: Record<string, ScheduleEntry> },
  steps: number,
  modelName = 'model',
): DdimSchedule {
  const supported = model.supportedSteps ?? [];
  if (!supported.includes(steps)) {
    throw new RangeError(
      `manifest models.${modelName}: ${steps} steps not supported (supportedSteps = [${supported.join(', ')}])`,
    );
  }
  const s = computeDdimSchedule(steps);
  const entry = model.schedules?.[String(steps)];
  if (entry) {
    const where = `manifest models.${modelName}.schedules["${steps}"].time`;
    const t = entry.time;
    if (!Array.isArray(t) || t.length !== steps) throw new Error(`${where}: expected ${steps} finite numbers`);
    for (let k = 0; k < steps; k++) {
      if (!(Math.abs(t[k] - s.time[k]) <= 1e-6)) {
        throw new Error(`${where}[${k}] = ${t[k]} is not the VP grid's ${s.time[k]} (β_min 0.1, β_max 20, ε 1e-3): DDIM cannot sample this model`);
      }
    }
  }
  return s;
}
