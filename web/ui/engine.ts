// The models the page needs, loaded lazily in the generation worker, and generations run so that the
// NEWEST request wins: starting one aborts the one before it (the worker stops it at the next denoising
// step) and waits for it to stop before running. Backend choice and the WebGPU → WASM fallback (at load
// and at run time) are not made here or in web/main.ts: the page's `backend` (URL) goes to the worker,
// where src/loadModel.ts decides, in one place for the page and the library (createGenerator). Which file of a
// model runs (fp32 or a variant such as int8) is the manifest's chooseVariant: the entry's defaultVariant
// unless the page asks for another (URL `variant=fp32`).
import { type Manifest, type ModelEntry } from '../../src/index';
import { chooseVariant } from '../../src/manifest';
import { GenerationClient, type ClientEvents, type ModelInfo, type RemoteGenerateOptions, type RemoteResult, type RemoteTimelineOptions, type RemoteTimelineResult } from '../../src/worker/client';
import type { TimelineRequest } from '../../src/worker/generationHost';
import type { BackendChoice, Mode } from './state';

export interface ModelChoice {
  name: string;
  entry: ModelEntry;
}

/**
 * The models for each mode: text and random use the text model, action the action model (EMDM models,
 * objective "ddgan"); `diffusion` is the text model trained with the plain diffusion objective that the
 * compare view samples with DDIM beside EMDM (null when the manifest has none).
 */
export function pickModels(m: Manifest): { text: ModelChoice | null; action: ModelChoice | null; diffusion: ModelChoice | null } {
  const isDiffusion = (e: ModelEntry) => e.objective === 'diffusion';
  const find = (task: ModelEntry['task'], preferred: string, diffusion: boolean): ModelChoice | null => {
    const ok = (e: ModelEntry | undefined) => !!e && e.task === task && isDiffusion(e) === diffusion;
    if (ok(m.models[preferred])) return { name: preferred, entry: m.models[preferred] };
    const hit = Object.entries(m.models).find(([, e]) => ok(e));
    return hit ? { name: hit[0], entry: hit[1] } : null;
  };
  return {
    text: find('text', 'emdm-t2m-web', false),
    action: find('action', 'emdm-a2m-web', false),
    diffusion: find('text', 'diffusion-t2m-web', true),
  };
}

export function modelForMode(models: ReturnType<typeof pickModels>, mode: Mode): ModelChoice | null {
  return mode === 'action' ? models.action : models.text;
}

/**
 * The page's `variant` URL flag: 'fp32' or a variant every model of the manifest has (e.g. 'int8', 'fp16');
 * absent = each model's manifest default. Anything else is ignored with a notice saying what is known.
 */
export function pageVariant(m: Manifest, search: string): { variant: string | undefined; notice: string } {
  const v = new URLSearchParams(search).get('variant');
  if (v === null) return { variant: undefined, notice: '' };
  const entries = Object.values(m.models);
  const common = entries.length ? Object.keys(entries[0].variants ?? {}).filter((k) => entries.every((e) => k in (e.variants ?? {}))) : [];
  if (v === 'fp32' || common.includes(v)) return { variant: v, notice: '' };
  return { variant: undefined, notice: `URL variant='${v}' is not a model file every model has (fp32${common.map((k) => `, ${k}`).join('')}); each model runs its default file.` };
}

/** The most WASM threads the `threads` flag may ask for. */
export const MAX_PAGE_THREADS = 16;

/**
 * The WASM thread count the URL's `threads` flag asks for (a whole number 1…MAX_PAGE_THREADS), or undefined: the
 * runtime's own choice (all cores but one, at most 4, when cross-origin isolated). On a 2-core machine `threads=2`
 * generates faster (a timeline's windows begun together gain most) while the page draws less smoothly.
 */
export function pageThreads(search: string): { threads: number | undefined; notice: string } {
  const v = new URLSearchParams(search).get('threads');
  if (v === null) return { threads: undefined, notice: '' };
  const n = Number(v);
  if (Number.isInteger(n) && n >= 1 && n <= MAX_PAGE_THREADS) return { threads: n, notice: '' };
  return { threads: undefined, notice: `URL threads='${v}' is not a whole number 1–${MAX_PAGE_THREADS}; the runtime chooses the WASM thread count.` };
}

export class SupersededError extends Error {
  constructor() {
    super('cancelled: a newer request replaced this one');
    this.name = 'AbortError';
  }
}

/** The visitor pressed Cancel. */
export class CancelledError extends Error {
  constructor() {
    super('cancelled');
    this.name = 'AbortError';
  }
}

export function isAbort(e: unknown): boolean {
  return e instanceof Error && e.name === 'AbortError';
}

export type LoadEvents = Pick<ClientEvents, 'download' | 'fallback'> & Partial<ClientEvents>;

/**
 * `fallback` called once per reason: without a usable GPU every model the page loads (text, action, the
 * compare view's diffusion model) falls back for the same reason, and one notice says it (not one per model).
 */
export function oncePerReason(fallback: LoadEvents['fallback']): LoadEvents['fallback'] {
  const said = new Set<string>();
  return (model, reason) => {
    if (said.has(reason)) return;
    said.add(reason);
    fallback(model, reason);
  };
}

/**
 * The page's models, loaded and run in the generation worker (src/worker): the page's thread only
 * sends requests and receives motions (bone rotations solved there too).
 */
export class Engine {
  readonly client: GenerationClient;
  private readonly loads = new Map<string, Promise<ModelInfo>>();
  private current: { ctrl: AbortController; done: Promise<unknown> } | null = null;

  private readonly manifest: Manifest;
  /** the variant the page asked for ('fp32', 'int8', …; undefined: each model's manifest default) */
  private readonly variant: string | undefined;

  constructor(manifest: Manifest, baseUrl: string, backend: BackendChoice, events: LoadEvents, variant?: string, threads?: number) {
    this.manifest = manifest;
    this.variant = variant;
    this.client = new GenerationClient({ manifest, baseUrl, backend, threads, events: { ...events, fallback: oncePerReason(events.fallback) } });
  }

  /** The variant `model` runs (undefined: its fp32 file): chooseVariant of the page's request. */
  private variantOf(model: string): string | undefined {
    return chooseVariant(this.manifest, model, this.variant);
  }

  /** Load a model in the worker (once; a failed load is forgotten so it can be retried). */
  load(model: string): Promise<ModelInfo> {
    let p = this.loads.get(model);
    if (!p) {
      p = (async () => this.client.load(model, this.variantOf(model)))();
      this.loads.set(model, p);
      p.catch(() => this.loads.delete(model));
    }
    return p;
  }

  /** One motion on the page's file of `model` (variantOf), with its pose track unless `pose: false` (a timeline
   * window, whose stitched result is solved once); WebGPU failures are retried on WASM in the worker. */
  generate(model: string, o: RemoteGenerateOptions): Promise<RemoteResult> {
    return this.client.generate(model, { pose: true, ...o }, this.variantOf(model));
  }

  /** A whole timeline in the worker (GenerationClient.timeline), each of its models on the page's file (variantOf). */
  timeline(request: Omit<TimelineRequest, 'variant'>, o: RemoteTimelineOptions): Promise<RemoteTimelineResult> {
    return this.client.timeline({ ...request, ...(this.variant !== undefined ? { variant: this.variant } : {}) }, o);
  }

  /** Run `job` as the newest request: the previous one is aborted and awaited first. */
  async run<T>(job: (signal: AbortSignal) => Promise<T>): Promise<T> {
    const prev = this.current;
    const ctrl = new AbortController();
    prev?.ctrl.abort(new SupersededError());
    const done = (async () => {
      if (prev) await prev.done.catch(() => undefined);
      if (ctrl.signal.aborted) throw new SupersededError();
      return job(ctrl.signal);
    })();
    this.current = { ctrl, done };
    try {
      return await done;
    } finally {
      if (this.current?.done === done) this.current = null;
    }
  }

  get busy(): boolean {
    return this.current !== null;
  }

  /** Stop the running request at its next denoising step (it rejects with a CancelledError). */
  cancel(): void {
    this.current?.ctrl.abort(new CancelledError());
  }

  dispose(): Promise<void> {
    return this.client.dispose();
  }
}
