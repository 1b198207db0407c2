/**
 * The generation worker's state, without the messaging: the generators it has loaded (lazily, once
 * each) and the text encoders they share. The backend choice with its fallbacks (WebGPU missing or
 * failing at load → WASM, WebGPU failing while generating → reload on WASM and run again) is
 * src/loadModel.ts's; events say what happened (downloads, fallbacks) so the page can tell the user.
 * Runs wherever createGenerator (src/createGenerator.ts) runs it: the worker in the browser, or
 * in-process (Node, `{worker: false}`).
 */
import { loadModel, runWithFallback, withFallback } from '../loadModel';
import { type EditBegin, type EditCondition, EditError, type EditGenerate, type EditLimits, type Timeline, type TimelineSegment, generateTimeline } from '../edit';
import type { BeginOptions, GenerateOptions, GenerateResult, Generator, SampleState } from '../openModel';
import { type Manifest, chooseVariant } from '../manifest';
import { decodeJoints } from '../motion/decode';
import { type MotionPose, solvePose } from '../motion/ik';
import { beginByModel, modelFor, resolveRequest, wireBegin } from '../requests';
import { type BackendRequest, loadMark, preloadWasmRuntime } from '../runtime/ort';
import type { SamplingSettings } from '../sampler/settings';
import { createTextEncoder, type TextEncoder } from '../text';

export interface HostEvents {
  download(model: string, loaded: number, total: number): void;
  fallback(model: string, reason: string): void;
}

export interface HostOptions {
  manifest: Manifest;
  baseUrl: string;
  backend: BackendRequest;
  threads?: number;
}

/** A timeline to generate where the models are (GenerationHost.timeline; the worker's `timeline` message). */
/** `steps` and `guidance` (SamplingSettings): every window's (default: each model's manifest defaults). */
export interface TimelineRequest extends Partial<Pick<SamplingSettings, 'steps' | 'guidance'>> {
  segments: TimelineSegment[];
  /** the model of the prompt segments and of the action segments (default: the manifest's EMDM text / action model) */
  models?: { text?: string; action?: string };
  /** an earlier result's `timeline`: its segments equal to the new list's first ones are reused as they were */
  previous?: Timeline | null;
  /** the file asked for ('fp32' or a variant; absent: each model's manifest default): chooseVariant's choice, per model */
  variant?: string;
}

/** What one window's generation took: its GenerateResult without the motion, and its model. */
export type WindowRun = Omit<GenerateResult, 'motion'> & { model: string; frames: number };

export interface TimelineResult {
  /** src/edit.ts's Timeline (raw decoded joints, segments and their windows): give it back as `previous` */
  timeline: Timeline;
  /** the joints as a motion is shown: smoothed, feet cleaned up (decodeJoints, generate()'s decoding) */
  display: Float32Array;
  /** the windows this call generated, in order (none when every segment was reused) */
  windows: WindowRun[];
  /** ms the windows' early steps took, begun together */
  beginMs: number;
  /** ms of the whole call */
  totalMs: number;
}

export interface TimelineHooks {
  signal?: AbortSignal;
  /** before each window (src/edit.ts's onWindow): its segment, windows done and to do */
  onWindow?: (segment: number, done: number, total: number) => void;
  /** a denoising step: of `together` windows begun at once, or (together = 0) of the window being finished */
  onStep?: (done: number, total: number, together: number) => void;
}

export class GenerationHost {
  private readonly generators = new Map<string, Promise<Generator>>();
  private readonly encoders = new Map<string, Promise<TextEncoder>>();
  /** progress of every download under way, summed */
  private readonly downloads = new Map<string, [number, number]>();

  private runtime: Promise<void> | null = null;

  constructor(private readonly opts: HostOptions, private readonly events: HostEvents) {}

  /**
   * ONNX Runtime's WASM backend, fetched from the first moment (the text encoder runs on it whatever
   * the step model's backend), its bytes counted in `model`'s download progress beside the model files.
   */
  private preloadRuntime(model: string): Promise<void> {
    this.runtime ??= preloadWasmRuntime({ threads: this.opts.threads }, this.progress('runtime', model));
    const p = this.runtime;
    p.catch(() => {
      if (this.runtime === p) this.runtime = null;
    });
    return p;
  }

  get manifest(): Manifest {
    return this.opts.manifest;
  }

  /** The generator of a model (created on first use; a failed load is forgotten so it can be retried). */
  load(model: string, variant?: string): Promise<Generator> {
    const key = `${model}|${variant ?? ''}`;
    let g = this.generators.get(key);
    if (!g) {
      g = this.create(model, variant);
      this.generators.set(key, g);
      g.catch(() => this.generators.delete(key));
    }
    return g;
  }

  /**
   * Generate with a model; a WebGPU failure reloads the model on WASM (said with a fallback event) and runs again.
   * `pose`: also solve the motion's bone rotations (IK, `this.pose`).
   */
  async generate(model: string, o: GenerateOptions, variant?: string, pose = false): Promise<{ gen: Generator; result: GenerateResult; pose?: MotionPose }> {
    const gen = await this.load(model, variant);
    const r = await runWithFallback(gen, o, () => this.reloadOnWasm(model, variant), (reason) => this.events.fallback(model, reason));
    return pose ? { ...r, pose: this.pose(r.result.motion.joints, r.result.motion.frames) } : r;
  }

  /** Bone rotations (IK) of frames × 22 × 3 joints: every result's pose, step preview's and solve request's, in the worker and in-process. */
  pose(joints: Float32Array, frames: number): MotionPose {
    return solvePose(joints, frames, this.opts.manifest.skeleton);
  }

  /** Start several generations together (Generator.begin), with the same WebGPU → WASM fallback. */
  async begin(model: string, os: readonly BeginOptions[], variant?: string): Promise<{ gen: Generator; states: SampleState[] }> {
    const gen = await this.load(model, variant);
    const r = await withFallback(gen, os[0]?.signal, (g) => g.begin(os), () => this.reloadOnWasm(model, variant), (reason) => this.events.fallback(model, reason));
    return { gen: r.gen, states: r.result };
  }

  /**
   * A whole timeline (src/edit.ts's generateTimeline with this host's generate and begin): every window, its seam
   * easing and the stitching run here, so a page's worker answers one request per timeline. Each window is the
   * request createGenerator would make of it (resolveRequest): the same motion as generateTimeline elsewhere.
   * `pose`: also solve the shown joints' bone rotations (IK, `this.pose`).
   */
  async timeline(req: TimelineRequest, hooks: TimelineHooks = {}, pose = false): Promise<TimelineResult & { pose?: MotionPose }> {
    const t0 = performance.now();
    const manifest = this.opts.manifest;
    const { signal } = hooks;
    const modelOf = (c: EditCondition): string =>
      c.action !== undefined ? (req.models?.action ?? modelFor(manifest, { action: c.action })) : (req.models?.text ?? modelFor(manifest, {}));
    const common = { ...(req.steps !== undefined ? { steps: req.steps } : {}), ...(req.guidance !== undefined ? { guidance: req.guidance } : {}) };
    const cond = (c: EditCondition) => (c.action !== undefined ? { action: c.action } : { prompt: c.prompt ?? '' });
    // every segment's request resolved first (its model, in the manifest; its action label): a bad one stops before any sampling
    const used = [...new Set(req.segments.map((seg, i) => {
      try {
        return resolveRequest(manifest, { ...cond(seg), ...common, model: modelOf(seg), frames: 1, seed: 0 }).model;
      } catch (e) {
        throw new EditError(`segment ${i + 1}: ${(e as Error).message}`, i);
      }
    }))];
    const entries = used.map((m) => manifest.models[m]);
    if (entries.some((e) => e.fps !== entries[0].fps)) throw new EditError(`timeline: the models ${used.join(', ')} run at different frame rates`);
    const limits: EditLimits = { fps: entries[0]?.fps ?? manifest.skeleton.fps, maxFrames: Math.min(...entries.map((e) => e.maxFrames)) };
    const variantOf = (model: string) => chooseVariant(manifest, model, req.variant);
    const windows: WindowRun[] = [];
    let beginMs = 0;
    const gen: EditGenerate = async (r) => {
      const { model, options } = resolveRequest(manifest, {
        ...cond(r), ...common, model: modelOf(r), frames: r.frames, seed: r.seed,
        ...(r.known ? { known: r.known } : {}), ...(r.resume ? { resume: r.resume } : {}),
      });
      const { result } = await this.generate(model, { ...options, signal, onStep: (d, t) => hooks.onStep?.(d, t, 0) }, variantOf(model));
      const { motion, ...run } = result;
      windows.push({ ...run, model, frames: motion.frames });
      return { frames: motion.frames, fps: motion.fps, features: motion.features, joints: motion.joints };
    };
    const begin: EditBegin = async (reqs) => {
      const b0 = performance.now();
      const states = await beginByModel(reqs, modelOf, async (model, rs) => {
        const os = rs.map((r, i): BeginOptions => ({
          ...wireBegin(manifest, { ...cond(r), ...common, model, frames: r.frames, seed: r.seed, stopAt: r.stopAt, keep: r.keep, keepFromTime: r.keepFromTime }),
          signal, ...(i === 0 ? { onStep: (d: number, t: number) => hooks.onStep?.(d, t, rs.length) } : {}),
        }));
        return (await this.begin(model, os, variantOf(model))).states;
      });
      beginMs += performance.now() - b0;
      return states;
    };
    const timeline = await generateTimeline(req.segments, gen, limits, { previous: req.previous, signal, begin, onWindow: hooks.onWindow });
    const display = decodeJoints(timeline.features, timeline.frames, manifest.skeleton, { smooth: true, footCleanup: true });
    const result: TimelineResult = { timeline, display, windows, beginMs, totalMs: performance.now() - t0 };
    return pose ? { ...result, pose: this.pose(display, timeline.frames) } : result;
  }

  private reloadOnWasm(model: string, variant: string | undefined): Promise<Generator> {
    const key = `${model}|${variant ?? ''}`;
    this.generators.get(key)?.then((g) => g.dispose()).catch(() => undefined);
    const g = this.create(model, variant, 'wasm');
    this.generators.set(key, g);
    g.catch(() => this.generators.delete(key));
    return g;
  }

  private progress(key: string, label: string) {
    return (loaded: number, total: number) => {
      this.downloads.set(key, [loaded, total]);
      let l = 0;
      let t = 0;
      for (const [a, b] of this.downloads.values()) {
        l += a;
        t += b;
      }
      this.events.download(label, l, t);
    };
  }

  /** A text model's encoder, loaded at the same time as its step model (the first prompt does not wait for it). */
  private encoderFor(model: string): { ready: Promise<unknown>; encoder?: TextEncoder } {
    const c = this.opts.manifest.models[model]?.condition;
    if (!c || c.type !== 'text') return { ready: Promise.resolve() };
    let enc = this.encoders.get(c.encoder);
    if (!enc) {
      enc = createTextEncoder(this.opts.manifest, this.opts.baseUrl, c.encoder, { onDownload: this.progress(`enc:${c.encoder}`, model), threads: this.opts.threads });
      this.encoders.set(c.encoder, enc);
      enc.catch(() => this.encoders.delete(c.encoder));
    }
    const p = enc;
    const encoder: TextEncoder = {
      id: c.encoder,
      dim: c.dim,
      encode: async (text: string) => (await p).encode(text),
      // createTextEncoder's encoders have tokenize: generate() reports a prompt cut to maxTokens with it
      tokenize: async (text: string) => (await p).tokenize!(text),
    };
    return { ready: p, encoder };
  }

  private async create(model: string, variant?: string, force?: 'wasm'): Promise<Generator> {
    const runtime = this.preloadRuntime(model);
    const enc = this.encoderFor(model);
    const gen = this.createStep(model, variant, enc.encoder, force);
    // All must load; if one fails, the model is unusable (the error names the file).
    const [g] = await Promise.all([gen, enc.ready, runtime]).catch(async (e) => {
      gen.then((x) => x.dispose()).catch(() => undefined);
      throw e;
    });
    loadMark(`model-ready:${model}`);
    return g;
  }

  private async createStep(model: string, variant: string | undefined, textEncoder?: TextEncoder, force?: 'wasm'): Promise<Generator> {
    const common = {
      manifest: this.opts.manifest, baseUrl: this.opts.baseUrl, model, variant, threads: this.opts.threads,
      onDownload: this.progress(`model:${model}|${variant ?? ''}`, model), textEncoder,
    };
    return loadModel({ ...common, backend: force ?? this.opts.backend }, (reason) => this.events.fallback(model, reason));
  }

  async dispose(): Promise<void> {
    const all = await Promise.allSettled(this.generators.values());
    for (const r of all) if (r.status === 'fulfilled') await r.value.dispose();
    this.generators.clear();
  }
}
