/**
 * The sampler loop (docs/ARCHITECTURE.md "Sampling" and "DDIM sampling"), independent of ONNX: the
 * step model is a function, the noise a source, so tests can run it with fixture noise. The update rule is
 * the registry's (src/sampler/registry.ts: `settings.method`): the few-step DDGAN posterior (fresh z and ε every
 * step, ddgan.ts) for EMDM models and deterministic DDIM (z drawn then zeroed, no ε, ddim.ts) for the plain
 * diffusion baseline. With the settings' `known` and `keep` (src/sampler/mask.ts) the loop inpaints: docs/ARCHITECTURE.md
 * "Sampling with constraints".
 */
import { MAX_STEPS, MAX_X0_SMOOTHING } from '../manifest';
import { smoothPose } from '../motion/smooth';
import { samplerRule } from './registry';
import type { Schedule } from './schedule';
import type { SamplerName, SamplingSettings } from './settings';
import type { SamplerRule } from './update';

export type { SamplerName, SamplingSettings };

/** One call of the denoising step model: inputs in the ONNX contract layout, returns x0 [B, L, D]. */
export interface StepInputs {
  x: Float32Array; // [B, L, D]
  z: Float32Array; // [B, zDim]
  cond: Float32Array; // [B, C]
  t: Float32Array; // [B]
  mask: Float32Array; // [B, L]
  batch: number;
  frames: number;
}
export type StepFn = (inputs: StepInputs) => Promise<Float32Array>;

/** Where the random numbers come from; called in the documented order x_T, then per step z, ε. */
export interface NoiseSource {
  normals(n: number, what: 'xT' | 'z' | 'eps', stepIndex: number): Float32Array;
}

export class AbortError extends Error {
  constructor(message = 'generation cancelled') {
    super(message);
    this.name = 'AbortError';
  }
}

/**
 * One sampling run: the request's SamplingSettings as they came, inpainting (`known`, `keep`, `keepFromTime`)
 * included (`method` default 'ddgan'; the step count is the schedule's, made for `steps` by scheduleFor), the step
 * model, the noise and the model's shapes (Python's `z_dim`/`feature_dim` settings).
 */
export interface SampleOptions extends Omit<SamplingSettings, 'steps'> {
  /** the schedule of the settings' `steps` (one object holds every rule's coefficients: scheduleFor / computeSchedule) */
  schedule: Schedule;
  step: StepFn;
  noise: NoiseSource;
  frames: number;
  featureDim: number;
  zDim: number;
  /** condition vector [C]; a zero vector means unconditional */
  cond: Float32Array;
  /**
   * The model's mean and std of root velocity channels 1 and 2, [m1, m2, s1, s2] (Python's `root_norm`; openModel
   * takes them from the model's meanstd): needed when `speedCap` > 0.
   */
  rootNorm?: readonly number[];
  /**
   * Stop before the first step whose time is ≤ stopAt (at the latest before the last step; with one step, before
   * it) and return the state there (`SampleResult.next`): the first part of a run that `resume` finishes — a
   * timeline window's steps before its context joins, sampled together with the other windows' (src/edit.ts,
   * src/sampler/lockstep.ts). A run that stops before any step imposes the kept part may give `keep` without
   * `known` (the lead frames sit out all the same).
   */
  stopAt?: number;
  /**
   * Go on from a stopped run: its `x` (all L frames) before step `next`. x_T is not drawn; the noise source must go
   * on where the stopped run left off (the same object, or a SeededRandom restored from its state). The two parts
   * give the result of one whole run, bit for bit.
   */
  resume?: { x: Float32Array; next: number; speedRef?: number };
  signal?: AbortSignal;
  onStep?: (done: number, total: number) => void;
  /**
   * Each step's prediction x̂0 [L, D] (normalised, guided and inpainted as the update reads it), before
   * onStep. Only read when given (no copy otherwise); it draws no random numbers, so the result is the
   * same with or without it. The array is the caller's to keep.
   */
  onX0?: (x0: Float32Array, done: number, total: number) => void;
  now?: () => number;
}

export interface SampleResult {
  /** final x_0 in normalised feature space [L, D]; with `next`, the state x before step `next` */
  x: Float32Array;
  /** a run stopped by `stopAt`: the step to resume at (absent when every step ran, i.e. without stopAt) */
  next?: number;
  /** a stopped run with `speedCap`: its first conditional x̂0's median root speed (m per frame), for `resume` */
  speedRef?: number;
  stepMs: number[];
  modelCalls: number;
  /** steps that ran the unconditional row too (2 batch rows); the others ran 1 */
  guidedSteps: number;
  /** the update rule that ran (`settings.method`) */
  sampler: SamplerName;
}

function throwIfAborted(signal: AbortSignal | undefined, done: number, total: number): void {
  if (signal?.aborted) {
    const err = new AbortError(`generation cancelled after ${done} of ${total} steps`);
    (err as Error & { cause?: unknown }).cause = signal.reason;
    throw err;
  }
}

/** The coefficients the rule reads must be there, sized for the schedule's step count. */
function checkSchedule(s: Schedule, rule: SamplerRule): void {
  const T = s?.steps;
  if (!Number.isInteger(T) || T < 1 || T > MAX_STEPS) throw new Error(`sampler: schedule.steps must be an integer in 1…${MAX_STEPS}, got ${T} (see scheduleFor / computeSchedule)`);
  for (const [key, size] of Object.entries(rule.reads) as [keyof Schedule, 'steps' | 'steps+1'][]) {
    const n = size === 'steps' ? T : T + 1;
    const v = s[key] as ArrayLike<number> | undefined;
    if (v?.length !== n) {
      throw new Error(`sampler: method '${rule.name}' needs schedule.${key} of ${n} values for ${T} steps, got ${v?.length ?? 'none'} (see scheduleFor / computeSchedule)`);
    }
  }
}

function checkLength(a: Float32Array, n: number, what: string): void {
  if (a.length !== n) throw new Error(`sampler: ${what} has ${a.length} values, expected ${n}`);
}

/** Run T denoising steps from x_T ~ N(0, I); returns x_0 (normalised features). */
export async function sample(o: SampleOptions): Promise<SampleResult> {
  const { schedule, frames: L, featureDim: D, zDim, cond } = o;
  const rule = samplerRule(o.method ?? 'ddgan');
  checkSchedule(schedule, rule);
  const now = o.now ?? (() => performance.now());
  if (!Number.isInteger(L) || L < 1) throw new RangeError(`sampler: frames must be a positive integer, got ${L}`);
  if (!Number.isFinite(o.guidance)) throw new RangeError(`sampler: guidance must be a finite number, got ${o.guidance}`);
  const n = L * D;
  const C = cond.length;
  const conditioned = cond.some((v) => v !== 0);
  const guided = conditioned && o.guidance !== 1;
  const gMin = o.guidanceMinTime ?? 0;
  if (!Number.isFinite(gMin) || gMin < 0) throw new RangeError(`sampler: guidanceMinTime must be a finite time ≥ 0 (0 = guide every step), got ${gMin}`);
  const xs = o.x0Smoothing ?? 0;
  if (!Number.isFinite(xs) || xs < 0 || xs > MAX_X0_SMOOTHING) throw new RangeError(`sampler: x0Smoothing must be a finite σ ≥ 0 in frames (0 = off), got ${xs} (at most ${MAX_X0_SMOOTHING})`);
  const cap = o.speedCap ?? 0;
  if (!Number.isFinite(cap) || cap < 0) throw new RangeError(`sampler: speedCap must be a finite multiple ≥ 0 of the first step's root speed (0 = off), got ${cap}`);
  const norm = cap > 0 ? checkRootNorm(o.rootNorm) : null;
  const s = o.guidance;
  const T = schedule.steps;
  // the steps this call runs: from T − 1 (or resume.next) down to just above the first step with t ≤ stopAt
  const start = o.resume ? o.resume.next : T - 1;
  if (!Number.isInteger(start) || start < 0 || start >= T) throw new RangeError(`sampler: resume.next must be a step index in 0…${T - 1}, got ${o.resume?.next}`);
  if (o.stopAt !== undefined && !(Number.isFinite(o.stopAt) && o.stopAt >= 0)) throw new RangeError(`sampler: stopAt must be a finite time ≥ 0, got ${o.stopAt}`);
  let stop = -1;
  if (o.stopAt !== undefined) {
    while (stop + 1 < T && schedule.time[stop + 1] <= o.stopAt) stop++;
    stop = Math.max(stop, 0); // at the latest before the last step (which imposes any kept part)
  }
  const constraint = checkConstraint(o.known, o.keep, L, D, schedule);
  const keepFrom = o.keepFromTime ?? 1;
  if (!Number.isFinite(keepFrom) || keepFrom < 0) throw new RangeError(`sampler: keepFromTime must be a finite time ≥ 0 (1 = impose the kept part at every step), got ${keepFrom}`);
  /** the constraint imposed at step k: at the steps with t ≤ keepFromTime and at the last */
  const keptAt = (k: number): Constraint | null => (constraint && (schedule.time[k] <= keepFrom || k === 0) ? constraint : null);
  for (let k = start; k > stop; k--) {
    if (keptAt(k) && !constraint!.known) throw new Error(`sampler: the kept part is imposed at step ${k} (t = ${schedule.time[k]}), so known is needed; give it, or stop this run before (stopAt)`);
  }

  throwIfAborted(o.signal, 0, T);
  const first = keptAt(T - 1);
  let x: Float32Array;
  if (o.resume) {
    x = Float32Array.from(o.resume.x);
    checkLength(x, n, 'resume.x');
  } else {
    x = Float32Array.from(o.noise.normals(n, 'xT', T));
    checkLength(x, n, 'x_T noise');
  }
  // a deferred kept part: its leading whole-kept frames sit out the steps before it is imposed
  const lead = constraint && !first ? leadFrames(constraint.keep, L, D) : 0;

  // inputs of a 2-row (guided: [c, 0]) and of a 1-row call, of all L frames or the L − lead free ones, made when first needed
  const rowBuffers = new Map<string, StepInputs>();
  const buffers = (B: number, frames: number): StepInputs => {
    const key = `${B}x${frames}`;
    let b = rowBuffers.get(key);
    if (!b) rowBuffers.set(key, (b = stepBuffers(B, frames, frames * D, zDim, cond)));
    return b;
  };
  // x̂0 of a step whose output is combined (guidance) or changed (the kept part): one buffer for the run
  const x0buf = new Float32Array(n);
  // speedCap: the first step's conditional x̂0's median root speed, from this run or from the part it resumes (a part
  // that stopped before any step has none: this one runs the first step)
  let speedRef = norm ? o.resume?.speedRef : undefined;
  if (norm && o.resume && start < T - 1 && speedRef === undefined) throw new Error('sampler: resume.speedRef is missing; a run with speedCap is resumed with the speedRef its first part returned');
  const stepMs: number[] = [];
  let modelCalls = 0;
  let guidedSteps = 0;

  for (let k = start; k > stop; k--) {
    throwIfAborted(o.signal, schedule.steps - 1 - k, schedule.steps);
    const t0 = now();
    // z is drawn at every step even for a rule that feeds zeros (DDIM), so the draw order is every rule's
    const drawn = o.noise.normals(zDim, 'z', k);
    checkLength(drawn, zDim, `z noise at step ${k}`);
    const z = rule.usesZ ? drawn : new Float32Array(zDim);
    const guidedK = guided && schedule.time[k] > gMin;
    const kept = keptAt(k);
    // the kept part enters x where it is first imposed: all of it at the first step (x_T's), or the lead frames
    if (kept && k === T - 1) imposeNoisedKnown(x, kept, T, n, schedule);
    else if (lead && kept && !keptAt(k + 1)) imposeNoisedKnown(x, kept, k + 1, lead * D, schedule);
    // the model sees frames [f0, L): all of them, or the free ones while the lead frames sit out
    const f0 = kept ? 0 : lead;
    const nk = n - f0 * D;
    const xk = f0 ? x.subarray(f0 * D) : x;
    const inputs = buffers(guidedK ? 2 : 1, L - f0);
    for (let b = 0; b < inputs.batch; b++) {
      inputs.x.set(xk, b * nk);
      inputs.z.set(z, b * zDim);
      inputs.t[b] = schedule.time[k];
    }
    const out = await o.step({ ...inputs });
    modelCalls++;
    if (guidedK) guidedSteps++;
    checkLength(out, inputs.batch * nk, `model output x0 at step ${k}`);
    if (norm && k === T - 1) speedRef = rootSpeed(out.subarray(0, nk), L - f0, D, norm); // row 0: the conditional one
    // x̂0 smoothed along time at every step but the last (x0Smoothing), before the kept part is replaced
    const smoothed = xs > 0 && k > 0 ? smoothPose(guidedK ? guidedX0(out, nk, s, x0buf) : out, L - f0, xs) : null;
    /** what onX0 sees: all L frames (the lead frames sitting out shown as their known motion) */
    const fullX0 = (x0: ArrayLike<number>): Float32Array => {
      const a = new Float32Array(n);
      if (f0 && constraint!.known) a.set(constraint!.known.subarray(0, f0 * D));
      a.set(x0, f0 * D);
      return a;
    };
    const x0 = smoothed ?? (guidedK ? guidedX0(out, nk, s, x0buf) : kept ? copyInto(x0buf, out) : out);
    if (kept) replaceKnown(x0, kept);
    const x0copy = o.onX0 ? fullX0(x0) : null;
    rule.update(xk, x0, k, schedule, { eps: () => drawEps(o.noise, n, k).subarray(f0 * D) });
    stepMs.push(now() - t0);
    if (x0copy) o.onX0!(x0copy, schedule.steps - k, schedule.steps);
    o.onStep?.(schedule.steps - k, schedule.steps);
  }
  if (norm && speedRef !== undefined && stop < 0) capRootSpeed(x, L, D, cap * speedRef, norm, constraint?.keep);
  return {
    x, ...(stop >= 0 ? { next: stop } : {}), ...(stop >= 0 && speedRef !== undefined ? { speedRef } : {}),
    stepMs, modelCalls, guidedSteps, sampler: rule.name,
  };
}

/** m per frame (0.5 m/s at 20 fps): a first x̂0 slower than this does not travel, and its motion is left alone (Python CAP_MIN_SPEED). */
export const CAP_MIN_SPEED = 0.5 / 20;

function checkRootNorm(norm: readonly number[] | undefined): readonly number[] {
  if (!norm || norm.length !== 4 || !norm.every(Number.isFinite) || !(norm[2] > 0 && norm[3] > 0)) {
    throw new RangeError(`sampler: speedCap needs rootNorm: the mean and std of root velocity channels 1 and 2 ([m1, m2, s1, s2], the model's meanstd, stds > 0), got ${JSON.stringify(norm)}`);
  }
  return norm.map(Math.fround);
}

/** The median horizontal root speed (m per frame) of normalised features x [frames, D], in float32 as numpy (Python `root_speeds`). */
export function rootSpeed(x: Float32Array, frames: number, D: number, norm: readonly number[]): number {
  const [m1, m2, s1, s2] = norm;
  const f = Math.max(frames, 1);
  const v = new Float32Array(f);
  for (let i = 0; i < f; i++) {
    const a = Math.fround(Math.fround(x[i * D + 1] * s1) + m1);
    const b = Math.fround(Math.fround(x[i * D + 2] * s2) + m2);
    v[i] = Math.fround(Math.hypot(a, b));
  }
  v.sort();
  const h = f >> 1;
  return f % 2 ? v[h] : Math.fround(Math.fround(v[h - 1] + v[h]) / 2);
}

/** x's root velocity channels scaled so its median speed is at most `capSpeed` (unless the reference did not travel), kept entries unchanged (Python `cap_root_speed`). */
function capRootSpeed(x: Float32Array, L: number, D: number, capSpeed: number, norm: readonly number[], keep: Float32Array | undefined): void {
  const cur = rootSpeed(x, L, D, norm);
  if (!(capSpeed >= CAP_MIN_SPEED && cur > capSpeed)) return;
  const r = Math.fround(capSpeed / cur);
  const [m1, m2, s1, s2] = norm;
  for (let i = 0; i < L; i++) {
    for (const [c, m, sd] of [[1, m1, s1], [2, m2, s2]] as const) {
      const j = i * D + c;
      if (keep && keep[j] > 0) continue;
      x[j] = Math.fround(Math.fround(Math.fround(Math.fround(Math.fround(x[j] * sd) + m) * r) - m) / sd);
    }
  }
}

/** ε of step k for all n values (frames sitting out included: the draws do not depend on who sits out), checked. */
function drawEps(noise: NoiseSource, n: number, k: number): Float32Array {
  const eps = noise.normals(n, 'eps', k);
  checkLength(eps, n, `ε noise at step ${k}`);
  return eps;
}

/** Step inputs for `B` rows of `L` frames: cond in row 0 (row 1, when there, stays zero: unconditional), mask all 1. */
function stepBuffers(B: number, L: number, n: number, zDim: number, cond: Float32Array): StepInputs {
  const c = new Float32Array(B * cond.length);
  c.set(cond, 0);
  return { x: new Float32Array(B * n), z: new Float32Array(B * zDim), cond: c, t: new Float32Array(B), mask: new Float32Array(B * L).fill(1), batch: B, frames: L };
}

/** `known` may be absent in a run that stops before the kept part is imposed (`stopAt`; checked by the caller). */
type Constraint = { known?: Float32Array; keep: Float32Array };

/** Both or neither (keep alone: see Constraint); [L, D] each; keep only 0/1; known finite where kept; the marginals the noising reads. */
function checkConstraint(known: Float32Array | undefined, keep: Float32Array | undefined, L: number, D: number, sch: Schedule): Constraint | null {
  if (known === undefined && keep === undefined) return null;
  if (!keep) throw new Error('sampler: inpainting needs both known (the motion to keep) and keep (its mask); give both or neither');
  if (known) checkLength(known, L * D, `known (frames ${L} × ${D})`);
  checkLength(keep, L * D, `keep (frames ${L} × ${D})`);
  for (let i = 0; i < keep.length; i++) {
    if (keep[i] !== 0 && keep[i] !== 1) throw new RangeError(`sampler: keep[${i}] is ${keep[i]}; the mask holds only 0 and 1 (build it with keepMask)`);
    if (known && keep[i] && !Number.isFinite(known[i])) throw new RangeError(`sampler: known is ${known[i]} at frame ${Math.floor(i / D)}, channel ${i % D}, which keep marks as kept`);
  }
  if (sch.aCum?.length !== sch.steps + 1 || sch.sCum?.length !== sch.steps + 1) {
    throw new Error(`sampler: inpainting needs schedule.aCum and schedule.sCum of ${sch.steps + 1} values (see scheduleFor / computeSchedule)`);
  }
  return { known, keep };
}

/** The kept part of x's first `upto` values := aCum[j]·known + sCum[j]·x (x_T's draw there; float32 operations, as
 * numpy in emdm.sample): x_T's when j = T, the lead frames' when they join at step j − 1. */
function imposeNoisedKnown(x: Float32Array, c: Constraint, j: number, upto: number, sch: Schedule): void {
  const a = Math.fround(sch.aCum[j]);
  const sd = Math.fround(sch.sCum[j]);
  for (let i = 0; i < upto; i++) {
    if (c.keep[i]) x[i] = Math.fround(Math.fround(a * c.known![i]) + Math.fround(sd * x[i]));
  }
}

/** How many leading frames `keep` [L, D] keeps on every channel, fewer than all (Python `emdm.sampler.lead_frames`). */
export function leadFrames(keep: ArrayLike<number>, L: number, D: number): number {
  let f = 0;
  for (; f < L; f++) {
    for (let c = 0; c < D; c++) if (keep[f * D + c] !== 1) return f;
  }
  return 0;
}

function replaceKnown(x0: Float32Array, c: Constraint): void {
  for (let i = 0; i < x0.length; i++) if (c.keep[i]) x0[i] = c.known![i];
}

/** `from` copied into the start of `into` (the step model's output stays as it came). */
function copyInto(into: Float32Array, from: Float32Array): Float32Array {
  const x0 = into.subarray(0, from.length);
  x0.set(from);
  return x0;
}

/** x0 = x0_u + s·(x0_c − x0_u) from a batched [cond, uncond] output, rounded to float32 like Python. */
function guidedX0(out: Float32Array, n: number, s: number, into: Float32Array): Float32Array {
  const x0 = into.subarray(0, n);
  for (let i = 0; i < n; i++) x0[i] = Math.fround(out[n + i] + Math.fround(s * Math.fround(out[i] - out[n + i])));
  return x0;
}

/** Noise from a seeded generator, drawn in the documented order. */
export function seededNoise(rng: { normals(n: number): Float32Array }): NoiseSource {
  return { normals: (n) => rng.normals(n) };
}
