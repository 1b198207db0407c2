/**
 * The one place that loads and configures transformers.js for the text encoders.
 *
 * - Local files only (`allowRemoteModels = false`): nothing is fetched from the Hub or a CDN.
 * - Every model file is fetched by `fetchVerified` (size + sha256 against the manifest) BEFORE
 *   transformers.js asks for it, and handed over through `env.customCache`, so transformers.js
 *   never reads an unverified byte and nothing is downloaded twice.
 * - Browser: transformers.js's own ONNX Runtime Web build (≠ our onnxruntime-web version) runs
 *   from self-hosted wasm at `<BASE_URL>ort-tfjs/` (copied by scripts/build/copy-ort.mjs).
 *   Node: transformers.js uses onnxruntime-node (native CPU).
 */

type Transformers = typeof import('@huggingface/transformers');

const IS_NODE =
  typeof process !== 'undefined' && !!(process as { versions?: { node?: string } }).versions?.node && typeof window === 'undefined';

/** Verified bytes by cache key (the path transformers.js asks for). */
const verified = new Map<string, ArrayBuffer>();

function normaliseKey(key: string): string {
  let k = key;
  if (k.startsWith('file://')) k = decodeURIComponent(k.slice('file://'.length));
  return k.replace(/\/{2,}/g, '/');
}

const verifiedCache = {
  async match(request: string | { url: string }): Promise<Response | undefined> {
    const key = normaliseKey(typeof request === 'string' ? request : request.url);
    const buf = verified.get(key);
    if (!buf) return undefined;
    return new Response(buf.slice(0), { status: 200, headers: { 'content-length': String(buf.byteLength) } });
  },
  async put(): Promise<void> {
    // transformers.js only stores files it fetched itself; every file we allow is already here.
  },
};

/** Make `bytes` the answer transformers.js gets when it asks for `key` (a model-relative path under a model id). */
export function provideVerifiedFile(key: string, bytes: ArrayBuffer): void {
  verified.set(normaliseKey(key), bytes);
}

export function defaultTfjsWasmPaths(): string {
  const base = (import.meta as unknown as { env?: { BASE_URL?: string } }).env?.BASE_URL ?? '/';
  return `${base.endsWith('/') ? base : base + '/'}ort-tfjs/`;
}

let loaded: Promise<Transformers> | null = null;

/** transformers.js, configured once (local files only, verified cache, self-hosted wasm). */
export function loadTransformers(wasmPaths?: string): Promise<Transformers> {
  loaded ??= (async () => {
    const tf = await import('@huggingface/transformers');
    const env = tf.env;
    env.allowRemoteModels = false;
    env.allowLocalModels = true;
    env.useBrowserCache = false;
    env.useFSCache = false;
    env.useCustomCache = true;
    env.customCache = verifiedCache;
    if (!IS_NODE) {
      const wasm = env.backends.onnx.wasm;
      if (wasm) {
        wasm.wasmPaths = wasmPaths ?? defaultTfjsWasmPaths();
        wasm.proxy = false;
      }
    }
    return tf;
  })();
  return loaded;
}

export const isNodeRuntime = IS_NODE;
