/**
 * The page's side of the generation worker: generate motions off the page's thread.
 *
 * ```ts
 * const manifest = await loadManifest('/models/');
 * const client = new GenerationClient({ manifest, baseUrl: '/models/' });
 * const r = await client.generate('emdm-t2m-web', { condition: { type: 'text', text: 'a person waves' }, frames: 120, steps: 4, guidance: 2.5, seed: 1 });
 * r.motion.joints; // frames × 22 × 3, bit-identical to openModel(...).generate() (src/openModel.ts) on the same backend
 * ```
 *
 * One worker per client holds the models, the text encoder and ORT; requests travel as messages
 * (./protocol.ts). An AbortSignal cancels a generation at the next denoising step; `onStep` hears
 * each step; with `previewSteps: true`, `onPreview` gets each step's x̂0 as joints (and pose); errors come back as the same classes (ModelFileError, NonFiniteMotionError, AbortError).
 */
import type { FileEvent } from '../cache/modelCache';
import { EditError } from '../edit';
import { NonFiniteMotionError } from '../errors';
import type { GenerateResult, SampleState } from '../openModel';
import { ModelFileError, type Manifest, type ModelFileErrorReason } from '../manifest';
import type { BackendRequest } from '../runtime/ort';
import { AbortError } from '../sampler/sampler';
import type { TimelineRequest, TimelineResult } from './generationHost';
import type { FromWorker, ModelInfo, ToWorker, WireError, WireBeginOptions, WireGenerateOptions, WirePose, WireStepPreview } from './protocol';

export type { FileEvent, ModelInfo, WireGenerateOptions, WirePose, WireStepPreview };

export interface WorkerEnvironment {
  crossOriginIsolated: boolean;
  /** WASM threads ORT uses in the worker */
  threads: number;
  hardwareConcurrency: number;
}

export interface ClientEvents {
  /** bytes of the files a model load is fetching (summed over the loads under way) */
  download(model: string, loaded: number, total: number): void;
  /** one file's state: read from the cache, bytes from the network, verified, failed */
  file(e: FileEvent): void;
  /** a model runs on WASM instead of WebGPU, and why */
  fallback(model: string, reason: string): void;
  /** something the user should know (e.g. a corrupt cached file was downloaded again) */
  notice(kind: 'info' | 'warn', text: string): void;
}

export interface GenerationClientOptions {
  manifest: Manifest;
  /** the models folder (resolved against the page) */
  baseUrl: string;
  backend?: BackendRequest;
  threads?: number;
  /** keep model files in Cache Storage for the next visit (default true) */
  cache?: boolean;
  events?: Partial<ClientEvents>;
  /** a worker that speaks ./protocol.ts (default: a new module worker of ./generation.worker.ts) */
  worker?: Worker;
}

export interface RemoteGenerateOptions extends WireGenerateOptions {
  signal?: AbortSignal;
  onStep?: (done: number, total: number) => void;
  /** each step's decoded x̂0 (only with `previewSteps: true`), before the next step runs */
  onPreview?: (p: WireStepPreview) => void;
}

export interface RemoteResult extends GenerateResult {
  info: ModelInfo;
  /** bone rotations solved in the worker (when `pose: true` was asked) */
  pose?: WirePose;
}

/** Rebuild an error sent by the worker as the class the caller checks for. */
function rebuild(w: WireError): Error {
  let e: Error;
  if (w.name === 'ModelFileError' && w.path !== undefined) {
    e = new ModelFileError(w.path, (w.reason ?? 'network') as ModelFileErrorReason, '');
    e.message = w.message;
  } else if (w.name === 'NonFiniteMotionError' && w.source !== undefined) {
    e = new NonFiniteMotionError(w.source, w.index ?? -1, w.count ?? 0, w.value ?? NaN);
    e.message = w.message;
  } else if (w.name === 'EditError' && w.segment !== undefined) {
    e = new EditError(w.message, w.segment);
  } else if (w.name === 'AbortError') {
    e = new AbortError(w.message);
  } else {
    e = new Error(w.message);
    e.name = w.name;
  }
  if (w.stack) e.stack = `${w.stack}\n    (in the generation worker)`;
  return e;
}

interface Pending {
  resolve(m: FromWorker): void;
  reject(e: Error): void;
  onStep?: (done: number, total: number, together?: number) => void;
  onPreview?: (p: WireStepPreview) => void;
  onWindow?: (segment: number, done: number, total: number) => void;
}

/** How `GenerationClient.timeline` reports and stops. */
export interface RemoteTimelineOptions {
  /** also solve the shown joints into bone rotations (IK) in the worker */
  pose?: boolean;
  signal?: AbortSignal;
  onWindow?: (segment: number, done: number, total: number) => void;
  /** a denoising step: of `together` windows begun at once, or (together = 0) of the window being finished */
  onStep?: (done: number, total: number, together: number) => void;
}

export interface RemoteTimelineResult extends TimelineResult {
  /** bone rotations of `display` (when `pose: true` was asked) */
  pose?: WirePose;
}

export class GenerationClient {
  private readonly worker: Worker;
  private readonly pending = new Map<number, Pending>();
  private nextId = 1;
  private broken: Error | null = null;
  private readonly events: Partial<ClientEvents>;
  /** where the worker runs: cross-origin isolated or not, and ORT's thread count there */
  readonly environment: Promise<WorkerEnvironment>;

  constructor(opts: GenerationClientOptions) {
    this.events = opts.events ?? {};
    this.worker = opts.worker ?? new Worker(new URL('./generation.worker.ts', import.meta.url), { type: 'module', name: 'emdm-generation' });
    let envResolve!: (e: WorkerEnvironment) => void;
    this.environment = new Promise((r) => (envResolve = r));
    this.worker.addEventListener('message', (e: MessageEvent<FromWorker>) => {
      const m = e.data;
      switch (m.type) {
        case 'environment':
          envResolve({ crossOriginIsolated: m.crossOriginIsolated, threads: m.threads, hardwareConcurrency: m.hardwareConcurrency });
          return;
        case 'download':
          this.events.download?.(m.model, m.loaded, m.total);
          return;
        case 'file':
          this.events.file?.(m.file);
          return;
        case 'fallback':
          this.events.fallback?.(m.model, m.reason);
          return;
        case 'notice':
          this.events.notice?.(m.kind, m.text);
          return;
        case 'step':
          this.pending.get(m.id)?.onStep?.(m.done, m.total, m.together);
          return;
        case 'timeline-window':
          this.pending.get(m.id)?.onWindow?.(m.segment, m.done, m.total);
          return;
        case 'step-preview':
          this.pending.get(m.id)?.onPreview?.(m.preview);
          return;
        default: {
          const p = this.pending.get(m.id);
          if (!p) return;
          this.pending.delete(m.id);
          if (m.type === 'error') p.reject(rebuild(m.error));
          else p.resolve(m);
        }
      }
    });
    this.worker.addEventListener('error', (e: ErrorEvent) => {
      e.preventDefault?.();
      this.fail(new Error(`generation worker failed: ${e.message || 'its script could not be loaded or threw'} (${e.filename || 'generation.worker'}:${e.lineno ?? '?'})`));
    });
    this.worker.addEventListener('messageerror', () => this.fail(new Error('generation worker: a message could not be decoded')));
    const baseUrl = typeof location !== 'undefined' ? new URL(opts.baseUrl, location.href).href : opts.baseUrl;
    this.send({ type: 'init', init: { manifest: opts.manifest, baseUrl, backend: opts.backend ?? 'auto', threads: opts.threads, cache: opts.cache } });
  }

  private fail(e: Error): void {
    this.broken = e;
    for (const p of this.pending.values()) p.reject(e);
    this.pending.clear();
  }

  private send(msg: ToWorker, transfer: Transferable[] = []): void {
    this.worker.postMessage(msg, transfer);
  }

  private request(msg: ToWorker & { id: number }, onStep?: Pending['onStep'], onPreview?: Pending['onPreview'], transfer: Transferable[] = [], onWindow?: Pending['onWindow']): Promise<FromWorker> {
    if (this.broken) return Promise.reject(this.broken);
    return new Promise((resolve, reject) => {
      this.pending.set(msg.id, { resolve, reject, onStep, onPreview, onWindow });
      this.send(msg, transfer);
    });
  }

  /** Load a model in the worker (downloads, verifies, opens its session; a text model's encoder too). */
  async load(model: string, variant?: string): Promise<ModelInfo> {
    const m = await this.request({ type: 'load', id: this.nextId++, model, variant });
    if (m.type !== 'loaded') throw new Error(`generation worker answered '${m.type}' to load`);
    return m.info;
  }

  /**
   * One motion; the signal cancels it at the next denoising step (rejecting with an AbortError). With
   * `known` (inpainting), its two arrays are copied to the worker (structured clone, ~200 kB for 196 frames),
   * not transferred: the caller keeps using them (src/edit.ts reads `keep` again after the generation).
   */
  async generate(model: string, o: RemoteGenerateOptions, variant?: string): Promise<RemoteResult> {
    const { signal, onStep, onPreview, ...options } = o;
    const m = await this.cancellable(signal, (id) => this.request({ type: 'generate', id, model, variant, options }, onStep, onPreview));
    if (m.type !== 'result') throw new Error(`generation worker answered '${m.type}' to generate`);
    return { ...m.result, info: m.info, pose: m.pose };
  }

  /** A request `signal` cancels in the worker (at its next denoising step); refused at once when already aborted. */
  private async cancellable(signal: AbortSignal | undefined, send: (id: number) => Promise<FromWorker>): Promise<FromWorker> {
    if (signal?.aborted) throw new AbortError('generation cancelled before it started');
    const id = this.nextId++;
    const cancel = () => this.send({ type: 'cancel', id });
    signal?.addEventListener('abort', cancel, { once: true });
    try {
      return await send(id);
    } finally {
      signal?.removeEventListener('abort', cancel);
    }
  }

  /**
   * Start several generations together in the worker (Generator.begin): one model call per step for all, each stopped
   * before its first step with t ≤ its stopAt; finish each with generate({ ...o, resume: state }). The signal cancels
   * them; `onStep` counts the first one's steps.
   */
  async begin(model: string, options: WireBeginOptions[], variant?: string, signal?: AbortSignal, onStep?: (done: number, total: number) => void): Promise<SampleState[]> {
    const m = await this.cancellable(signal, (id) => this.request({ type: 'begin', id, model, variant, options }, onStep));
    if (m.type !== 'begun') throw new Error(`generation worker answered '${m.type}' to begin`);
    return m.states;
  }

  /**
   * A whole timeline in the worker (GenerationHost.timeline: every window, its seam easing and the stitching there),
   * one request and one answer; `request.previous` is copied over. The signal cancels it at the next denoising step;
   * a bad segment rejects with the EditError naming it.
   */
  async timeline(request: TimelineRequest, o: RemoteTimelineOptions = {}): Promise<RemoteTimelineResult> {
    const { signal, onWindow, onStep, pose } = o;
    const m = await this.cancellable(signal, (id) => this.request({ type: 'timeline', id, request, pose }, onStep && ((d, t, w) => onStep(d, t, w ?? 0)), undefined, [], onWindow));
    if (m.type !== 'timeline-result') throw new Error(`generation worker answered '${m.type}' to timeline`);
    return { ...m.result, pose: m.pose };
  }

  /** Bone rotations (IK, the worker's solveIK) for frames × 22 × 3 joints made here, e.g. a stitched timeline; `joints` is copied. */
  async solve(joints: Float32Array, frames: number): Promise<WirePose> {
    const copy = Float32Array.from(joints);
    const m = await this.request({ type: 'solve', id: this.nextId++, joints: copy, frames }, undefined, undefined, [copy.buffer]);
    if (m.type !== 'solved') throw new Error(`generation worker answered '${m.type}' to solve`);
    return m.pose;
  }

  /** Free the worker's sessions and stop it. */
  async dispose(): Promise<void> {
    if (!this.broken) await this.request({ type: 'dispose', id: this.nextId++ }).catch(() => undefined);
    this.worker.terminate();
    this.fail(new Error('generation worker: the client was disposed'));
  }
}
