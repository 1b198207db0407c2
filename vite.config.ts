/// <reference types="vitest/config" />
// Vite (dev/build/preview) and vitest configuration.
// - root is web/ (the pages), static files come from public/ (models, self-hosted ORT wasm).
// - `vite build` (production, dist/) contains the demo (web/index.html) and the library's examples
//   (web/examples/*.html, e.g. /examples/minimal.html; they import 'emdm-web' = src/index.ts and
//   'emdm-web/three' = src/three.ts, the aliases below, as package.json's exports). The test pages
//   (web/harness/: no CSP, takes ?models=<any URL>) are built only in the test mode
//   (`vite build --mode e2e`, into dist-e2e/), which Playwright's test server builds and serves;
//   the dev server serves every page.
// - COOP/COEP headers on dev AND preview so ORT-web can use wasm threads (SharedArrayBuffer).
// - the build writes .br/.gz beside every compressible file and preview serves them with
//   Content-Encoding (scripts/build/precompress.mjs; README "Hosting" for static hosts).
// - the ORT wasm binaries are copied into public/ort/ before anything runs (scripts/build/copy-ort.mjs);
//   transformers.js is resolved onto the same onnxruntime-web (scripts/build/one-ort.mjs).
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { defineConfig, type Plugin } from 'vite';
// @ts-expect-error -- plain ESM build script without type declarations
import { copyOrt } from './scripts/build/copy-ort.mjs';
// @ts-expect-error -- plain ESM build script without type declarations
import { oneOnnxRuntime } from './scripts/build/one-ort.mjs';
// @ts-expect-error -- plain ESM build script without type declarations
import { precompress } from './scripts/build/precompress.mjs';

const ROOT = path.dirname(fileURLToPath(import.meta.url));
const WEB = path.join(ROOT, 'web');

export const CROSS_ORIGIN_ISOLATION_HEADERS = {
  'Cross-Origin-Opener-Policy': 'same-origin',
  'Cross-Origin-Embedder-Policy': 'require-corp',
  'Cross-Origin-Resource-Policy': 'same-origin',
};

/** The mode of the test build (`vite build --mode e2e`): the demo plus the test pages. */
export const E2E_MODE = 'e2e';

/**
 * The pages of a build, keyed by folder ('main' for web/index.html) or by path without .html for the
 * examples ('examples/minimal'): the demo and the examples, plus with `testPages` every
 * web/**\/index.html (the test harness).
 */
export function pageInputs(webDir: string = WEB, { testPages = false }: { testPages?: boolean } = {}): Record<string, string> {
  const inputs: Record<string, string> = {};
  if (!fs.existsSync(webDir)) return inputs;
  const examples = path.join(webDir, 'examples');
  const examplePages = fs.existsSync(examples) ? fs.readdirSync(examples).filter((f) => f.endsWith('.html')).sort() : [];
  for (const f of examplePages) inputs[`examples/${f.slice(0, -'.html'.length)}`] = path.join(examples, f);
  if (!testPages) {
    const demo = path.join(webDir, 'index.html');
    return fs.existsSync(demo) ? { main: demo, ...inputs } : inputs;
  }
  const entries = fs.readdirSync(webDir, { recursive: true, encoding: 'utf8' });
  for (const rel of entries.sort()) {
    if (path.basename(rel) !== 'index.html') continue;
    if (rel.split(path.sep).includes('node_modules')) continue;
    const dir = path.dirname(rel);
    const key = dir === '.' ? 'main' : dir.split(path.sep).join('/');
    inputs[key] = path.join(webDir, rel);
  }
  return inputs;
}

copyOrt(ROOT);

/**
 * Dev server only: ORT loads its wasm glue with a runtime `import(wasmPaths + 'ort-wasm-*.mjs')`.
 * Vite's dev server rewrites such imports (`?import`) and refuses to serve public/ files as
 * modules, so answer /ort/* straight from public/ before Vite's transforms.
 * (The production build serves public/ files as-is, so nothing is needed there.)
 */
function serveOrtRaw(): Plugin {
  return {
    name: 'emdm-serve-ort-raw',
    apply: 'serve',
    configureServer(server) {
      server.middlewares.use((req, res, next) => {
        const url = (req.url ?? '').split('?')[0];
        const m = /^\/(ort)\/(ort-wasm-[\w.-]+\.(mjs|wasm))$/.exec(url);
        if (!m) return next();
        const file = path.join(ROOT, 'public', m[1], m[2]);
        if (!fs.existsSync(file)) return next();
        res.setHeader('Content-Type', m[3] === 'mjs' ? 'text/javascript' : 'application/wasm');
        for (const [k, v] of Object.entries(CROSS_ORIGIN_ISOLATION_HEADERS)) res.setHeader(k, v);
        fs.createReadStream(file).pipe(res);
      });
    },
  };
}

export default defineConfig(({ mode }) => {
  const inputs = pageInputs(WEB, { testPages: mode === E2E_MODE });
  return {
    root: WEB,
    publicDir: path.join(ROOT, 'public'),
    plugins: [serveOrtRaw(), oneOnnxRuntime(), precompress()],
    resolve: {
      // the library as its users import it (package.json "exports"): the examples use these names
      alias: [
        { find: /^emdm-web$/, replacement: path.join(ROOT, 'src/index.ts') },
        { find: /^emdm-web\/three$/, replacement: path.join(ROOT, 'src/three.ts') },
      ],
    },
    build: {
      outDir: path.join(ROOT, mode === E2E_MODE ? 'dist-e2e' : 'dist'),
      emptyOutDir: true,
      target: 'es2022',
      chunkSizeWarningLimit: 4096,
      rollupOptions: Object.keys(inputs).length ? { input: inputs } : {},
    },
    server: {
      host: '127.0.0.1',
      port: 5173,
      headers: CROSS_ORIGIN_ISOLATION_HEADERS,
      fs: { allow: [ROOT] },
    },
    preview: {
      host: '127.0.0.1',
      port: 5173,
      headers: CROSS_ORIGIN_ISOLATION_HEADERS,
    },
    optimizeDeps: {
      // ORT locates its wasm via wasmPaths (public/ort/); pre-bundling it breaks that lookup.
      exclude: ['onnxruntime-web', '@huggingface/transformers'],
    },
    worker: { format: 'es', plugins: () => [oneOnnxRuntime()] },
    test: {
      root: ROOT,
      include: ['tests/unit/**/*.test.ts'],
      environment: 'node',
      testTimeout: 60_000,
      hookTimeout: 120_000,
      pool: 'forks',
      maxWorkers: 2,
    },
  };
});
