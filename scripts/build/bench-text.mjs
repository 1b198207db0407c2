#!/usr/bin/env node
// Text-encoder figures: load time and per-prompt latency of the shipped MiniLM
//   - in Node (transformers.js + onnxruntime-node, src/text loaded through Vite's SSR loader),
//   - in headless Chromium (transformers.js + ORT-web WASM, the built test page tests/e2e/pages/text),
// plus the sizes of the shipped files. Usage: node scripts/build/bench-text.mjs [--prompts N] [--skip-browser]
import fs from 'node:fs';
import path from 'node:path';
import os from 'node:os';
import { execFileSync } from 'node:child_process';
import { fileURLToPath, pathToFileURL } from 'node:url';
import { build } from 'vite';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const args = process.argv.slice(2);
const N = Number(args[args.indexOf('--prompts') + 1] || 0) || 30;
const SKIP_BROWSER = args.includes('--skip-browser');
const PROMPTS = [
  'a person walks forward and then turns around',
  'someone jumps up and down twice',
  'the man kicks with his left leg',
  'a woman dances happily in a circle',
  'an elderly man walks slowly, exhausted',
  'a person waves with both hands above the head',
];
const prompts = Array.from({ length: N }, (_, i) => `${PROMPTS[i % PROMPTS.length]} ${i}`);

function stats(ms) {
  const s = [...ms].sort((a, b) => a - b);
  const mean = s.reduce((a, b) => a + b, 0) / s.length;
  return `mean ${mean.toFixed(1)} ms, median ${s[Math.floor(s.length / 2)].toFixed(1)} ms, p90 ${s[Math.floor(s.length * 0.9)].toFixed(1)} ms`;
}

async function benchNode() {
  // Bundle src/ for Node (dependencies stay external, imported natively) the way an app would ship it.
  // inside node_modules/ so the bundle's bare imports resolve to the project's packages
  const outDir = path.join(ROOT, 'node_modules/.cache/emdm-bench-text');
  try {
    await build({
      configFile: false, root: ROOT, logLevel: 'error',
      build: { ssr: true, outDir, emptyOutDir: true, target: 'node20',
        rollupOptions: { input: { manifest: path.join(ROOT, 'src/manifest.ts'), text: path.join(ROOT, 'src/text/index.ts') } } },
    });
    const ti = performance.now();
    await import('@huggingface/transformers');
    const importMs = performance.now() - ti;
    const { loadManifest } = await import(pathToFileURL(path.join(outDir, 'manifest.js')).href);
    const { createTextEncoder } = await import(pathToFileURL(path.join(outDir, 'text.js')).href);
    const base = path.join(ROOT, 'public/models') + '/';
    const t0 = performance.now();
    const enc = await createTextEncoder(await loadManifest(base), base);
    const loadMs = performance.now() - t0;
    const t1 = performance.now();
    await enc.encode('a person walks');
    const firstMs = performance.now() - t1;
    const ms = [];
    for (const p of prompts) {
      const t = performance.now();
      await enc.encode(p);
      ms.push(performance.now() - t);
    }
    console.log(`node     (transformers.js, onnxruntime-node): import ${importMs.toFixed(0)} ms, load (verify + session) ${loadMs.toFixed(0)} ms, first prompt ${firstMs.toFixed(1)} ms, ${N} prompts: ${stats(ms)}`);
  } finally {
    fs.rmSync(outDir, { recursive: true, force: true });
  }
}

/** Baseline in the same run: Python onnxruntime (native) on the same file, one prompt per call. */
function benchPython() {
  const py = path.join(ROOT, '.venv/bin/python');
  if (!fs.existsSync(py)) return console.log('python   skipped: no .venv (run `make setup`)');
  const code = `
import json, sys, time
t0 = time.perf_counter()
from emdm.text import load_encoder
enc = load_encoder()
load = (time.perf_counter() - t0) * 1000
t = time.perf_counter(); enc.encode(["a person walks"]); first = (time.perf_counter() - t) * 1000
ms = []
for p in json.loads(sys.argv[1]):
    t = time.perf_counter(); enc.encode([p]); ms.append((time.perf_counter() - t) * 1000)
print(json.dumps({"load": load, "first": first, "ms": ms}))`;
  const r = JSON.parse(execFileSync(py, ['-c', code, JSON.stringify(prompts)], { cwd: ROOT, encoding: 'utf8' }).trim().split('\n').pop());
  console.log(`python   (onnxruntime native, baseline): import + load ${r.load.toFixed(0)} ms, first prompt ${r.first.toFixed(1)} ms, ${N} prompts: ${stats(r.ms)}`);
  return r.ms;
}

async function sha256Time() {
  const buf = fs.readFileSync(path.join(ROOT, 'public/models/text/all-MiniLM-L6-v2/onnx/model_quantized.onnx'));
  const t = performance.now();
  await crypto.subtle.digest('SHA-256', buf);
  return performance.now() - t;
}

async function benchBrowser() {
  const { buildAndServe } = await import('./serve-pages.mjs');
  const { chromium } = await import('playwright-core');
  const server = await buildAndServe({ pagesDir: path.join(ROOT, 'tests/e2e/pages') });
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM_PATH ?? '/usr/bin/chromium',
    headless: true,
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  try {
    const page = await (await browser.newContext()).newPage();
    await page.goto(`${server.url}/text/`);
    await page.waitForFunction(() => !!window.textPage);
    const coi = await page.evaluate(() => window.textPage.crossOriginIsolated);
    const threads = await page.evaluate(() => navigator.hardwareConcurrency);
    const info = await page.evaluate(() => window.textPage.load());
    const first = await page.evaluate(() => window.textPage.encode('a person walks'));
    const ms = [];
    for (const p of prompts) ms.push((await page.evaluate((t) => window.textPage.encode(t), p)).ms);
    console.log(`chromium (transformers.js, ORT-web WASM, crossOriginIsolated=${coi}, ${threads} cores): load ${info.loadMs.toFixed(0)} ms ` +
      `(manifest ${info.manifestMs.toFixed(0)} ms, ${(info.bytes / 1e6).toFixed(1)} MB verified), first prompt ${first.ms.toFixed(1)} ms, ${N} prompts: ${stats(ms)}`);
  } finally {
    await browser.close();
    await server.close();
  }
}

const manifest = JSON.parse(fs.readFileSync(path.join(ROOT, 'public/models/manifest.json'), 'utf8'));
for (const [id, e] of Object.entries(manifest.textEncoders)) {
  const sizes = e.files.map((f) => `${f.split('/').slice(2).join('/')} ${(manifest.files[f].bytes / 1e6).toFixed(2)} MB`);
  const total = e.files.reduce((s, f) => s + manifest.files[f].bytes, 0);
  console.log(`files    ${id}: ${sizes.join(', ')}; total ${(total / 1e6).toFixed(1)} MB`);
}
console.log(`machine  ${os.cpus().length} cores, load average ${os.loadavg().map((x) => x.toFixed(1)).join(' ')} (figures scale with contention)`);
console.log(`sha256   of the 23 MB ONNX file (Node WebCrypto): ${(await sha256Time()).toFixed(0)} ms`);
benchPython();
await benchNode();
if (!SKIP_BROWSER) await benchBrowser();
console.log(`machine  load average after: ${os.loadavg().map((x) => x.toFixed(1)).join(' ')}`);
