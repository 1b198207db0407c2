/**
 * openModel: one model on one backend — text / action / nothing → 3-D motion. Wires the manifest
 * (verified downloads), the text encoder, the ONNX step model (src/runtime), the sampler (src/sampler)
 * and decoding (src/motion). Which backend, and falling back from WebGPU to WASM, is decided in ONE
 * place, src/loadModel.ts (loadModel, runWithFallback), which the library's entry createGenerator
 * (src/createGenerator.ts) runs through.
 */
import type { PromptCheck } from './capabilities';
import { type Condition, conditionEncoder } from './condition';
import { assertFinite } from './errors';
import { type Manifest, type ModelEntry, ModelFileError, fetchVerified } from './manifest';
import { decodeJoints } from './motion/decode';
import { denormalize, parseMeanStd } from './motion/recover';
import { pinKeptRoot } from './motion/stitch';
import type { Motion } from './motion/types';
import { type Backend, type OrtSession, getSession } from './runtime/ort';
import { IncompatibleModelError, stepFunction } from './runtime/stepModel';
import { together } from './sampler/lockstep';
import { type RandomState, SeededRandom } from './sampler/rng';
import { type NoiseSource, type SampleOptions, type StepFn, sample } from './sampler/sampler';
import { type RequestSettings, type SamplerName, inpaintingSettings, methodOf } from './sampler/settings';
import type { KnownMotion } from './sampler/mask';
import { type Schedule, scheduleFor } from './sampler/schedule';
import type { TextEncoder } from './text';

export type { Condition };

/** One generation on one model: what to generate, its SamplingSettings (steps and guidance given; `method`, `guidanceMinTime` and `x0Smoothing` default to the model's; inpainting as `known`), and how to report. */
export interface GenerateOptions extends RequestSettings {
  condition: Condition;
  /** motion length in frames at 20 fps (1 … maxFrames) */
  frames: number;
  /** uint32 seed: the same seed gives bit-identical output in Node and the browser (same backend) */
  seed: number;
  signal?: AbortSignal;
  onStep?: (done: number, total: number) => void;
  /** Gaussian temporal smoothing of the joints (σ = 1 frame); default false */
  smooth?: boolean;
  /** pin feet the model marks in contact and keep them above the floor; default false */
  footCleanup?: boolean;
  /** replace the seeded noise (tests: reproduce a Python run with its noise) */
  noise?: NoiseSource;
  /**
   * Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"): keep the entries of `features`
   * (frames × featureDim, de-normalised like `Motion.features`) where `keep` (`keepMask`) is 1; the rest is
   * generated around them. The result's features equal `features` there (up to float rounding), and kept
   * frames decode to `recoverJoints(features)`'s joints (free frames' root velocities are adjusted: `pinKeptRoot`).
   * `fromTime`: the sampler's `keepFromTime` (default every step). The sampler's settings get it normalised
   * (`inpaintingSettings`: SamplingSettings' `known`, `keep`, `keepFromTime`).
   */
  known?: KnownMotion;
  /**
   * Go on from where `Generator.begin` stopped this request (the same options, now with `known.features` when it
   * keeps something): the result is that of one whole generation with the seed, bit for bit on the same backend.
   */
  resume?: SampleState;
  /**
   * Watch it denoise: each step's prediction x̂0, decoded to a motion exactly as the final result is
   * (de-normalised, joints recovered, smoothed and cleaned up as asked), after the step and before the
   * next one runs. It draws no random numbers: the final result is bit-identical with or without it.
   * Costs nothing when absent.
   */
  onPreview?: (p: StepPreview) => void;
}

/** One step's prediction x̂0 as a motion (GenerateOptions.onPreview). */
export interface StepPreview {
  /** steps done (1 … steps) */
  step: number;
  steps: number;
  motion: Motion;
  /** time to decode it, ms */
  decodeMs: number;
}

export type { Motion };

export interface GenerateResult {
  motion: Motion;
  /** `stepMs`: this call's steps (a resumed run's: those after its begun part, which `begin` timed) */
  timings: { encodeMs: number; stepMs: number[]; decodeMs: number; totalMs: number; backend: Backend; threads: number };
  /** model calls that made the motion (a resumed run's include those of its begun part) */
  modelCalls: number;
  /** steps that ran the unconditional batch row too (guidance; only those above guidanceMinTime) */
  guidedSteps?: number;
  /** the sampler that ran (`method`): 'ddgan' (EMDM posterior, objective "ddgan") or 'ddim' (η = 0, objective "diffusion") */
  sampler: SamplerName;
  /** denoising steps run */
  steps: number;
  /** a text prompt's tokens: `truncated` when it had more than the encoder reads (manifest maxTokens) */
  prompt?: { tokens: number; maxTokens: number; truncated: boolean };
  /** a text prompt far from what the model does well (`known` false) and the closest prompts that work (src/capabilities.ts); absent without a capabilities file */
  promptCheck?: PromptCheck;
}

/**
 * A request to `Generator.begin`: a generation's options and `stopAt`, the time before which it stops (the sampler's
 * stopAt). It may keep `known.keep` without `known.features` when it stops before they are imposed.
 */
export type BeginOptions = Omit<GenerateOptions, 'known' | 'resume' | 'onPreview'> & {
  stopAt: number;
  known?: Omit<KnownMotion, 'features'> & { features?: Float32Array };
};

/**
 * A generation stopped part way (`Generator.begin`), to be finished by `generate({ ...sameOptions, resume })`: plain
 * numbers and arrays, so it can cross to and from a worker.
 */
export interface SampleState {
  /** x before step `next`, normalised, frames × featureDim */
  x: Float32Array;
  frames: number;
  steps: number;
  /** the denoising step to run next (index into the schedule, counting down) */
  next: number;
  /** the seeded noise's state there (absent when the request gave its own noise source: pass the same one again) */
  rng?: RandomState;
  /** with a speed cap (`speedCap`): the first step's conditional root speed, m per frame, that the finished run is held to */
  speedRef?: number;
  /** the model calls (and of them the guided steps) the stopped part ran: the finished run's counts include them */
  modelCalls?: number;
  guidedSteps?: number;
}

export interface Generator {
  readonly modelName: string;
  readonly backend: Backend;
  readonly threads: number;
  readonly entry: ModelEntry;
  /** the sampler this model's objective calls for: 'ddgan' or 'ddim' */
  readonly sampler: SamplerName;
  /** Rejects with NonFiniteMotionError (src/errors.ts) when the model's output holds NaN or ±Infinity. */
  generate(o: GenerateOptions): Promise<GenerateResult>;
  /**
   * Start several generations together, one model call per step for all of them, and stop each before its first
   * step whose time is ≤ its `stopAt`; `generate({ ...o, resume: state })` finishes each. A timeline's windows
   * (src/edit.ts) are begun together: their steps before their context joins need nothing from one another.
   * On a step model that is not `batchesExactly` the requests run one by one instead (each as generate would).
   */
  begin(os: readonly BeginOptions[]): Promise<SampleState[]>;
  /**
   * Whether a row's result is the same in any batch (fp32, fp16). A model that quantises its activations per call
   * (DynamicQuantizeLinear: the int8 files) rounds each row by a scale shared with the batch, so the same request
   * gives another motion in another batch (a timeline regenerated from segment 2 differed from the same timeline
   * loaded from its URL by up to 22 cm): `begin` then runs its requests alone, and every result depends only on its
   * own request.
   */
  readonly batchesExactly: boolean;
  dispose(): Promise<void>;
}

export interface GeneratorOptions {
  manifest: Manifest;
  baseUrl: string;
  model: string;
  /** the backend to open the model on (default 'wasm'); choosing and falling back: src/loadModel.ts */
  backend?: Backend;
  threads?: number;
  /** a variant key of the model entry (e.g. 'int8') instead of the fp32 `onnx` file */
  variant?: string;
  /** where ORT's wasm is served (browser); default `<BASE_URL>ort/` */
  wasmPaths?: string;
  onDownload?: (loaded: number, total: number) => void;
  /** reuse an already created text encoder (else one is created on the first text prompt) */
  textEncoder?: TextEncoder;
}

const now = () => performance.now();

function modelEntry(manifest: Manifest, name: string): ModelEntry {
  const entry = manifest.models[name];
  if (!entry) {
    const have = Object.keys(manifest.models);
    throw new ModelFileError('manifest.json', 'missing', `field 'models.${name}' not found (models: ${have.length ? have.join(', ') : 'none'})`);
  }
  for (const k of ['featureDim', 'zDim', 'maxFrames', 'fps'] as const) {
    if (!Number.isInteger(entry[k]) || entry[k] <= 0) {
      throw new ModelFileError('manifest.json', 'incompatible', `field 'models.${name}.${k}' must be a positive integer`);
    }
  }
  const objective = entry.objective ?? 'ddgan';
  if (objective !== 'ddgan' && objective !== 'diffusion') {
    throw new ModelFileError('manifest.json', 'incompatible', `field 'models.${name}.objective' is ${JSON.stringify(objective)}; expected "ddgan" (sampled with the DDGAN posterior) or "diffusion" (sampled with DDIM)`);
  }
  if (!entry.condition || !Number.isInteger(entry.condition.dim)) {
    throw new ModelFileError('manifest.json', 'incompatible', `field 'models.${name}.condition.dim' must be an integer`);
  }
  return entry;
}

/** Whether an ONNX file quantises activations at run time (a DynamicQuantizeLinear node: the op's name is in the bytes). */
export function quantisesPerCall(onnx: ArrayBuffer | Uint8Array): boolean {
  const b = onnx instanceof Uint8Array ? onnx : new Uint8Array(onnx);
  const op = 'DynamicQuantizeLinear';
  const first = op.charCodeAt(0);
  outer: for (let i = b.indexOf(first); i >= 0 && i + op.length <= b.length; i = b.indexOf(first, i + 1)) {
    for (let k = 1; k < op.length; k++) if (b[i + k] !== op.charCodeAt(k)) continue outer;
    return true;
  }
  return false;
}

/** A request's frames, guidance, step count (its schedule for `method`, returned) and resume state, checked against the model before anything runs. */
function checkedSchedule(o: GenerateOptions | BeginOptions, entry: ModelEntry, model: string, method: SamplerName): Schedule {
  if (!Number.isInteger(o.frames) || o.frames < 1 || o.frames > entry.maxFrames) {
    throw new RangeError(`generate: frames must be an integer in 1…${entry.maxFrames}, got ${o.frames}`);
  }
  if (!Number.isFinite(o.guidance) || o.guidance < 0) throw new RangeError(`generate: guidance must be a finite number ≥ 0, got ${o.guidance}`);
  const schedule = scheduleFor(entry, o.steps, model, method);
  const resume = 'resume' in o ? o.resume : undefined;
  if (resume && (resume.frames !== o.frames || resume.steps !== o.steps)) {
    throw new RangeError(`generate: resume is a state of ${resume.frames} frames and ${resume.steps} steps; this request asks for ${o.frames} frames and ${o.steps} steps (resume with the options it was begun with)`);
  }
  return schedule;
}

/** The verified files of a model (its step model and mean/std), fetched together with one combined progress. */
function fetchFiles(o: GeneratorOptions, paths: string[]): Promise<ArrayBuffer[]> {
  const sizes = paths.map((p) => o.manifest.files[p]?.bytes ?? 0);
  const total = sizes.reduce((a, b) => a + b, 0);
  const loaded = paths.map(() => 0);
  const progress = (i: number) => (l: number) => {
    loaded[i] = l;
    o.onDownload?.(loaded.reduce((a, b) => a + b, 0), total);
  };
  return Promise.all(paths.map((p, i) => fetchVerified(o.baseUrl, o.manifest, p, progress(i))));
}

/**
 * The step model's session and checked step function on exactly one backend (a 2-frame warm-up call checks the shapes
 * and compiles kernels before the first prompt). On WASM every failure is the model's fault (ModelFileError
 * 'incompatible'); on WebGPU it is a plain Error (a backend problem: src/loadModel.ts then opens WASM).
 */
async function openStep(bytes: ArrayBuffer, b: Backend, o: GeneratorOptions & { onnxPath: string; entry: ModelEntry }): Promise<{ session: OrtSession; step: StepFn }> {
  const { onnxPath, entry } = o;
  const D = entry.featureDim;
  const C = entry.condition.dim;
  let session: OrtSession;
  try {
    session = await getSession(`${onnxPath}#${o.manifest.files[onnxPath].sha256}`, bytes, b, { threads: o.threads, wasmPaths: o.wasmPaths });
  } catch (e) {
    if (b === 'webgpu') throw e;
    throw new ModelFileError(onnxPath, 'incompatible', (e as Error).message);
  }
  try {
    const st = stepFunction(session, { featureDim: D, zDim: entry.zDim, condDim: C }, onnxPath);
    await st({ x: new Float32Array(2 * D), z: new Float32Array(entry.zDim), cond: new Float32Array(C), t: Float32Array.of(0.5), mask: new Float32Array(2).fill(1), batch: 1, frames: 2 });
    return { session, step: st };
  } catch (e) {
    await session.release();
    if (e instanceof IncompatibleModelError) throw new ModelFileError(onnxPath, 'incompatible', e.message.replace(`${onnxPath}: `, ''));
    if (b === 'webgpu') throw new Error(`runtime: ${onnxPath} does not run on WebGPU: ${(e as Error).message}`, { cause: e });
    throw new ModelFileError(onnxPath, 'incompatible', `the step model does not run with the manifest's shapes (featureDim ${D}, zDim ${entry.zDim}, condition dim ${C}): ${(e as Error).message}`);
  }
}

/** The sampler's speed cap options: `speedCap` with the model's root velocity normalisation, or none when 0. */
function speedCapOptions(speedCap: number, mean: Float32Array, std: Float32Array): Pick<SampleOptions, 'speedCap' | 'rootNorm'> {
  return speedCap > 0 ? { speedCap, rootNorm: [mean[1], mean[2], std[1], std[2]] } : {};
}

/**
 * Open a model on exactly `opts.backend`. Fails with ModelFileError when a file is missing, corrupt or
 * does not fit the manifest; a WebGPU session that cannot run fails with a plain Error (a backend
 * problem: src/loadModel.ts then opens WASM).
 */
export async function openModel(opts: GeneratorOptions): Promise<Generator> {
  const { manifest, baseUrl, model } = opts;
  const entry = modelEntry(manifest, model);
  const onnxPath = opts.variant ? entry.variants?.[opts.variant] : entry.onnx;
  if (!onnxPath) {
    throw new ModelFileError('manifest.json', 'missing', `models.${model}.variants has no '${opts.variant}' (variants: ${Object.keys(entry.variants ?? {}).join(', ') || 'none'})`);
  }
  const D = entry.featureDim;
  const samplerName = methodOf(entry.objective);

  const [bytes, msBuf] = await fetchFiles(opts, [onnxPath, entry.meanStd]);
  const { mean, std } = parseMeanStd(msBuf, D, entry.meanStd);

  const batchesExactly = !quantisesPerCall(bytes);
  const backend: Backend = opts.backend ?? 'wasm';
  if (backend !== 'wasm' && backend !== 'webgpu') throw new RangeError(`openModel: backend must be 'wasm' or 'webgpu', got ${JSON.stringify(backend)} (choosing one: loadModel in src/loadModel.ts)`);
  const { session, step } = await openStep(bytes, backend, { ...opts, onnxPath, entry });

  const condition = conditionEncoder({ manifest, baseUrl, model, textEncoder: opts.textEncoder });
  let queue: Promise<unknown> = Promise.resolve();
  let disposed = false;

  /** Normalised features x [L, D] (the sampler's x0) → de-normalised features and joints, checked: the final result's and every step preview's one path. */
  function decode(x: Float32Array, o: GenerateOptions): { features: Float32Array; joints: Float32Array } {
    // kept frames after free ones: their root is pinned where the known motion has it (src/motion/stitch.ts)
    const features = o.known ? pinKeptRoot(denormalize(x, mean, std), o.frames, o.known.keep, o.known.features, D) : denormalize(x, mean, std);
    assertFinite(features, `model ${model} (${onnxPath}) output features`);
    const joints = decodeJoints(features, o.frames, manifest.skeleton, o, D);
    assertFinite(joints, `joints decoded from model ${model}'s output`);
    return { features, joints };
  }

  /** The sampler's options for a request (checked; its condition encoded), all but the step function. */
  async function samplerOptions(o: GenerateOptions | BeginOptions, noise: NoiseSource): Promise<{ options: Omit<SampleOptions, 'step'>; prompt: GenerateResult['prompt']; check?: PromptCheck }> {
    if (disposed) throw new Error(`generator for ${model} was disposed`);
    const method = o.method ?? samplerName;
    const schedule = checkedSchedule(o, entry, model, method);
    const resume = 'resume' in o ? o.resume : undefined;
    const cond = await condition.vector(o.condition);
    const prompt = o.condition.type === 'text' ? await condition.tokens(o.condition.text) : undefined;
    const check = o.condition.type === 'text' ? await condition.check(cond) : undefined;
    return {
      prompt, ...(check ? { check } : {}),
      options: {
        method, schedule, noise, frames: o.frames, featureDim: D, zDim: entry.zDim, cond, guidance: o.guidance,
        guidanceMinTime: o.guidanceMinTime ?? entry.guidanceMinTime ?? 0, x0Smoothing: o.x0Smoothing ?? entry.x0Smoothing ?? 0, signal: o.signal, onStep: o.onStep,
        ...speedCapOptions(o.speedCap ?? entry.speedCap ?? 0, mean, std),
        ...inpaintingSettings(o.known, mean, std),
        ...(resume ? { resume: { x: resume.x, next: resume.next, ...(resume.speedRef !== undefined ? { speedRef: resume.speedRef } : {}) } } : {}),
      },
    };
  }

  /** One generation (or begin) at a time per generator: ORT sessions are not re-entrant. */
  function inTurn<T>(job: () => Promise<T>): Promise<T> {
    const p = queue.then(job);
    queue = p.catch(() => undefined);
    return p;
  }

  async function begin(os: readonly BeginOptions[]): Promise<SampleState[]> {
    if (!Array.isArray(os) || os.length === 0) throw new RangeError('begin: give at least one request');
    const rngs = os.map((o) => (o.noise ? null : new SeededRandom(o.seed)));
    const runs: Omit<SampleOptions, 'step'>[] = [];
    for (const [i, o] of os.entries()) {
      const { options } = await samplerOptions(o, o.noise ?? rngs[i]!);
      if (typeof o.stopAt !== 'number') throw new RangeError(`begin: request ${i + 1} needs stopAt, the time before which it stops (got ${o.stopAt})`);
      runs.push({ ...options, stopAt: o.stopAt });
    }
    const done: Awaited<ReturnType<typeof sample>>[] = [];
    if (batchesExactly) done.push(...(await together(step, runs.map((r) => (st: StepFn) => sample({ ...r, step: st })))));
    else for (const r of runs) done.push(await sample({ ...r, step }));
    return done.map((r, i) => ({ x: r.x, frames: os[i].frames, steps: os[i].steps, next: r.next!, modelCalls: r.modelCalls, guidedSteps: r.guidedSteps,
      ...(r.speedRef !== undefined ? { speedRef: r.speedRef } : {}), ...(rngs[i] ? { rng: rngs[i]!.state() } : {}) }));
  }

  async function run(o: GenerateOptions): Promise<GenerateResult> {
    const t0 = now();
    const noise = o.noise ?? (o.resume?.rng ? SeededRandom.fromState(o.resume.rng) : new SeededRandom(o.seed));
    const { options, prompt, check } = await samplerOptions(o, noise);
    const t1 = now();
    const onPreview = o.onPreview;
    const onX0 = onPreview && ((x0: Float32Array, done: number, total: number) => {
      const p0 = now();
      const { features, joints } = decode(x0, o);
      onPreview({ step: done, steps: total, motion: { frames: o.frames, fps: entry.fps, joints, features }, decodeMs: now() - p0 });
    });
    const r = await sample({ ...options, step, ...(onX0 ? { onX0 } : {}) });
    const t2 = now();
    const { features, joints } = decode(r.x, o);
    const t3 = now();
    return {
      motion: { frames: o.frames, fps: entry.fps, joints, features },
      timings: { encodeMs: t1 - t0, stepMs: r.stepMs, decodeMs: t3 - t2, totalMs: t3 - t0, backend, threads: session.threads },
      modelCalls: r.modelCalls + (o.resume?.modelCalls ?? 0), // a resumed run's include its begun part's
      guidedSteps: r.guidedSteps + (o.resume?.guidedSteps ?? 0),
      sampler: r.sampler,
      steps: o.steps,
      ...(prompt ? { prompt } : {}),
      ...(check ? { promptCheck: check } : {}),
    };
  }

  return {
    modelName: model,
    backend,
    threads: session.threads,
    entry,
    sampler: samplerName,
    batchesExactly,
    generate: (o) => inTurn(() => run(o)),
    begin: (os) => inTurn(() => begin(os)),
    async dispose() {
      if (disposed) return;
      disposed = true;
      await queue;
      await session.release();
    },
  };
}
