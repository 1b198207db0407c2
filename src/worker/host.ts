/**
 * The generation worker's state, without the messaging: the generators it has loaded (lazily, once
 * each) and the text encoders they share. The backend choice with its fallbacks (WebGPU missing or
 * failing at load → WASM, WebGPU failing while generating → reload on WASM and run again) is
 * src/backends.ts's; events say what happened (downloads, fallbacks) so the page can tell the user.
 * Runs wherever createGenerator (src/createGenerator.ts) runs it: the worker in the browser, or
 * in-process (Node, `{worker: false}`).
 */
import { loadModel, runWithFallback, withFallback } from '../backends';
import type { BeginOptions, GenerateOptions, GenerateResult, Generator, SampleState } from '../generate';
import type { Manifest } from '../manifest';
import { type BackendRequest, loadMark, preloadWasmRuntime } from '../runtime/ort';
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

  /** Generate with a model; a WebGPU failure reloads the model on WASM (said with a fallback event) and runs again. */
  async generate(model: string, o: GenerateOptions, variant?: string): Promise<{ gen: Generator; result: GenerateResult }> {
    const gen = await this.load(model, variant);
    return runWithFallback(gen, o, () => this.reloadOnWasm(model, variant), (reason) => this.events.fallback(model, reason));
  }

  /** Start several generations together (Generator.begin), with the same WebGPU → WASM fallback. */
  async begin(model: string, os: readonly BeginOptions[], variant?: string): Promise<{ gen: Generator; states: SampleState[] }> {
    const gen = await this.load(model, variant);
    const r = await withFallback(gen, os[0]?.signal, (g) => g.begin(os), () => this.reloadOnWasm(model, variant), (reason) => this.events.fallback(model, reason));
    return { gen: r.gen, states: r.result };
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
