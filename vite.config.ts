/// <reference types="vitest/config" />
// Vite (dev/build/preview) and vitest configuration.
// - root is web/ (the pages), static files come from public/ (the models).
// - `vite build` (production, dist/) contains the demo (web/index.html) and the library's examples
//   (web/examples/*.html, e.g. /examples/minimal.html; they import 'emdm-web' = src/index.ts and
//   'emdm-web/three' = src/three.ts, the aliases below, as package.json's exports). The test pages
//   (web/harness/: no CSP, takes ?models=<any URL>) are built only in the test mode
//   (`vite build --mode e2e`, into dist-e2e/), which Playwright's test server builds and serves;
//   the dev server serves every page.
// - ONNX Runtime is wired by the package's own plugin, `emdm()` of 'emdm-web/vite' (src/vite.ts), as in a
//   consumer's app, with `webgpu: true` (the demo runs on WebGPU where a visitor has it): its two runtimes' wasm
//   (WASM's and WebGPU's) at /ort/ with files.json (from node_modules in dev, written into the build),
//   transformers.js on the same onnxruntime-web, ES-module workers, COOP/COEP headers on dev AND preview so
//   ORT-web can use wasm threads (SharedArrayBuffer). The models come from public/models (publicDir).
// - the build writes .br/.gz beside every compressible file and preview serves them with
//   Content-Encoding (scripts/build/precompress.mjs; README "Hosting" for static hosts).
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { defineConfig } from 'vite';
// @ts-expect-error -- plain ESM build script without type declarations
import { precompress } from './scripts/build/precompress.mjs';
import { CROSS_ORIGIN_ISOLATION_HEADERS, emdm } from './src/vite.ts';   // with its extension, as Node's own loader needs

const ROOT = path.dirname(fileURLToPath(import.meta.url));
const WEB = path.join(ROOT, 'web');

export { CROSS_ORIGIN_ISOLATION_HEADERS };

/** The mode of the test build (`vite build --mode e2e`): the demo plus the test pages. */
export const E2E_MODE = 'e2e';
/** The mode of scripts/build/serve-pages.mjs's builds: their own root and pages with this wiring (no demo pages, not
 * precompressed). */
export const PAGES_MODE = 'pages';

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

// public/ort/ was the ORT folder of older builds (a copy-ort script): Vite would copy it into dist/ beside
// the plugin's ort/, so it goes.
fs.rmSync(path.join(ROOT, 'public', 'ort'), { recursive: true, force: true });

export default defineConfig(({ mode }) => {
  const inputs = mode === PAGES_MODE ? {} : pageInputs(WEB, { testPages: mode === E2E_MODE });
  return {
    root: WEB,
    publicDir: path.join(ROOT, 'public'),
    plugins: [...emdm({ webgpu: true }), ...(mode === PAGES_MODE ? [] : [precompress()])],
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
