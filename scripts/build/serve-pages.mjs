// Build a folder of test pages (each <dir>/index.html) with Vite, against the project's public/
// (models; the self-hosted ORT is copied into the build's ort/), and serve the result with `vite preview` and the COOP/COEP headers.
// Used by tests/e2e/text.spec.ts and scripts/build/bench-text.mjs.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { build, preview } from 'vite';
import { copyOrt } from './copy-ort.mjs';
import { oneOnnxRuntime } from './one-ort.mjs';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const HEADERS = {
  'Cross-Origin-Opener-Policy': 'same-origin',
  'Cross-Origin-Embedder-Policy': 'require-corp',
  'Cross-Origin-Resource-Policy': 'same-origin',
};

function pages(dir) {
  const input = {};
  for (const rel of fs.readdirSync(dir, { recursive: true, encoding: 'utf8' })) {
    if (path.basename(rel) === 'index.html') input[path.dirname(rel) === '.' ? 'main' : path.dirname(rel)] = path.join(dir, rel);
  }
  if (!Object.keys(input).length) throw new Error(`serve-pages: no index.html under ${dir}`);
  return input;
}

/** Build `pagesDir` into a temp folder and serve it on 127.0.0.1:`port` (0 = any free port). */
export async function buildAndServe({ pagesDir, port = 0 }) {
  const outDir = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-pages-'));
  const common = { configFile: false, root: pagesDir, publicDir: path.join(ROOT, 'public'), logLevel: 'warn', plugins: [oneOnnxRuntime()], worker: { format: 'es', plugins: () => [oneOnnxRuntime()] } };
  await build({
    ...common,
    build: { outDir, emptyOutDir: true, target: 'es2022', chunkSizeWarningLimit: 8192, rollupOptions: { input: pages(pagesDir) } },
  });
  copyOrt(path.join(outDir, 'ort'));
  const server = await preview({
    ...common,
    build: { outDir },
    preview: { host: '127.0.0.1', port, strictPort: port !== 0, headers: HEADERS },
  });
  const addr = server.httpServer.address();
  const url = `http://127.0.0.1:${typeof addr === 'object' && addr ? addr.port : port}`;
  return {
    url,
    async close() {
      await new Promise((r) => server.httpServer.close(() => r(undefined)));
      fs.rmSync(outDir, { recursive: true, force: true });
    },
  };
}
