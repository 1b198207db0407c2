// Loads the step models the page needs (lazily, once each), falls back from WebGPU to WASM when
// WebGPU is missing or fails, and runs generations so that the NEWEST request wins: starting one
// aborts the one before it (between denoising steps) and waits for it to stop before running.
import { createGenerator, type Generator } from '../../src/generate';
import { ModelFileError, type Manifest, type ModelEntry } from '../../src/manifest';
import { createTextEncoder, type TextEncoder } from '../../src/text';
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

export class SupersededError extends Error {
  constructor() {
    super('cancelled: a newer request replaced this one');
    this.name = 'AbortError';
  }
}

export function isAbort(e: unknown): boolean {
  return e instanceof Error && e.name === 'AbortError';
}

export interface LoadEvents {
  download(model: string, loaded: number, total: number): void;
  fallback(model: string, reason: string): void;
}

export class Engine {
  private readonly generators = new Map<string, Promise<Generator>>();
  private current: { ctrl: AbortController; done: Promise<unknown> } | null = null;

  constructor(
    private readonly manifest: Manifest,
    private readonly baseUrl: string,
    private readonly backend: BackendChoice,
    private readonly events: LoadEvents,
  ) {}

  /** The generator of a model (created on first use; a failed load is forgotten so it can be retried). */
  load(model: string): Promise<Generator> {
    let g = this.generators.get(model);
    if (!g) {
      g = this.create(model);
      this.generators.set(model, g);
      g.catch(() => this.generators.delete(model));
    }
    return g;
  }

  /** Progress of every download under way, summed. */
  private readonly downloads = new Map<string, [number, number]>();
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

  /**
   * A text model's encoder, loaded at the same time as the step model (so the first prompt does not
   * wait for it); the generator gets a stand-in that waits for it.
   */
  private encoderFor(model: string): { ready: Promise<unknown>; encoder?: TextEncoder } {
    const c = this.manifest.models[model]?.condition;
    if (!c || c.type !== 'text') return { ready: Promise.resolve() };
    let enc = this.encoders.get(c.encoder);
    if (!enc) {
      enc = createTextEncoder(this.manifest, this.baseUrl, c.encoder, { onDownload: this.progress(`enc:${c.encoder}`, model) });
      this.encoders.set(c.encoder, enc);
      enc.catch(() => this.encoders.delete(c.encoder));
    }
    const p = enc;
    return { ready: p, encoder: { id: c.encoder, dim: c.dim, encode: async (text: string) => (await p).encode(text) } };
  }

  private readonly encoders = new Map<string, Promise<TextEncoder>>();

  /**
   * WebGPU failed while generating: say so, drop the WebGPU generator and load the model on WASM
   * (every later generation of this model runs there).
   */
  async reloadOnWasm(model: string, reason: string): Promise<Generator> {
    this.events.fallback(model, `WebGPU failed while generating (${reason})`);
    const old = this.generators.get(model);
    old?.then((g) => g.dispose()).catch(() => undefined);
    const g = this.create(model, 'wasm');
    this.generators.set(model, g);
    g.catch(() => this.generators.delete(model));
    return g;
  }

  private async create(model: string, backend?: 'wasm'): Promise<Generator> {
    const enc = this.encoderFor(model);
    const gen = this.createStep(model, enc.encoder, backend);
    // Both must load; if either fails, the model is unusable (the error names the file).
    const [g] = await Promise.all([gen, enc.ready]).catch(async (e) => {
      gen.then((g) => g.dispose()).catch(() => undefined);
      throw e;
    });
    return g;
  }

  private async createStep(model: string, textEncoder?: TextEncoder, force?: 'wasm'): Promise<Generator> {
    const onDownload = this.progress(`model:${model}`, model);
    const common = { manifest: this.manifest, baseUrl: this.baseUrl, model, onDownload, textEncoder };
    const hasGpu = typeof navigator !== 'undefined' && 'gpu' in navigator && !!(navigator as { gpu?: unknown }).gpu;
    if (this.backend === 'wasm' || force === 'wasm') return createGenerator({ ...common, backend: 'wasm' });
    if (!hasGpu) {
      this.events.fallback(model, 'WebGPU is not available in this browser');
      return createGenerator({ ...common, backend: 'wasm' });
    }
    try {
      const g = await createGenerator({ ...common, backend: this.backend });
      if (g.backend !== 'webgpu') this.events.fallback(model, 'WebGPU is not available (no usable GPU adapter)');
      return g;
    } catch (e) {
      if (e instanceof ModelFileError) throw e; // a bad file is not a backend problem
      this.events.fallback(model, `WebGPU failed (${e instanceof Error ? e.message : String(e)})`);
      return createGenerator({ ...common, backend: 'wasm' });
    }
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

  async dispose(): Promise<void> {
    const all = await Promise.allSettled(this.generators.values());
    for (const r of all) if (r.status === 'fulfilled') await r.value.dispose();
    this.generators.clear();
  }
}
