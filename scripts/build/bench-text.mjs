#!/usr/bin/env node
// Text-encoder figures: load time and per-prompt latency of the shipped MiniLM
//   - in Node (transformers.js + onnxruntime-node, src/text loaded through Vite's SSR loader),
//   - in headless Chromium (transformers.js + ORT-web WASM, the built test page tests/e2e/pages/text),
// plus the sizes of the shipped files. Usage: node scripts/build/bench-text.mjs [--prompts N] [--skip-browser]
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { createServer } from 'vite';

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
  const vite = await createServer({ configFile: false, root: ROOT, logLevel: 'error', server: { middlewareMode: true, hmr: false }, appType: 'custom', optimizeDeps: { noDiscovery: true } });
  try {
    const { loadManifest } = await vite.ssrLoadModule('/src/manifest.ts');
    const { createTextEncoder } = await vite.ssrLoadModule('/src/text/index.ts');
    const { loadTransformers } = await vite.ssrLoadModule('/src/text/transformersEnv.ts');
    const ti = performance.now();
    await loadTransformers();
    const importMs = performance.now() - ti;
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
    await vite.close();
  }
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
await benchNode();
if (!SKIP_BROWSER) await benchBrowser();
