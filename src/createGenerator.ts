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
 *   while generating) are src/loadModel.ts's; the results are bit-identical on the same backend.
 */
import { type EditCondition, EditError, type EditMotion, type Timeline, type TimelineSegment } from './edit';
import type { GenerateResult, SampleState } from './openModel';
import { type Manifest, chooseVariant, loadManifest } from './manifest';
import type { Motion } from './motion/types';
import { type BeginRequest, type MotionRequest, beginByModel, modelFor, resolveRequest, wireBegin } from './requests';
import type { Backend, BackendRequest } from './runtime/ort';
import type { SamplingSettings } from './sampler/settings';
import type { Skeleton } from './skeleton';
import { GenerationClient, type ClientEvents } from './worker/client';
import type { TimelineRequest, TimelineResult, WindowRun } from './worker/generationHost';
import type { WireGenerateOptions } from './worker/protocol';
import { liveCondition } from './live/core';
import { type LiveHooks, type LiveOptions, type LiveStream, startLive } from './live/stream';
import { solvePose } from './motion/ik';

export type { BeginRequest, MotionRequest } from './requests';

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
  /** run in a Web Worker (default: true on a browser page's thread; false in Node and inside a worker) */
  worker?: boolean;
  /** keep verified model files in Cache Storage (worker only; default true) */
  cache?: boolean;
  /** bytes fetched of the files a model load needs */
  onDownload?: (model: string, loaded: number, total: number) => void;
  /** a model runs on WASM instead of WebGPU, and why */
  onFallback?: (model: string, reason: string) => void;
}

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
  /** a text prompt far from what the model does well, and the closest prompts that work (absent: no capabilities file) */
  promptCheck?: GenerateResult['promptCheck'];
}

/** Options of MotionGenerator.timeline; `steps` and `guidance` (SamplingSettings) are every window's (default: the models' manifest defaults). */
export interface TimelineCallOptions extends Partial<Pick<SamplingSettings, 'steps' | 'guidance'>> {
  /** an earlier result: its segments equal to the new list's first ones are reused as they were (the rest continue from them) */
  previous?: GeneratedTimeline | null;
  signal?: AbortSignal;
  /** before each window: its segment, windows done and to do */
  onWindow?: (segment: number, done: number, total: number) => void;
  /** a denoising step: of `together` windows begun at once, or (together = 0) of the window being finished */
  onStep?: (done: number, total: number, together: number) => void;
}

/** A timeline's motion: joints as shown (smoothed, feet cleaned up) with their pose, and src/edit.ts's Timeline. */
export interface GeneratedTimeline extends Motion {
  features: Float32Array;
  pose: GeneratedMotion['pose'];
  /** the first frame of each segment */
  starts: number[];
  /** the segments, their windows and the raw decoded joints (what later edits start from) */
  timeline: Timeline;
  /** what each window generated by this call took (none when every segment was reused) */
  windows: WindowRun[];
}

/** Options of MotionGenerator.live: the first prompt or action, the seed, the window settings (src/live/core.ts) and every window's steps and guidance. */
export interface LiveCallOptions extends LiveOptions, Partial<Pick<SamplingSettings, 'steps' | 'guidance'>> {}

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
  /**
   * A timeline of prompts and actions, up to 60 s (src/edit.ts's generateTimeline, run where the models are: in the
   * worker, one request for the whole timeline). Bad input rejects with an EditError naming the segment.
   */
  timeline(segments: readonly TimelineSegment[], options?: TimelineCallOptions): Promise<GeneratedTimeline>;
  /**
   * A live stream (src/live/stream.ts): motion made ahead of playback in short windows, each a timeline window
   * continuing the motion being played (generate with `known`: in the worker where there is one); `prompt()` changes
   * what comes next, `frameAt(t)` never waits. Resolves once its first window is ready. Bad input: EditError.
   */
  live(options: LiveCallOptions): Promise<LiveStream>;
  dispose(): Promise<void>;
}

function defaultModelsUrl(): string {
  const base = (import.meta as unknown as { env?: { BASE_URL?: string } }).env?.BASE_URL;
  if (base === undefined || typeof location === 'undefined') {
    throw new Error('createGenerator: no baseUrl given; pass the models folder (the one holding manifest.json), e.g. {baseUrl: "/models/"}');
  }
  return new URL(`${base.endsWith('/') ? base : base + '/'}models/`, location.href).href;
}

/** Text / action / nothing → motion, with the manifest's defaults; see the header. */
export async function createGenerator(opts: CreateGeneratorOptions = {}): Promise<MotionGenerator> {
  const baseUrl = opts.baseUrl ?? defaultModelsUrl();
  const manifest = opts.manifest ?? (await loadManifest(baseUrl));
  // a page's thread: the worker. Not Node, whose global Worker ONNX Runtime's own module sets (worker_threads: a
  // second createGenerator in one process then started a browser worker there and crashed), nor a worker itself
  const inWorker = opts.worker ?? (typeof window !== 'undefined' && typeof Worker !== 'undefined');
  if (opts.threads !== undefined && !(Number.isInteger(opts.threads) && opts.threads >= 1)) {
    throw new RangeError(`createGenerator: threads must be a whole number ≥ 1 (WASM threads), got ${String(opts.threads)}`);
  }
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

  const timelineRequest = (segments: readonly TimelineSegment[], o: TimelineCallOptions): TimelineRequest => ({
    segments: segments.map((seg) => ({ ...seg })), previous: o.previous?.timeline ?? null,
    ...(o.steps !== undefined ? { steps: o.steps } : {}), ...(o.guidance !== undefined ? { guidance: o.guidance } : {}),
    ...(opts.variant !== undefined ? { variant: opts.variant } : {}),
  });

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
      async timeline(segments, o = {}) {
        const r = await client.timeline(timelineRequest(segments, o), { pose: true, signal: o.signal, onWindow: o.onWindow, onStep: o.onStep });
        if (!r.pose) throw new Error('generation worker: the timeline has no pose (IK) although it was asked for');
        return timelineOf(r, r.pose);
      },
      live(o) {
        return liveOn(this as MotionGenerator, o, (joints, frames) => client.solve(joints, frames));
      },
      dispose: () => client.dispose(),
    };
  }

  // in-process: loaded on demand, so a page that uses the worker does not carry the sampler and ORT glue
  const { GenerationHost } = await import('./worker/generationHost');
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
      const { gen, result, pose } = await host.generate(model, { ...options, signal: req.signal, onStep: req.onStep }, variantOf(model), true);
      return motionOf(model, options, result, gen.backend, pose!);
    },
    begin: (reqs, signal) => beginByModel(reqs, (r) => modelFor(manifest, r), async (model, rs) => (await host.begin(model, rs.map((r) => ({ ...wireBegin(manifest, r), signal })), variantOf(model))).states),
    async timeline(segments, o = {}) {
      const r = await host.timeline(timelineRequest(segments, o), { signal: o.signal, onWindow: o.onWindow, onStep: o.onStep }, true);
      return timelineOf(r, r.pose!);
    },
    live(o) {
      return liveOn(this as MotionGenerator, o, async (joints, frames) => host.pose(joints, frames));
    },
    dispose: () => host.dispose(),
  };
}

/**
 * What a live stream needs of a generator: its manifest, skeleton and `generate` (a MotionGenerator is one; the demo
 * page passes its own worker session's, web/ui/live.ts, so the stream runs on the models it already loaded).
 */
export type LiveHost = Pick<MotionGenerator, 'manifest' | 'skeleton'> & { generate(request: MotionRequest): Promise<EditMotion> };

/** A live stream whose windows are `g.generate` calls and whose windows' poses are `solveFrames` calls (so both run where
 * g's generations run: in its worker when it has one; without `solveFrames`, frameAt solves each frame it shows). */
export async function liveOn(g: LiveHost, o: LiveCallOptions, solveFrames?: LiveHooks['solveFrames']): Promise<LiveStream> {
  if (o === null || typeof o !== 'object') throw new EditError(`live: options must be an object such as {prompt: 'a person walks'}, got ${String(o)}`);
  const { steps, guidance, ...live } = o;
  const first = liveCondition({ prompt: live.prompt, action: live.action });
  let entry;
  try {
    entry = g.manifest.models[modelFor(g.manifest, first.action !== undefined ? { action: first.action } : {})];
  } catch (e) {
    throw new EditError(`live: ${(e as Error).message}`);
  }
  const limits = { fps: entry.fps, maxFrames: entry.maxFrames };
  const sampling = { ...(steps !== undefined ? { steps } : {}), ...(guidance !== undefined ? { guidance } : {}) };
  const check = (c: EditCondition) => {
    try {
      resolveRequest(g.manifest, { ...c, ...sampling, frames: 1, seed: 0 });
    } catch (e) {
      throw new EditError(`live: ${(e as Error).message}`);
    }
  };
  const solve = (joints: Float32Array) => {
    const p = solvePose(joints, 1, g.skeleton);
    return { rootPos: p.rootPos, quats: p.quats, offsets: p.offsets };
  };
  return startLive((r) => g.generate({ ...r, ...sampling }), limits, live, { solve, solveFrames, check });
}

function timelineOf(r: TimelineResult, pose: GeneratedMotion['pose']): GeneratedTimeline {
  const t = r.timeline;
  return {
    frames: t.frames, fps: t.fps, joints: r.display, features: t.features, pose: { rootPos: pose.rootPos, quats: pose.quats },
    starts: t.starts, timeline: t, windows: r.windows,
  };
}

function motionOf(model: string, o: WireGenerateOptions, r: GenerateResult, backend: Backend, pose: GeneratedMotion['pose']): GeneratedMotion {
  return {
    ...r.motion, model, backend, seed: o.seed, steps: r.steps, guidance: o.guidance,
    pose: { rootPos: pose.rootPos, quats: pose.quats }, timings: r.timings, prompt: r.prompt,
    ...(r.promptCheck ? { promptCheck: r.promptCheck } : {}),
  };
}
