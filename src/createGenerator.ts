/**
 * createGenerator: the library's entry (docs/ARCHITECTURE.md "TypeScript library").
 *
 * ```ts
 * const generator = await createGenerator();                       // <BASE_URL>models/, WebGPU → WASM
 * const motion = await generator.generate({ prompt: 'a person walks forward', seconds: 4 });
 * motion.joints; // frames × 22 × 3 positions (metres, Y up) at motion.fps; motion.pose: bone rotations
 * ```
 *
 * - Which model: a prompt goes to the manifest's text model, an action (label index or name) to its
 *   action model, neither to the text model unconditioned; `model` names one instead. Steps, guidance
 *   and the longest length come from that model's manifest entry.
 * - Where it runs: in the generation worker (src/worker) by default where a page can start one, so the
 *   page's thread only renders; in-process (`{worker: false}`, and always in Node). Both run
 *   GenerationHost, whose backend choice and fallbacks (WebGPU missing or failing → WASM, at load and
 *   while generating) are src/backends.ts's; the results are bit-identical on the same backend.
 */
import type { GenerateResult, SampleState } from './generate';
import { type Manifest, type ModelEntry, chooseVariant, loadManifest } from './manifest';
import type { Motion } from './motion/types';
import type { KnownMotion } from './sampler/mask';
import type { Backend, BackendRequest } from './runtime/ort';
import type { Skeleton } from './skeleton';
import { GenerationClient, type ClientEvents } from './worker/client';
import type { WireBeginOptions, WireGenerateOptions } from './worker/protocol';

export interface CreateGeneratorOptions {
  /** the models folder holding manifest.json (default `<BASE_URL>models/` in a Vite page; required in Node) */
  baseUrl?: string;
  /** an already loaded manifest (default: loaded from `baseUrl`) */
  manifest?: Manifest;
  /** 'auto' (default): WebGPU where it works, else WASM; 'wasm': WASM only */
  backend?: BackendRequest;
  /** WASM threads (default: up to 4 when cross-origin isolated, else 1) */
  threads?: number;
  /**
   * Which file of each model to run: 'fp32' or a variant of its manifest entry, e.g. 'int8' (4.3 instead of
   * 15.6 MB, about half the WASM compute per step, the same coverage per step count: docs/MODELS.md "Speed in
   * the browser"). Default: the entry's `defaultVariant` (the shipped EMDM models: int8), else fp32; the
   * manifest's chooseVariant decides, for the page too. Results are bit-identical between Node and the page.
   */
  variant?: string;
  /** run in a Web Worker (default: true where `Worker` exists, i.e. in browsers; false in Node) */
  worker?: boolean;
  /** keep verified model files in Cache Storage (worker only; default true) */
  cache?: boolean;
  /** bytes fetched of the files a model load needs */
  onDownload?: (model: string, loaded: number, total: number) => void;
  /** a model runs on WASM instead of WebGPU, and why */
  onFallback?: (model: string, reason: string) => void;
}

export interface MotionRequest {
  /** text prompt (text model) */
  prompt?: string;
  /** action label: its index or its name in the action model's labels */
  action?: number | string;
  /** a model of the manifest (default: chosen by prompt / action, see above) */
  model?: string;
  /** length in seconds (default: the model's longest, maxFrames / fps); `frames` wins when given */
  seconds?: number;
  frames?: number;
  /** denoising steps (default: the model's defaultSteps) */
  steps?: number;
  /** classifier-free guidance scale (default: the model's guidance) */
  guidance?: number;
  /** guide only the denoising steps whose time is above this, one batch row below (default: the model's guidanceMinTime, else every step) */
  guidanceMinTime?: number;
  /** smooth x̂0 along time (σ frames) at every denoising step but the last (default: the model's x0Smoothing, else off) */
  x0Smoothing?: number;
  /** uint32 seed: the same seed gives the same motion on the same backend (default: random) */
  seed?: number;
  smooth?: boolean;
  footCleanup?: boolean;
  /**
   * Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"; src/edit.ts builds these for timelines,
   * in-betweening, body-part edits and loops): keep the entries of `features` (frames × 263, de-normalised: an
   * earlier result's `features`) where `keep` (`keepMask(frames, …)`) is 1 and generate the rest. The arrays are
   * copied, not taken. Kept frames after free ones decode where the known motion has them (`pinKeptRoot`).
   * `fromTime`: impose them only at the steps with t ≤ it (and the last; default every step).
   */
  known?: KnownMotion;
  /** finish a generation `begin` started (its state; the request as it was begun, now with `known.features`) */
  resume?: SampleState;
  onStep?: (done: number, total: number) => void;
  signal?: AbortSignal;
}

/**
 * A request to `MotionGenerator.begin` (src/edit.ts's EditBeginRequest fits it): a generation stopped before its first
 * denoising step with t ≤ `stopAt`; `keep` (with `keepFromTime`) marks what it will keep once `known` is given.
 */
export type BeginRequest = Omit<MotionRequest, 'known' | 'resume' | 'onStep' | 'signal'> & { stopAt: number; keep?: Float32Array; keepFromTime?: number };

/** A motion and, in `features`, its frames × 263 de-normalised features: what `known` takes to continue or edit it. */
export interface GeneratedMotion extends Motion {
  model: string;
  backend: Backend;
  seed: number;
  steps: number;
  guidance: number;
  /** bone rotations solved from the joints (IK): the pelvis position and each joint's local rotation */
  pose: { rootPos: Float32Array /* frames × 3 */; quats: Float32Array /* frames × 22 × 4, xyzw */ };
  timings: GenerateResult['timings'];
  prompt?: GenerateResult['prompt'];
}

export interface MotionGenerator {
  readonly manifest: Manifest;
  readonly skeleton: Skeleton;
  /** whether the models run in a Web Worker */
  readonly inWorker: boolean;
  /** Load a model ahead of the first request (downloads, verifies, opens it); generate() loads on demand. */
  load(model?: string): Promise<{ model: string; backend: Backend; threads: number }>;
  generate(request: MotionRequest): Promise<GeneratedMotion>;
  /**
   * Start several generations together, one model call per step for those of one model (Generator.begin), each
   * stopped before its first step with t ≤ its stopAt; `generate({ ...request, resume: state })` finishes each. A
   * timeline passes it as `generateTimeline(..., { begin: (rs) => generator.begin(rs) })`.
   */
  begin(requests: readonly BeginRequest[], signal?: AbortSignal): Promise<SampleState[]>;
  dispose(): Promise<void>;
}

function defaultModelsUrl(): string {
  const base = (import.meta as unknown as { env?: { BASE_URL?: string } }).env?.BASE_URL;
  if (base === undefined || typeof location === 'undefined') {
    throw new Error('createGenerator: no baseUrl given; pass the models folder (the one holding manifest.json), e.g. {baseUrl: "/models/"}');
  }
  return new URL(`${base.endsWith('/') ? base : base + '/'}models/`, location.href).href;
}

/** The model a request runs on: `model`, else the manifest's EMDM model for the task (text for a prompt or nothing). */
export function modelFor(manifest: Manifest, req: Pick<MotionRequest, 'model' | 'action'>): string {
  if (req.model !== undefined) {
    if (!manifest.models[req.model]) throw new Error(`createGenerator: model '${req.model}' is not in the manifest (models: ${Object.keys(manifest.models).join(', ')})`);
    return req.model;
  }
  const task: ModelEntry['task'] = req.action !== undefined ? 'action' : 'text';
  const hits = Object.entries(manifest.models).filter(([, e]) => e.task === task);
  const hit = hits.find(([, e]) => (e.objective ?? 'ddgan') === 'ddgan') ?? hits[0];
  if (!hit) throw new Error(`createGenerator: the manifest has no ${task} model (models: ${Object.keys(manifest.models).join(', ') || 'none'})`);
  return hit[0];
}

function randomSeed(): number {
  return crypto.getRandomValues(new Uint32Array(1))[0];
}

/** The request as the generation host takes it (condition, frames, steps, guidance and seed filled in from the manifest). */
export function resolveRequest(manifest: Manifest, req: MotionRequest): { model: string; options: WireGenerateOptions } {
  if (req.prompt !== undefined && req.action !== undefined) throw new Error('generate: give a prompt or an action, not both');
  const model = modelFor(manifest, req);
  const entry = manifest.models[model];
  let condition: WireGenerateOptions['condition'];
  if (req.prompt !== undefined) condition = { type: 'text', text: req.prompt };
  else if (req.action !== undefined) {
    const labels = entry.condition.type === 'action' ? entry.condition.labels : [];
    const label = typeof req.action === 'number' ? req.action : labels.indexOf(req.action);
    if (label < 0) throw new RangeError(`generate: action '${req.action}' is not a label of ${model} (${labels.join(', ')})`);
    condition = { type: 'action', label };
  } else condition = { type: 'none' };
  let frames = req.frames;
  if (frames === undefined) {
    if (req.seconds !== undefined && !(req.seconds > 0)) throw new RangeError(`generate: seconds must be > 0, got ${req.seconds}`);
    frames = req.seconds === undefined ? entry.maxFrames : Math.min(entry.maxFrames, Math.max(1, Math.round(req.seconds * entry.fps)));
  }
  return {
    model,
    options: {
      condition, frames, steps: req.steps ?? entry.defaultSteps, guidance: req.guidance ?? entry.guidance,
      ...(req.guidanceMinTime !== undefined ? { guidanceMinTime: req.guidanceMinTime } : {}),
      ...(req.x0Smoothing !== undefined ? { x0Smoothing: req.x0Smoothing } : {}),
      seed: req.seed ?? randomSeed(), smooth: req.smooth, footCleanup: req.footCleanup,
      ...(req.known ? { known: { ...req.known, features: Float32Array.from(req.known.features), keep: Float32Array.from(req.known.keep) } } : {}),
      ...(req.resume ? { resume: req.resume } : {}),
    },
  };
}

/**
 * `begin` for requests of several models: one `run` per model (its requests in their order, one batch), the states
 * back in the requests' order. createGenerator's begin and the demo page's timeline both group this way.
 */
export async function beginByModel<R>(reqs: readonly R[], modelOf: (r: R) => string, run: (model: string, reqs: R[]) => Promise<SampleState[]>): Promise<SampleState[]> {
  const groups = new Map<string, number[]>();
  reqs.forEach((r, i) => {
    const m = modelOf(r);
    groups.set(m, [...(groups.get(m) ?? []), i]);
  });
  const states: SampleState[] = new Array(reqs.length);
  for (const [model, at] of groups) {
    const got = await run(model, at.map((i) => reqs[i]));
    at.forEach((i, j) => (states[i] = got[j]));
  }
  return states;
}

/** A begin request as the generation host takes it (resolveRequest's options, stopped at stopAt, keeping `keep`). */
function wireBegin(manifest: Manifest, r: BeginRequest): WireBeginOptions {
  const { stopAt, keep, keepFromTime, ...req } = r;
  const { smooth: _s, footCleanup: _f, ...wire } = resolveRequest(manifest, req).options;
  return { ...wire, stopAt, ...(keep ? { known: { keep: Float32Array.from(keep), fromTime: keepFromTime } } : {}) };
}

/** Text / action / nothing → motion, with the manifest's defaults; see the header. */
export async function createGenerator(opts: CreateGeneratorOptions = {}): Promise<MotionGenerator> {
  const baseUrl = opts.baseUrl ?? defaultModelsUrl();
  const manifest = opts.manifest ?? (await loadManifest(baseUrl));
  const inWorker = opts.worker ?? typeof Worker !== 'undefined';
  const backend = opts.backend ?? 'auto';
  const events: Partial<ClientEvents> = {
    download: (m, l, t) => opts.onDownload?.(m, l, t),
    fallback: (m, r) => opts.onFallback?.(m, r),
  };

  const variantOf = (model: string): string | undefined => {
    try {
      return chooseVariant(manifest, model, opts.variant);
    } catch (e) {
      throw new Error(`createGenerator: ${(e as Error).message}`);
    }
  };

  if (inWorker) {
    const client = new GenerationClient({ manifest, baseUrl, backend, threads: opts.threads, cache: opts.cache, events });
    return {
      manifest, skeleton: manifest.skeleton, inWorker,
      async load(model) {
        const name = model ?? modelFor(manifest, {});
        const info = await client.load(name, variantOf(name));
        return { model: info.model, backend: info.backend, threads: info.threads };
      },
      async generate(req) {
        const { model, options } = resolveRequest(manifest, req);
        const r = await client.generate(model, { ...options, pose: true, signal: req.signal, onStep: req.onStep }, variantOf(model));
        if (!r.pose) throw new Error('generation worker: the result has no pose (IK) although it was asked for');
        return motionOf(model, options, r, r.info.backend, r.pose);
      },
      begin: (reqs, signal) => beginByModel(reqs, (r) => modelFor(manifest, r), (model, rs) => client.begin(model, rs.map((r) => wireBegin(manifest, r)), variantOf(model), signal)),
      dispose: () => client.dispose(),
    };
  }

  // in-process: loaded on demand, so a page that uses the worker does not carry the sampler and ORT glue
  const [{ GenerationHost }, { solveIK }] = await Promise.all([import('./worker/host'), import('./motion/ik')]);
  const host = new GenerationHost({ manifest, baseUrl, backend, threads: opts.threads }, {
    download: (m, l, t) => events.download?.(m, l, t),
    fallback: (m, r) => events.fallback?.(m, r),
  });
  return {
    manifest, skeleton: manifest.skeleton, inWorker,
    async load(model) {
      const name = model ?? modelFor(manifest, {});
      const g = await host.load(name, variantOf(name));
      return { model: name, backend: g.backend, threads: g.threads };
    },
    async generate(req) {
      const { model, options } = resolveRequest(manifest, req);
      const { gen, result } = await host.generate(model, { ...options, signal: req.signal, onStep: req.onStep }, variantOf(model));
      const ik = solveIK(result.motion.joints, result.motion.frames, manifest.skeleton);
      return motionOf(model, options, result, gen.backend, { rootPos: ik.rootPos, quats: ik.quats });
    },
    begin: (reqs, signal) => beginByModel(reqs, (r) => modelFor(manifest, r), async (model, rs) => (await host.begin(model, rs.map((r) => ({ ...wireBegin(manifest, r), signal })), variantOf(model))).states),
    dispose: () => host.dispose(),
  };
}

function motionOf(model: string, o: WireGenerateOptions, r: GenerateResult, backend: Backend, pose: GeneratedMotion['pose']): GeneratedMotion {
  return {
    ...r.motion, model, backend, seed: o.seed, steps: r.steps, guidance: o.guidance,
    pose: { rootPos: pose.rootPos, quats: pose.quats }, timings: r.timings, prompt: r.prompt,
  };
}
