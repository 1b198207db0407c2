#!/usr/bin/env node
// Which ONNX Runtime .wasm one build can ship: the WASM execution provider's cost in headless Chromium of
// `onnxruntime-web/wasm`'s plain build (ort-wasm-simd-threaded.wasm) against `onnxruntime-web/webgpu`'s
// (ort-wasm-simd-threaded.asyncify.wasm, which also runs the WASM EP). Per build: the .wasm's size (raw and
// brotli), the time to create the first session (fetch + compile + load), and one generator step at 196 frames
// (batch 2, as classifier-free guidance runs it) for each model file, median of --reps runs after a warm-up.
// Both builds run in one browser, in alternating order, on the same files.
//
//   node scripts/bench/ort-wasm-bench.mjs [--reps 15] [--threads 1] [--models emdm-t2m-web.int8.onnx,emdm-t2m-web.onnx]
import fs from 'node:fs';
import http from 'node:http';
import path from 'node:path';
import zlib from 'node:zlib';
import { cli, ROOT } from './common.mjs';

const { opt, list } = cli();
const REPS = Number(opt('reps', '15'));
const THREADS = Number(opt('threads', '1'));
const MODELS = list(opt('models', 'emdm-t2m-web.int8.onnx,emdm-t2m-web.onnx'));
const ORT = path.join(ROOT, 'node_modules', 'onnxruntime-web', 'dist');
const BUILDS = { plain: 'ort.wasm.min.mjs', asyncify: 'ort.webgpu.min.mjs' };
const WASM = { plain: 'ort-wasm-simd-threaded.wasm', asyncify: 'ort-wasm-simd-threaded.asyncify.wasm' };

const PAGE = `<!doctype html><script type="module">
window.bench = async (build, model, reps, threads) => {
  const ort = await import('/ort/' + build);
  ort.env.wasm.numThreads = threads;
  ort.env.wasm.wasmPaths = location.origin + '/ort/';
  const t0 = performance.now();
  const s = await ort.InferenceSession.create('/models/' + model, { executionProviders: ['wasm'] });
  const createMs = performance.now() - t0;
  const B = 2, L = 196, D = 263;
  const rnd = (n) => Float32Array.from({ length: n }, (_, i) => Math.sin(i * 12.9898) * 0.5);
  const feeds = {
    x_t: new ort.Tensor('float32', rnd(B * L * D), [B, L, D]), z: new ort.Tensor('float32', rnd(B * 64), [B, 64]),
    cond: new ort.Tensor('float32', rnd(B * 384), [B, 384]), t: new ort.Tensor('float32', new Float32Array(B).fill(0.5), [B]),
    mask: new ort.Tensor('float32', new Float32Array(B * L).fill(1), [B, L]),
  };
  await s.run(feeds);
  const ms = [];
  for (let i = 0; i < reps; i++) { const a = performance.now(); await s.run(feeds); ms.push(performance.now() - a); }
  await s.release();
  return { createMs, ms };
};
</script>`;

function serve() {
  const server = http.createServer((req, res) => {
    const url = (req.url ?? '/').split('?')[0];
    let file = null;
    if (url.startsWith('/ort/')) file = path.join(ORT, path.basename(url));
    else if (url.startsWith('/models/')) file = path.join(ROOT, 'public', 'models', path.basename(url));
    res.setHeader('Cross-Origin-Opener-Policy', 'same-origin');
    res.setHeader('Cross-Origin-Embedder-Policy', 'require-corp');
    if (url === '/') return res.setHeader('Content-Type', 'text/html'), res.end(PAGE);
    if (!file || !fs.existsSync(file)) return (res.statusCode = 404), res.end();
    res.setHeader('Content-Type', file.endsWith('.wasm') ? 'application/wasm' : file.endsWith('.mjs') ? 'text/javascript' : 'application/octet-stream');
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((ok) => server.listen(0, '127.0.0.1', () => ok(server)));
}

const median = (xs) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];
const mb = (n) => (n / 1e6).toFixed(1);

async function main() {
  for (const [k, f] of Object.entries(WASM)) {
    const bytes = fs.readFileSync(path.join(ORT, f));
    const br = zlib.brotliCompressSync(bytes, { params: { [zlib.constants.BROTLI_PARAM_QUALITY]: 9 } }).length;
    console.log(`${k.padEnd(8)} ${f}: ${mb(bytes.length)} MB, brotli ${mb(br)} MB`);
  }
  const server = await serve();
  const { chromium } = await import('playwright-core');
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM_PATH ?? '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  try {
    const results = {};
    for (const model of MODELS) {
      for (const order of [['plain', 'asyncify'], ['asyncify', 'plain']]) {
        for (const k of order) {
          const page = await browser.newPage();   // a fresh page: ORT's module state is per document
          await page.goto(`http://127.0.0.1:${server.address().port}/`);
          const r = await page.evaluate(([b, m, n, t]) => window.bench(b, m, n, t), [BUILDS[k], model, REPS, THREADS]);
          ((results[model] ??= {})[k] ??= { create: [], ms: [] }).create.push(r.createMs);
          results[model][k].ms.push(...r.ms);
          await page.close();
        }
      }
      const p = results[model].plain, a = results[model].asyncify;
      for (const [k, r] of [['plain', p], ['asyncify', a]]) {
        console.log(`${model} ${k.padEnd(8)} (${THREADS} thread): step ${median(r.ms).toFixed(1)} ms (min ${Math.min(...r.ms).toFixed(1)}), ` +
          `first session ${r.create.map((x) => x.toFixed(0)).join('/')} ms`);
      }
      console.log(`${model}: asyncify / plain step = ${(median(a.ms) / median(p.ms)).toFixed(3)}`);
    }
  } finally {
    await browser.close();
    server.close();
  }
}

await main();
