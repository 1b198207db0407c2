/**
 * The variance-preserving diffusion schedule and the DDGAN posterior q(x_{k} | x_{k+1}, x0)
 * (docs/ARCHITECTURE.md "Diffusion schedule"). Pure float64 math; the manifest carries the same
 * numbers per step count and `scheduleFor` prefers them, so Python and TypeScript share one source.
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
