/**
 * The Vite plugin of the npm package (`emdm-web/vite`): the wiring a Vite app needs to run the library in the
 * browser, in one call.
 *
 * ```ts
 * // vite.config.ts
 * import { defineConfig } from 'vite';
 * import { emdm } from 'emdm-web/vite';
 * export default defineConfig({ plugins: [emdm({ models: 'path/to/models' })] });
 * ```
 *
 * - ONNX Runtime's wasm at `<base>ort/` with the `files.json` (size, sha256) the library checks it against: served
 *   from node_modules by the dev server, written by the build (this repository's pages use this plugin too). One
 *   runtime by default, the WASM backend's (14 MB); `webgpu: true` adds onnxruntime-web/webgpu's (.asyncify, 27 MB
 *   more), and only then does the library try WebGPU (files.json lists what is served: src/loadModel.ts). The
 *   copies Rollup emits under assets/ for ORT's own `new URL(...)` are dropped: never fetched (69 MB).
 * - transformers.js (the text encoder) resolved onto the library's onnxruntime-web: one runtime, one .wasm, no CDN
 *   in workers too; ES-module workers; `optimizeDeps.exclude` for the packages whose
 *   `import.meta.url` lookups pre-bundling would break.
 * - `models` (a copy of the repository's public/models): served at `<base>models/` in dev, and the manifest with
 *   every file a browser loads copied there by the build, each checked against its sha256 first (createGenerator's
 *   default baseUrl; the training weights stay behind: src/assets.ts modelFiles).
 * - Cross-origin isolation headers on the dev and preview servers, so ORT runs on several threads.
 */
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import type { Plugin } from 'vite';
import { AssetError, copyModels, copyOrt, modelFiles, ortFiles } from './assets.ts';   // with its extension: vite.config.ts loads this file too

export interface EmdmPluginOptions {
  /** a models folder (manifest.json and the files it lists); omit when the app serves models itself */
  models?: string;
  /**
   * serve onnxruntime-web/webgpu's runtime too (a second .wasm, 27 MB more), so `backend: 'auto'` runs on WebGPU
   * where the browser has it; default false: one .wasm, and every model runs on WASM
   */
  webgpu?: boolean;
}

export const CROSS_ORIGIN_ISOLATION_HEADERS = {
  'Cross-Origin-Opener-Policy': 'same-origin',
  'Cross-Origin-Embedder-Policy': 'require-corp',
  'Cross-Origin-Resource-Policy': 'same-origin',
};
const HERE = path.dirname(fileURLToPath(import.meta.url));

/** A file under `root` named by a URL path below it, or null (no file, or outside root). */
function inside(root: string, rel: string): string | null {
  const p = path.resolve(root, decodeURIComponent(rel));
  return p.startsWith(root + path.sep) && fs.existsSync(p) && fs.statSync(p).isFile() ? p : null;
}

const TYPES: Record<string, string> = { '.mjs': 'text/javascript', '.wasm': 'application/wasm', '.json': 'application/json' };

/** transformers.js's 'onnxruntime-web' → the library's 'onnxruntime-web/wasm'. */
function oneOnnxRuntime(): Plugin {
  const ours = path.join(HERE, 'runtime', fs.existsSync(path.join(HERE, 'runtime', 'ort.ts')) ? 'ort.ts' : 'ort.js');
  return {
    name: 'emdm-web:one-onnxruntime',
    enforce: 'pre',
    async resolveId(source, importer) {
      if (source !== 'onnxruntime-web' || !importer?.split(path.sep).join('/').includes('/@huggingface/transformers/')) return null;
      const hit = await this.resolve('onnxruntime-web/wasm', ours, { skipSelf: true });
      if (!hit) throw new Error(`emdm-web/vite: cannot resolve onnxruntime-web/wasm for ${importer}`);
      return hit;
    },
  };
}

/** Drop the .wasm copies Rollup emits for ORT's default `new URL('ort-wasm-*.wasm', import.meta.url)`: the library
 * points ORT at `<base>ort/` (wasmPaths), so they are never fetched (~86 MB). */
function dropOrtAssets(): Plugin {
  return {
    name: 'emdm-web:drop-ort-assets',
    generateBundle(_out, bundle) {
      for (const name of Object.keys(bundle)) {
        if (/(^|\/)ort-wasm[^/]*\.wasm$/.test(name) && !name.startsWith('ort/')) delete bundle[name];
      }
    },
  };
}

/** The plugins: add `emdm({ models })` (or `emdm({ models, webgpu: true })`) to the app's `plugins`. */
export function emdm(options: EmdmPluginOptions = {}): Plugin[] {
  const models = options.models ? path.resolve(options.models) : null;
  try {
    if (models) modelFiles(models);                // a wrong folder is an error now, not a 404 in the browser
  } catch (e) {
    throw e instanceof AssetError ? new Error(`emdm-web/vite: models: ${e.message}`) : e;
  }
  let base = '/';
  const ortOptions = { webgpu: options.webgpu ?? false };
  let ort: ReturnType<typeof ortFiles> | null = null;
  const ortNow = () => (ort ??= ortFiles(ortOptions));
  const written = new Set<string>();               // the output folders this build has written the files into
  const main: Plugin = {
    name: 'emdm-web',
    config: () => ({
      optimizeDeps: { exclude: ['emdm-web', 'onnxruntime-web', '@huggingface/transformers'] },
      worker: { format: 'es', plugins: () => [oneOnnxRuntime(), dropOrtAssets()] },
      server: { headers: CROSS_ORIGIN_ISOLATION_HEADERS },
      preview: { headers: CROSS_ORIGIN_ISOLATION_HEADERS },
    }),
    configResolved(config) {
      base = config.base.endsWith('/') ? config.base : config.base + '/';
    },
    configureServer(server) {
      server.middlewares.use((req, res, next) => {
        const url = (req.url ?? '').split('?')[0];
        if (!url.startsWith(base)) return next();
        const rel = url.slice(base.length);
        let file: string | null = null;
        let body: string | null = null;
        if (rel === 'ort/files.json') body = ortNow().list;
        else if (rel.startsWith('ort/')) file = ortNow().files.get(rel.slice(4)) ?? null;
        else if (models && rel.startsWith('models/')) file = inside(models, rel.slice(7));
        if (!file && body === null) return next();
        res.setHeader('Content-Type', TYPES[path.extname(file ?? rel)] ?? 'application/octet-stream');
        for (const [k, v] of Object.entries(CROSS_ORIGIN_ISOLATION_HEADERS)) res.setHeader(k, v);
        if (body !== null) res.end(body);
        else fs.createReadStream(file!).pipe(res);
      });
    },
    buildStart() {
      written.clear();
    },
    writeBundle(out) {
      // once per build and output folder: a flag, not a file there (an app's public/ort/ from `npx emdm-web ort`
      // is in the output before this runs, and its files.json once made the build skip the models and WebGPU's runtime)
      const dir = out.dir;
      if (!dir || written.has(path.resolve(dir))) return;
      written.add(path.resolve(dir));
      copyOrt(path.join(dir, 'ort'), ortOptions);
      if (models) copyModels(models, path.join(dir, 'models'));
    },
  };
  return [oneOnnxRuntime(), dropOrtAssets(), main];
}
