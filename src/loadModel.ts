/**
 * Backend choice and fallback, in ONE place (docs/ARCHITECTURE.md "TypeScript library"):
 * - at load (`loadModel`, choosing with `chooseBackend`): 'wasm' opens WASM; 'auto' or 'webgpu' opens WebGPU when
 *   the app serves its runtime (ORT's files.json lists it: `emdm({ webgpu: true })`) and this environment has an
 *   adapter, else WASM ('auto' on an app without the WebGPU runtime says nothing: the app chose WASM); a WebGPU
 *   session that fails to open or to run its warm-up falls back to WASM (a broken model file is not a backend
 *   problem: that ModelFileError is thrown as is);
 * - while generating (`runWithFallback`): a WebGPU run that fails is run again on WASM.
 * Each fallback is reported with its reason, so a page can tell the user. createGenerator
 * (src/createGenerator.ts) runs this through GenerationHost, in the generation worker or in-process.
 */
import { type GenerateOptions, type GenerateResult, type Generator, type GeneratorOptions, openModel } from './openModel';
import { ModelFileError } from './manifest';
import { AbortError } from './sampler/sampler';
import { type Backend, type BackendRequest, type RuntimeFileList, servedRuntimes, WEBGPU_RUNTIME_FILE, webgpuAvailable } from './runtime/ort';

export interface LoadModelOptions extends Omit<GeneratorOptions, 'backend'> {
  /** 'auto' (default) or 'webgpu': WebGPU where it works, else WASM; 'wasm': WASM only */
  backend?: BackendRequest;
}

const hasNavigatorGpu = (): boolean => {
  const nav = (globalThis as { navigator?: { gpu?: unknown } }).navigator;
  return !!nav && 'gpu' in nav && !!nav.gpu;
};

const message = (e: unknown): string => (e instanceof Error ? e.message : String(e));

/** What this environment offers WebGPU: no `navigator.gpu`, one without a usable adapter, or an adapter. */
export type GpuState = 'no-api' | 'no-adapter' | 'adapter';

/**
 * The backend to open first for `request`, and why it is not WebGPU when WebGPU was wanted (`fallback`, for
 * onFallback; absent when there is nothing to say). `served` is the app's ORT files.json (null: no list, as in Node
 * or an older deployment: both runtimes assumed); without the WebGPU runtime in it WebGPU is never tried (no request
 * for a file the app does not serve), silently for 'auto', with a notice for an explicit 'webgpu'. `gpu` is asked
 * only when WebGPU could run.
 */
export async function chooseBackend(request: BackendRequest, served: RuntimeFileList | null, gpu: () => Promise<GpuState>): Promise<{ backend: Backend; fallback?: string }> {
  if (request === 'wasm') return { backend: 'wasm' };
  if (served && !served[WEBGPU_RUNTIME_FILE]) {
    return request === 'auto' ? { backend: 'wasm' } : {
      backend: 'wasm',
      fallback: `WebGPU is not available (this app serves only ONNX Runtime's WebAssembly runtime; emdm({ webgpu: true }) or 'emdm-web ort --webgpu' adds WebGPU's)`,
    };
  }
  const state = await gpu();
  if (state === 'no-api') return { backend: 'wasm', fallback: 'WebGPU is not available in this browser' };
  if (state === 'no-adapter') return { backend: 'wasm', fallback: 'WebGPU is not available (no usable GPU adapter)' };
  return { backend: 'webgpu' };
}

/** This environment's WebGPU: `navigator.gpu`, then an adapter. */
async function gpuState(): Promise<GpuState> {
  if (!hasNavigatorGpu()) return 'no-api';
  return (await webgpuAvailable()) ? 'adapter' : 'no-adapter';
}

/** Open `opts.model` on the requested backend, falling back to WASM (and saying why through `onFallback`). */
export async function loadModel(opts: LoadModelOptions, onFallback: (reason: string) => void = () => undefined): Promise<Generator> {
  const request = opts.backend ?? 'auto';
  if (request !== 'auto' && request !== 'wasm' && request !== 'webgpu') {
    throw new RangeError(`loadModel: backend must be 'auto', 'webgpu' or 'wasm', got ${JSON.stringify(request)}`);
  }
  const wasm = () => openModel({ ...opts, backend: 'wasm' });
  if (request === 'wasm') return wasm();
  const choice = await chooseBackend(request, await servedRuntimes({ wasmPaths: opts.wasmPaths }), gpuState);
  if (choice.fallback) onFallback(choice.fallback);
  if (choice.backend === 'wasm') return wasm();
  try {
    return await openModel({ ...opts, backend: 'webgpu' });
  } catch (e) {
    if (e instanceof ModelFileError) throw e; // a bad file fails on WASM too, with its name
    onFallback(`WebGPU failed (${message(e)})`);
    return wasm();
  }
}

const isAbort = (e: unknown) => e instanceof Error && e.name === 'AbortError';

/**
 * Run one generation; when it fails on WebGPU (not a cancel, not a bad file), say so through
 * `onFallback`, get a WASM generator from `reloadOnWasm` and run the same request there.
 */
export async function runWithFallback(
  gen: Generator,
  o: GenerateOptions,
  reloadOnWasm: () => Promise<Generator>,
  onFallback: (reason: string) => void = () => undefined,
): Promise<{ gen: Generator; result: GenerateResult }> {
  return withFallback(gen, o.signal, (g) => g.generate(o), reloadOnWasm, onFallback);
}

/** runWithFallback for any call of a generator (`run(gen)`, e.g. its begin): a WebGPU failure runs it again on WASM. */
export async function withFallback<T>(
  gen: Generator,
  signal: AbortSignal | undefined,
  run: (g: Generator) => Promise<T>,
  reloadOnWasm: () => Promise<Generator>,
  onFallback: (reason: string) => void = () => undefined,
): Promise<{ gen: Generator; result: T }> {
  if (signal?.aborted) {   // the library's AbortError, as a cancel mid-run gives (signal.reason: a DOMException)
    throw Object.assign(new AbortError('generation cancelled before it started'), { cause: signal.reason });
  }
  try {
    return { gen, result: await run(gen) };
  } catch (e) {
    if (isAbort(e) || gen.backend !== 'webgpu' || e instanceof ModelFileError) throw e;
    onFallback(`WebGPU failed while generating (${message(e)})`);
    const wasm = await reloadOnWasm();
    return { gen: wasm, result: await run(wasm) };
  }
}
