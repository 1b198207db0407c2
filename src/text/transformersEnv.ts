/**
 * The one place that loads and configures transformers.js for the text encoders.
 *
 * - Local files only (`allowRemoteModels = false`): nothing is fetched from the Hub or a CDN.
 * - Every model file is fetched by `fetchVerified` (size + sha256 against the manifest) BEFORE
 *   transformers.js asks for it, and handed over through `env.customCache`, so transformers.js
 *   never reads an unverified byte and nothing is downloaded twice.
 * - Browser: transformers.js runs on the project's onnxruntime-web (the bundler resolves its
 *   'onnxruntime-web' import to ours: src/vite.ts `oneOnnxRuntime`), the same instance as the
 *   step models (src/runtime/ort.ts), configured there before transformers.js is imported: one
 *   .wasm to download and compile, one thread count. Node: transformers.js uses onnxruntime-node.
 */
import { loadMark, loadWasmOrt, type RuntimeConfig } from '../runtime/ort';

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

let loaded: Promise<Transformers> | null = null;

/**
 * transformers.js, configured once (local files only, verified cache; in the browser on the project's
 * ONNX Runtime, configured with `runtime` first so transformers.js sees its wasm location and threads).
 */
export function loadTransformers(runtime: RuntimeConfig = {}): Promise<Transformers> {
  loaded ??= (async () => {
    // ORT first: transformers.js points an unconfigured ORT at a CDN when it is imported
    if (!IS_NODE) await loadWasmOrt(runtime);
    const tf = await import('@huggingface/transformers');
    loadMark('transformers-module');
    const env = tf.env;
    env.allowRemoteModels = false;
    env.allowLocalModels = true;
    env.useBrowserCache = false;
    env.useFSCache = false;
    env.useCustomCache = true;
    env.customCache = verifiedCache;
    if (!IS_NODE) {
      const wasm = env.backends.onnx.wasm;
      if (wasm) wasm.proxy = false;
    }
    return tf;
  })();
  loaded.catch(() => {
    loaded = null;
  });
  return loaded;
}

export const isNodeRuntime = IS_NODE;
