// Build a folder of test pages (each <dir>/index.html) with Vite and the repository's configuration (vite.config.ts in
// its 'pages' mode: the package's plugin wires ONNX Runtime as for the demo, public/ gives the models), and serve the
// result with `vite preview` and the COOP/COEP headers. Used by tests/e2e/text.spec.ts and scripts/build/bench-text.mjs.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { build, preview } from 'vite';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');

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
  const common = { configFile: path.join(ROOT, 'vite.config.ts'), mode: 'pages', root: pagesDir, logLevel: 'warn' };
  await build({
    ...common,
    build: { outDir, emptyOutDir: true, chunkSizeWarningLimit: 8192, rollupOptions: { input: pages(pagesDir) } },
  });
  const server = await preview({ ...common, build: { outDir }, preview: { host: '127.0.0.1', port, strictPort: port !== 0 } });
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
