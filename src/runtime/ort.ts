/**
 * The ONE place that loads ONNX Runtime Web and creates inference sessions.
 *
 * - Node (vitest, benchmarks): `onnxruntime-web` resolves to its Node build, which runs the same
 *   `ort-wasm-simd-threaded.wasm` binary as the browser's `onnxruntime-web/wasm`, so CPU results
 *   are bit-identical between Node and Chromium.
 * - Browser: WASM via `onnxruntime-web/wasm` with self-hosted binaries (`wasmPaths`, default
 *   `<BASE_URL>ort/`), threads when the page is cross-origin isolated; the text encoder
 *   (transformers.js) runs on this same ORT instance (vite.config.ts resolves its 'onnxruntime-web'
 *   here), so one .wasm is downloaded and compiled for both. `preloadWasmRuntime` fetches that .wasm
 *   at once (beside the model downloads, not after them) through the model files' verified path:
 *   `<wasmPaths>files.json` (written by the emdm-web/vite plugin or `emdm-web ort`) gives its size and sha256, so it
 *   is counted in the download progress, checked, and kept in Cache Storage for the next visit
 *   (src/cache/modelCache.ts); ORT gets the bytes as `env.wasm.wasmBinary`. WebGPU via
 *   `onnxruntime-web/webgpu` when `navigator.gpu` gives an adapter and files.json lists its runtime
 *   (the app serves it: `emdm({ webgpu: true })`; `servedRuntimes`) (which backend, and falling back
 *   from WebGPU to WASM, is decided in src/loadModel.ts only).
 * - ORT's wasm flags (thread count, paths) are global and fixed by the first session: a later
 *   request for a different thread count fails loudly instead of silently running with another.
 * - Sessions are cached by (key, backend), so every generator for the same model file reuses one.
 */
import type * as OrtTypes from 'onnxruntime-web';
import { fetchBytes, fetchVerified, ModelFileError, type FileEntry } from '../manifest';
import { yieldToEventLoop } from '../yield';

export type Backend = 'webgpu' | 'wasm';
export type BackendRequest = Backend | 'auto';
type Ort = typeof OrtTypes;

const isNode = typeof process !== 'undefined' && !!process.versions?.node && typeof window === 'undefined';

export interface RuntimeConfig {
  /** where the ORT wasm binaries are served (browser only); default `${import.meta.env.BASE_URL}ort/` */
  wasmPaths?: string;
  /** WASM threads; default: min(4, hardwareConcurrency − 1) when cross-origin isolated (one core is left
   * to the page's rendering and input), else 1 */
  threads?: number;
}

let wasmOrt: Promise<Ort> | null = null;
let webgpuOrt: Promise<Ort> | null = null;
let configuredThreads: number | null = null;
/** the WASM backend's .wasm bytes (browser), fetched once by preloadWasmRuntime; null: ORT fetches it itself */
let wasmBinary: Promise<ArrayBuffer | null> | null = null;

/**
 * A performance mark `emdm:<name>` (where the load time goes: the load benchmark,
 * tests/e2e/page-bench-load.spec.ts, reads them from the generation worker). No-op without
 * the User Timing API.
 */
export function loadMark(name: string): void {
  try {
    (globalThis as { performance?: { mark?: (n: string) => unknown } }).performance?.mark?.(`emdm:${name}`);
  } catch {
    // a mark is never worth an error
  }
}

/** The .wasm of the WASM backend (`onnxruntime-web/wasm`, threaded SIMD build). */
export const WASM_RUNTIME_FILE = 'ort-wasm-simd-threaded.wasm';
/** The .wasm of the WebGPU backend (`onnxruntime-web/webgpu`): served only by apps that ask for WebGPU. */
export const WEBGPU_RUNTIME_FILE = 'ort-wasm-simd-threaded.asyncify.wasm';
/** Sizes and sha256 of the runtime files in the wasm folder (src/assets.ts writes it). */
export const RUNTIME_FILES = 'files.json';
/** files.json: each .wasm the app serves → its size and sha256. */
export type RuntimeFileList = Record<string, FileEntry>;

/** `<BASE_URL>ort/` as an absolute URL (an origin-less path makes Vite's dev server rewrite ORT's
 * dynamic import of the .mjs in public/ and refuse it). */
function defaultWasmPaths(): string {
  const base = (import.meta as unknown as { env?: { BASE_URL?: string } }).env?.BASE_URL ?? '/';
  const rel = `${base.endsWith('/') ? base : base + '/'}ort/`;
  return typeof location !== 'undefined' ? new URL(rel, location.href).href : rel;
}

/** The thread count used when none is requested: one core is left to the page. On 2 cores, 2 WASM
 * threads starve the page's thread and the compositor (measured in Chromium: 6 frames in a 1.2 s
 * generation, 300 ms frame gaps; with 1 thread 33 frames, 83 ms at most, for a 1.5× longer generation). */
export function defaultThreads(): number {
  if (isNode) return 1;
  const g = globalThis as { crossOriginIsolated?: boolean; navigator?: { hardwareConcurrency?: number } };
  if (!g.crossOriginIsolated) return 1;
  return Math.max(1, Math.min(4, (g.navigator?.hardwareConcurrency ?? 2) - 1));
}

function configure(ort: Ort, cfg: RuntimeConfig): void {
  // no count asked for (e.g. the text encoder after a generator that asked for one): join the one in use
  const threads = cfg.threads ?? configuredThreads ?? defaultThreads();
  if (!Number.isInteger(threads) || threads < 1) throw new RangeError(`runtime: threads must be a positive integer, got ${threads}`);
  if (configuredThreads !== null && configuredThreads !== threads) {
    throw new Error(
      `runtime: ONNX Runtime already initialised with ${configuredThreads} WASM thread(s); ` +
        `${threads} requested. The thread count is global: use one value per page/process.`,
    );
  }
  configuredThreads = threads;
  ort.env.wasm.numThreads = threads;
  ort.env.wasm.proxy = false;
  ort.env.logLevel = 'error';
  if (!isNode) ort.env.wasm.wasmPaths = cfg.wasmPaths ?? defaultWasmPaths();
}

/** `<wasmPaths>files.json`, fetched once (a failed fetch is forgotten so a retry fetches again). */
let runtimeList: Promise<RuntimeFileList | null> | null = null;

function wasmBase(cfg: RuntimeConfig): string {
  const base = cfg.wasmPaths ?? defaultWasmPaths();
  return base.endsWith('/') ? base : base + '/';
}

async function fetchRuntimeList(base: string): Promise<RuntimeFileList | null> {
  try {
    return JSON.parse(new TextDecoder().decode(await fetchBytes(base, RUNTIME_FILES))) as RuntimeFileList;
  } catch (e) {
    if (e instanceof ModelFileError && e.reason === 'missing') return null;
    throw new Error(`runtime: cannot read ${base}${RUNTIME_FILES} (the ONNX Runtime file list): ${(e as Error).message}`, { cause: e });
  }
}

/**
 * The ONNX Runtime .wasm files the app serves (its files.json: the emdm-web/vite plugin or `emdm-web ort` writes it,
 * with the WebGPU runtime only when asked for): what src/loadModel.ts reads before it tries WebGPU, so a runtime the
 * app does not serve is never requested. null: no list (Node, or an older deployment without files.json).
 */
export function servedRuntimes(cfg: RuntimeConfig = {}): Promise<RuntimeFileList | null> {
  if (isNode) return Promise.resolve(null);
  if (!runtimeList) {
    const p = fetchRuntimeList(wasmBase(cfg));
    runtimeList = p;
    p.catch(() => {
      if (runtimeList === p) runtimeList = null;
    });
  }
  return runtimeList;
}

/**
 * Fetch the WASM backend's .wasm as a verified file: `<wasmPaths>files.json` lists its size and sha256,
 * and the bytes come through fetchVerified (the model cache when one is in use: progress, per-file
 * state, kept for the next visit, re-verified on read). A server without files.json (an older
 * deployment): null, and ORT fetches the .wasm itself as before.
 */
async function fetchWasmRuntime(cfg: RuntimeConfig, onProgress?: (loaded: number, total: number) => void): Promise<ArrayBuffer | null> {
  const base = wasmBase(cfg);
  const files = await servedRuntimes(cfg);
  if (!files) return null;
  if (!files[WASM_RUNTIME_FILE]) throw new Error(`runtime: ${base}${RUNTIME_FILES} does not list ${WASM_RUNTIME_FILE}; rebuild (the emdm-web/vite plugin or 'emdm-web ort' writes it)`);
  const bytes = await fetchVerified(base, { files }, WASM_RUNTIME_FILE, onProgress);
  loadMark('runtime-wasm-verified');
  return bytes;
}

/**
 * Start loading the WASM backend now: ONNX Runtime's module and (browser) its .wasm binary, whose bytes
 * are reported through `onProgress` like a model file's. Call it before the models are downloaded so
 * the runtime arrives with them; sessions created later wait for it. Idempotent; a failed load is
 * forgotten so a retry fetches again.
 */
export function preloadWasmRuntime(cfg: RuntimeConfig = {}, onProgress?: (loaded: number, total: number) => void): Promise<void> {
  wasmOrt ??= (isNode ? import('onnxruntime-web') : import('onnxruntime-web/wasm')) as Promise<Ort>;
  if (!isNode && !wasmBinary) {
    const p = fetchWasmRuntime(cfg, onProgress);
    wasmBinary = p;
    p.catch(() => {
      if (wasmBinary === p) wasmBinary = null;
    });
  }
  return Promise.all([wasmOrt, wasmBinary]).then(() => undefined);
}

async function loadOrt(backend: Backend, cfg: RuntimeConfig): Promise<Ort> {
  if (backend === 'wasm') {
    await preloadWasmRuntime(cfg);
    const ort = await wasmOrt!;
    loadMark('runtime-module');
    configure(ort, cfg);
    const binary = await wasmBinary;
    if (binary && !ort.env.wasm.wasmBinary) ort.env.wasm.wasmBinary = binary;
    return ort;
  }
  webgpuOrt ??= import('onnxruntime-web/webgpu') as Promise<Ort>;
  const ort = await webgpuOrt;
  configure(ort, cfg);
  return ort;
}

/**
 * ONNX Runtime's WASM backend, configured (threads, wasm location, preloaded binary): what
 * transformers.js runs the text encoder on (src/text/transformersEnv.ts), the same instance as the
 * step models', so the thread count and the .wasm are shared.
 */
export function loadWasmOrt(cfg: RuntimeConfig = {}): Promise<Ort> {
  return loadOrt('wasm', cfg);
}

/** Whether this environment offers a WebGPU adapter (never in Node). */
export async function webgpuAvailable(): Promise<boolean> {
  if (isNode) return false;
  const gpu = (globalThis as { navigator?: { gpu?: { requestAdapter(): Promise<unknown> } } }).navigator?.gpu;
  if (!gpu) return false;
  try {
    return (await gpu.requestAdapter()) != null;
  } catch {
    return false;
  }
}

export interface OrtSession {
  readonly backend: Backend;
  readonly threads: number;
  readonly inputNames: readonly string[];
  readonly outputNames: readonly string[];
  /** float32 inputs by name → float32 outputs by name */
  run(feeds: Record<string, { data: Float32Array; dims: number[] }>): Promise<Record<string, { data: Float32Array; dims: readonly number[] }>>;
  release(): Promise<void>;
}

interface CacheEntry {
  session: Promise<OrtSession>;
  refs: number;
}
const sessionCache = new Map<string, CacheEntry>();

/**
 * Create (or reuse) a session for model bytes. `key` identifies the bytes (e.g. path + sha256).
 * Each call takes a reference; `release()` drops it and frees the session with the last one.
 * Errors name the key and what went wrong.
 */
export async function getSession(key: string, bytes: ArrayBuffer | Uint8Array, backend: Backend, cfg: RuntimeConfig = {}): Promise<OrtSession> {
  const cacheKey = `${backend}|${key}`;
  let entry = sessionCache.get(cacheKey);
  if (!entry) {
    entry = { session: createSession(key, bytes, backend, cfg), refs: 0 };
    sessionCache.set(cacheKey, entry);
    entry.session.catch(() => sessionCache.delete(cacheKey));
  } else if (cfg.threads !== undefined && backend === 'wasm' && configuredThreads !== null && cfg.threads !== configuredThreads) {
    throw new Error(`runtime: ONNX Runtime already initialised with ${configuredThreads} WASM thread(s); ${cfg.threads} requested`);
  }
  const e = entry;
  const base = await e.session;
  e.refs++;
  let mine = true;
  return {
    ...base,
    run: base.run,
    async release() {
      if (!mine) return;
      mine = false;
      if (--e.refs <= 0 && sessionCache.get(cacheKey) === e) {
        sessionCache.delete(cacheKey);
        await base.release();
      }
    },
  };
}

async function createSession(key: string, bytes: ArrayBuffer | Uint8Array, backend: Backend, cfg: RuntimeConfig): Promise<OrtSession> {
  const ort = await loadOrt(backend, cfg);
  const data = bytes instanceof Uint8Array ? bytes : new Uint8Array(bytes);
  let session: OrtTypes.InferenceSession;
  loadMark(`session-start:${key}`);
  try {
    session = await ort.InferenceSession.create(data, {
      executionProviders: [backend],
      graphOptimizationLevel: 'all',
    });
  } catch (e) {
    throw new Error(`runtime: cannot load ONNX model ${key} on ${backend}: ${(e as Error).message}`, { cause: e });
  }
  loadMark(`session-ready:${key}`);
  const threads = backend === 'wasm' ? (ort.env.wasm.numThreads ?? 1) : 0;
  let released = false;
  return {
    backend,
    threads,
    inputNames: session.inputNames,
    outputNames: session.outputNames,
    async run(feeds) {
      if (released) throw new Error(`runtime: session for ${key} was released`);
      // A wasm run blocks its thread and resolves through microtasks only: give the event loop one turn
      // first, so messages that arrived meanwhile (a cancel sent to the generation worker, a click when
      // run on a page's thread) are handled before the next denoising step, not after the whole loop.
      await yieldToEventLoop();
      const tensors: Record<string, OrtTypes.Tensor> = {};
      for (const [name, { data: d, dims }] of Object.entries(feeds)) tensors[name] = new ort.Tensor('float32', d, dims);
      const out = await session.run(tensors);
      const result: Record<string, { data: Float32Array; dims: readonly number[] }> = {};
      for (const [name, t] of Object.entries(out)) {
        if (t.type !== 'float32') throw new Error(`runtime: ${key} output '${name}' is ${t.type}, expected float32`);
        result[name] = { data: (await t.getData()) as Float32Array, dims: t.dims };
        t.dispose();
      }
      return result;
    },
    async release() {
      if (released) return;
      released = true;
      await session.release();
    },
  };
}
