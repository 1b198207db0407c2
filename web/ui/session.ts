// The page's generation session: the manifest's models, what they allow (StateLimits), and the
// generation worker behind web/ui/engine.ts. It turns a PageState into motions (newest request wins)
// and counts what ran; it never touches the DOM. Backend choice and the WebGPU → WASM fallback are not
// here: they live in the worker (src/loadModel.ts); the session only passes the page's `backend` on.
//
// A panel that generates calls `session.generate(state, { extra })`: `extra` goes to the worker's
// generate as is (e.g. `known: { features, keep }` for in-betweening), `hooks` receive progress and
// step previews. Showing the result is the view's job (web/ui/view.ts).
import { type Manifest } from '../../src/index';
import { assertFinite } from '../../src/errors';
import type { GenerateResult } from '../../src/openModel';
import type { ModelInfo, RemoteGenerateOptions, WireStepPreview } from '../../src/worker/client';
import type { PoseTrack } from '../../src/three';
import { compareStepChoices, planCompare, type ComparePlan } from './compare';
import { Engine, modelForMode, pickModels, type LoadEvents } from './engine';
import { examplePrompts } from './examples';
import type { MotionSource } from './provenance';
import { framesFor, type BackendChoice, type PageState, type StateLimits } from './state';
import { emptyCounters, type Counters } from './counters';

/** One model's finished motion, solved for the character. */
export interface Produced {
  model: string;
  result: GenerateResult;
  track: PoseTrack;
  ikMs: number;
}

/** A finished request: the motion (left in compare mode), the DDIM one in compare mode, and what made them. */
export interface Generation {
  state: PageState;
  /** the caption's main text: the prompt, the action's words, or "Random motion" */
  label: string;
  /** compare mode: the step counts each model ran (null otherwise) */
  plan: ComparePlan | null;
  main: Produced;
  ddim: Produced | null;
  /** what made the motion when it is not one generation of `state` (a timeline, an edit, a live recording):
   * the JSON download's generator block and the page's link read it (web/ui/provenance.ts) */
  source?: MotionSource;
}

export interface GenerationHooks {
  /** progress of the whole request (0..1) with its label, e.g. "Denoising step 3 / 10" */
  progress?(fraction: number, text: string): void;
  /** a step's x̂0 (only when `watch` is set), with the request's signal (aborted = stale) */
  preview?(p: WireStepPreview, signal: AbortSignal): void;
}

export interface SessionGenerateOptions {
  /** one named manifest model alone (benchmarks), never the compare view */
  model?: string;
  /** ask the worker for each step's prediction (hooks.preview) */
  watch?: boolean;
  /** passed to the worker's generate as is (e.g. `known` for in-betweening); cannot override condition/frames/steps/seed */
  extra?: Partial<Omit<RemoteGenerateOptions, 'condition' | 'frames' | 'steps' | 'seed' | 'guidance' | 'signal' | 'onStep' | 'onPreview'>>;
}

export type LoadEvent = { phase: 'start' } | { phase: 'ready'; info: ModelInfo } | { phase: 'failed'; error: unknown };

/** What a request resolves to before anything runs (see Session.check). */
export interface Checked {
  model: string;
  frames: number;
  label: string;
  plan: ComparePlan | null;
}

/** The StateLimits of a manifest's models (the base is the text model, else the action model; null without either). */
export function limitsFor(manifest: Manifest, models: ReturnType<typeof pickModels> = pickModels(manifest)): StateLimits | null {
  const base = models.text ?? models.action;
  if (!base) return null;
  const actions = models.action && models.action.entry.condition.type === 'action' ? models.action.entry.condition.labels : [];
  const limits: StateLimits = {
    supportedSteps: [...base.entry.supportedSteps].sort((a, b) => a - b),
    defaultSteps: base.entry.defaultSteps,
    defaultGuidance: base.entry.guidance,
    actions,
    fps: base.entry.fps,
    maxFrames: Math.min(base.entry.maxFrames, manifest.skeleton.maxFrames),
    defaultText: examplePrompts(manifest, models.text?.name ?? null, actions)[0] ?? '',
    compareSteps: models.text && models.diffusion ? compareStepChoices(models.text.entry, models.diffusion.entry) : [],
  };
  return limits;
}

/** The caption's main text for a state. */
export function labelFor(s: PageState): string {
  return s.mode === 'text' ? s.text.trim() : s.mode === 'action' ? s.action.replace(/[_-]+/g, ' ') : 'Random motion';
}

export class Session {
  readonly models: ReturnType<typeof pickModels>;
  readonly engine: Engine;
  /** the backend the last loaded/run model used ('' before any) */
  backend = '';

  constructor(
    readonly manifest: Manifest,
    readonly limits: StateLimits,
    baseUrl: string,
    backend: BackendChoice,
    events: LoadEvents,
    readonly counters: Counters = emptyCounters(),
    variant?: string,
    threads?: number,
  ) {
    this.models = pickModels(manifest);
    this.engine = new Engine(manifest, baseUrl, backend, events, variant, threads);
  }

  /** Told when a model's load starts and how it ends (the view's status line follows it). */
  onLoad: (model: string, e: LoadEvent) => void = () => undefined;
  private readonly loaded = new Set<string>();
  private readonly loading = new Set<string>();

  /** Load a model in the worker (once; a failed load is tried again next time); resolves with its backend. */
  load(model: string): Promise<ModelInfo> {
    const fresh = !this.loaded.has(model) && !this.loading.has(model);
    const p = this.engine.load(model);
    if (fresh) {
      this.loading.add(model);
      this.onLoad(model, { phase: 'start' });
      p.then((info) => {
        this.loading.delete(model);
        this.loaded.add(model);
        this.onLoad(model, { phase: 'ready', info });
      }, (error: unknown) => {
        this.loading.delete(model);
        this.onLoad(model, { phase: 'failed', error });
      });
    }
    return p.then((info) => {
      this.backend = info.backend;
      return info;
    });
  }

  /** A generation is running (or waiting for the one it replaced to stop). */
  get busy(): boolean {
    return this.engine.busy;
  }

  /** The compare plan of a step count (null without a text and a diffusion model). */
  planCompare(steps: number): ComparePlan | null {
    const { text, diffusion } = this.models;
    return text && diffusion ? planCompare(steps, text.entry.supportedSteps, diffusion.entry.supportedSteps) : null;
  }

  /**
   * What a request would run, or an Error saying why it cannot (nothing runs, nothing changes):
   * an unknown model, a mode without a model, an empty prompt, an unknown action, compare without
   * the two models. `compareWhy` is the controls' reason the compare view is unavailable ('' = fine).
   */
  check(s: PageState, modelOverride?: string, compareWhy = ''): Checked {
    const compare = s.compare && !modelOverride;
    if (compare) {
      const why = compareWhy || (!this.models.text || !this.models.diffusion ? 'no EMDM text model or no diffusion model' : '');
      if (why) throw new Error(`compare view unavailable: ${why}`);
    }
    const choice = modelOverride
      ? (this.manifest.models[modelOverride] ? { name: modelOverride } : null)
      : modelForMode(this.models, s.mode);
    if (!choice) throw new Error(modelOverride ? `no model '${modelOverride}' in the manifest` : `no ${s.mode} model is shipped with this demo`);
    if (s.mode === 'text' && s.text.trim() === '') throw new Error('the prompt is empty: type what the character should do');
    if (s.mode === 'action' && !this.limits.actions.includes(s.action)) throw new Error(`unknown action '${s.action}'`);
    return { model: choice.name, frames: framesFor(s.seconds, this.limits), label: labelFor(s), plan: compare ? this.planCompare(s.steps) : null };
  }

  /**
   * Generate the motion(s) of a state as the newest request (an older one is cancelled at its next
   * step; it rejects with an AbortError). Compare mode runs EMDM then DDIM, one after the other (fair
   * timings on a shared CPU). Rejections carry `failedModel` (the model that was running).
   */
  async generate(requested: PageState, o: SessionGenerateOptions = {}, hooks: GenerationHooks = {}, compareWhy = ''): Promise<Generation> {
    const s = { ...requested };
    this.counters.requests++;
    const { model, frames, label, plan } = this.check(s, o.model, compareWhy);
    const progress = hooks.progress ?? (() => undefined);
    let running = model;
    try {
      const out = await this.engine.run(async (signal) => {
        progress(0, s.mode === 'text' ? 'Encoding the prompt…' : 'Sampling…');
        if (!plan) {
          const main = await this.produce(model, s, s.steps, frames, signal, o, hooks,
            (d, t) => progress(d / t, `Denoising step ${d} / ${t}`));
          return { main, ddim: null };
        }
        const total = plan.emdm + plan.ddim;
        const emdm = this.models.text!.name;
        const ddimModel = this.models.diffusion!.name;
        running = emdm;
        const main = await this.produce(emdm, s, plan.emdm, frames, signal, { extra: o.extra }, hooks,
          (d, t) => progress(d / total, `EMDM: denoising step ${d} / ${t}`));
        running = ddimModel;
        const ddim = await this.produce(ddimModel, s, plan.ddim, frames, signal, { extra: o.extra }, hooks,
          (d, t) => progress((plan.emdm + d) / total, `DDIM: denoising step ${d} / ${t}`));
        return { main, ddim };
      });
      this.counters.generations++;
      this.counters.modelCalls += out.main.result.modelCalls + (out.ddim?.result.modelCalls ?? 0);
      return { state: s, label, plan, ...out };
    } catch (e) {
      if (e instanceof Error && e.name === 'AbortError') this.counters.cancelled++;
      else this.counters.errors++;
      if (e instanceof Error) (e as Error & { failedModel?: string }).failedModel = running;
      throw e;
    }
  }

  /** One model's motion for a state, checked and solved (WebGPU failures retry on WASM in the worker). */
  private async produce(model: string, s: PageState, steps: number, frames: number, signal: AbortSignal,
    o: SessionGenerateOptions, hooks: GenerationHooks, onStep: (done: number, total: number) => void): Promise<Produced> {
    await this.load(model);
    if (signal.aborted) throw signal.reason;
    // the worker encodes, samples, decodes and solves the bone rotations; this thread only shows them
    const watch = o.watch && hooks.preview;
    const result = await this.engine.generate(model, {
      ...(o.extra ?? {}),
      condition: this.conditionFor(s), frames, steps, guidance: s.guidance, seed: s.seed, signal, smooth: true, footCleanup: true,
      onStep: (done: number, total: number) => {
        this.counters.stepsRun++;
        onStep(done, total);
      },
      ...(watch ? { previewSteps: true, onPreview: (p: WireStepPreview) => hooks.preview!(p, signal) } : {}),
    });
    this.backend = result.info.backend;
    const pose = result.pose;
    if (!pose) throw new Error('generation worker: the result has no pose track (pose: true was asked)');
    assertFinite(pose.quats, 'the solved joint rotations'); // generate() already refused non-finite joints
    assertFinite(pose.rootPos, 'the solved root positions');
    const track: PoseTrack = {
      frames: result.motion.frames, fps: result.motion.fps, joints: this.manifest.skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats,
      offsets: pose.offsets,
    };
    return { model, result, track, ikMs: pose.ikMs };
  }

  private conditionFor(s: PageState) {
    return s.mode === 'text' ? { type: 'text' as const, text: s.text }
      : s.mode === 'action' ? { type: 'action' as const, label: this.limits.actions.indexOf(s.action) }
        : { type: 'none' as const };
  }
}

/** The model a failed Session.generate was running ('' when unknown). */
export function failedModel(e: unknown): string {
  return (e as { failedModel?: string } | null)?.failedModel ?? '';
}
