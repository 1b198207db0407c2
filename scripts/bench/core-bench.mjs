#!/usr/bin/env node
// Benchmark of the TypeScript core: for each shipped model, ms per denoising step and per
// 196-frame motion at several step counts, on ORT-web WASM with 1 and 2 threads, in Node and in
// headless Chromium (web/harness/ on the Vite dev server, cross-origin isolated), and the
// real-time factor (seconds of motion per second of compute).
//
//   node scripts/bench/core-bench.mjs                      # all shipped models, steps 1,2,4,10
//   node scripts/bench/core-bench.mjs --models emdm-t2m-web --steps 4,10 --reps 3 --threads 1,2
//   node scripts/bench/core-bench.mjs --no-browser         # Node only
//   node scripts/bench/core-bench.mjs --variant int8       # the models' int8 variant
//
// Each (environment, thread count) runs in a fresh process / page: ORT's thread count is global.
// Timings are medians over --reps generations after two warm-up generations; "motion" = encode + all steps
// (guided: one batched call per step) + decode. Without shipped models it benchmarks the tiny
// fixture model (tests/fixtures/parity/tiny-step.onnx) so the command itself can be checked.
import { spawn } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { ROOT, cli, withLibrary } from './common.mjs';

const { args, opt, flag, list } = cli();

// --models-dir: another models folder (served to the browser harness at /bench-models/)
const MODELS_DIR = path.resolve(opt('models-dir', path.join(ROOT, 'public', 'models')));
const manifestPath = path.join(MODELS_DIR, 'manifest.json');
const shipped = fs.existsSync(manifestPath) ? Object.keys(JSON.parse(fs.readFileSync(manifestPath, 'utf8')).models ?? {}) : [];
const models = list(opt('models', shipped.join(',') || 'tiny'));
const stepCounts = list(opt('steps', '1,2,4,10')).map(Number);
const threadsList = list(opt('threads', '1,2')).map(Number);
const frames = Number(opt('frames', '196'));
const reps = Number(opt('reps', '3'));
const variant = opt('variant', undefined); // e.g. int8 (a key of the model's `variants`)
const FPS = 20;

function conditionFor(entry) {
  if (!entry) return { type: 'action', label: 0 };
  if (entry.condition.type === 'action') return { type: 'action', label: 0 };
  if (entry.condition.type === 'text') return { type: 'text', text: 'a person walks forward and then turns around' };
  return { type: 'none' };
}

// ---------------------------------------------------------------------------------------------
// worker: one Node process, one thread count
async function nodeWorker() {
  const threads = Number(opt('threads', '1'));
  await withLibrary(async (load) => {
    const { openModel } = await load('src/openModel.ts');
    const { loadManifest } = await load('src/manifest.ts');
    const { computeSchedule } = await load('src/sampler/schedule.ts');
    const out = [];
    for (const model of models) {
      let manifest = await loadManifest(MODELS_DIR + '/');
      let baseUrl = MODELS_DIR + '/';
      if (model === 'tiny') ({ manifest, baseUrl } = await tinyManifest(manifest, computeSchedule));
      const entry = manifest.models[model];
      const gen = await openModel({ manifest, baseUrl, model, variant, backend: 'wasm', threads });
      const condition = conditionFor(entry);
      const steps = stepCounts.filter((s) => entry.supportedSteps.includes(s));
      // warm-up: V8 tiers WASM up (Liftoff → TurboFan) over the first runs
      for (let i = 0; i < 2; i++) await gen.generate({ condition, frames, steps: Math.max(...steps), guidance: entry.guidance, seed: 1 });
      const results = [];
      for (const s of steps) {
        const totals = [];
        const per = [];
        let calls = 0;
        for (let i = 0; i < reps; i++) {
          const r = await gen.generate({ condition, frames, steps: s, guidance: entry.guidance, seed: 100 + i });
          totals.push(r.timings.totalMs);
          per.push(...r.timings.stepMs);
          calls = r.modelCalls;
        }
        results.push({ steps: s, msPerStep: median(per), msPerMotion: median(totals), modelCalls: calls });
      }
      out.push({ env: 'node', model: variant ? `${model}:${variant}` : model, threads: gen.threads, guidance: entry.guidance, results });
      await gen.dispose();
    }
    process.stdout.write('BENCH ' + JSON.stringify(out) + '\n');
  });
}

async function tinyManifest(real, computeSchedule) {
  const crypto = await import('node:crypto');
  const dir = path.join(ROOT, 'tests', 'fixtures', 'parity');
  const h = (b) => crypto.createHash('sha256').update(b).digest('hex');
  const onnx = fs.readFileSync(path.join(dir, 'tiny-step.onnx'));
  const ms = fs.readFileSync(path.join(dir, 'tiny.meanstd.f32'));
  const sched = Object.fromEntries(stepCounts.map((T) => {
    const s = computeSchedule(T);
    return [String(T), { time: [...s.time], coef1: [...s.coef1], coef2: [...s.coef2], sigma: [...s.sigma] }];
  }));
  return {
    baseUrl: dir + '/',
    manifest: {
      ...real,
      models: { tiny: {
        task: 'action', condition: { type: 'action', labels: ['a', 'b', 'c', 'd', 'e', 'f', 'g', 'h'], dim: 8 },
        onnx: 'tiny-step.onnx', meanStd: 'tiny.meanstd.f32', zDim: 64, featureDim: 263, fps: 20, maxFrames: 196, guidance: 2.5,
        defaultSteps: 4, supportedSteps: stepCounts, schedules: sched, files: ['tiny-step.onnx', 'tiny.meanstd.f32'],
      } },
      files: { ...real.files, 'tiny-step.onnx': { bytes: onnx.length, sha256: h(onnx) }, 'tiny.meanstd.f32': { bytes: ms.length, sha256: h(ms) } },
    },
  };
}

const median = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];

function runNode(threads) {
  return new Promise((resolve, reject) => {
    const child = spawn(process.execPath, [fileURLToPath(import.meta.url), '--worker', 'node', '--threads', String(threads), '--models', models.join(','), '--steps', stepCounts.join(','), '--frames', String(frames), '--reps', String(reps), '--models-dir', MODELS_DIR, ...(variant ? ['--variant', variant] : [])], { stdio: ['ignore', 'pipe', 'inherit'] });
    let buf = '';
    child.stdout.on('data', (d) => (buf += d));
    child.on('exit', (code) => {
      const line = buf.split('\n').find((l) => l.startsWith('BENCH '));
      if (code !== 0 || !line) reject(new Error(`node worker (threads ${threads}) failed with code ${code}:\n${buf}`));
      else resolve(JSON.parse(line.slice(6)));
    });
  });
}

// ---------------------------------------------------------------------------------------------
// browser: Vite dev server (COOP/COEP) + headless Chromium, one page per thread count
async function runBrowser() {
  const { createServer } = await import('vite');
  const { chromium } = await import('playwright-core');
  const port = Number(opt('port', '5191'));
  // serve --models-dir at /bench-models/ so the harness can load a folder outside public/
  const serveModels = {
    name: 'bench-models',
    configureServer(srv) {
      srv.middlewares.use('/bench-models', (req, res, next) => {
        const rel = decodeURIComponent((req.url ?? '/').split('?')[0]).replace(/^\/+/, '');
        const file = path.join(MODELS_DIR, rel);
        if (!file.startsWith(MODELS_DIR) || !fs.existsSync(file) || !fs.statSync(file).isFile()) return next();
        res.setHeader('Content-Length', fs.statSync(file).size);
        res.setHeader('Cross-Origin-Resource-Policy', 'same-origin');
        fs.createReadStream(file).pipe(res);
      });
    },
  };
  const server = await createServer({ configFile: path.join(ROOT, 'vite.config.ts'), server: { port, strictPort: true, hmr: false }, logLevel: 'error', plugins: [serveModels] });
  await server.listen();
  const browser = await chromium.launch({
    executablePath: process.env.CHROMIUM_PATH ?? '/usr/bin/chromium',
    args: ['--no-sandbox', '--disable-gpu', '--disable-quic', '--no-first-run', '--disable-background-networking', '--disable-component-update', '--disable-sync'],
  });
  const out = [];
  try {
    for (const threads of threadsList) {
      const page = await browser.newPage();
      const errors = [];
      page.on('pageerror', (e) => errors.push(e.message));
      await page.goto(`http://127.0.0.1:${port}/harness/?threads=${threads}&backend=wasm&models=/bench-models/`);
      await page.waitForFunction(() => window.coreHarness?.ready === true, null, { timeout: 120_000 });
      const info = await page.evaluate(() => window.coreHarness.info());
      for (const model of models) {
        const entry = model === 'tiny' ? { guidance: 2.5, supportedSteps: [2, 4], condition: { type: 'action' } } : JSON.parse(fs.readFileSync(manifestPath, 'utf8')).models[model];
        const steps = stepCounts.filter((s) => entry.supportedSteps.includes(s));
        const r = await page.evaluate((req) => window.coreHarness.bench(req), { model, variant, condition: conditionFor(entry), frames, stepCounts: steps, guidance: entry.guidance, reps });
        out.push({ env: `chromium${info.crossOriginIsolated ? '' : ' (not isolated)'}`, model: variant ? `${model}:${variant}` : model, threads: r.threads, guidance: entry.guidance, results: r.results });
      }
      if (errors.length) throw new Error(`harness page errors: ${errors.join('; ')}`);
      await page.close();
    }
  } finally {
    await browser.close();
    await server.close();
  }
  return out;
}

function report(rows) {
  const seconds = frames / FPS;
  console.log(`\nEMDM core benchmark: ${frames} frames (${seconds.toFixed(1)} s of motion), median of ${reps} runs, ORT-web WASM`);
  console.log('env                model            thr  guid steps  calls  ms/step  ms/motion  real-time x');
  for (const r of rows) {
    for (const x of r.results) {
      const rtf = seconds / (x.msPerMotion / 1000);
      console.log(
        `${r.env.padEnd(18)} ${r.model.padEnd(16)} ${String(r.threads).padStart(3)}  ${String(r.guidance).padStart(4)} ${String(x.steps).padStart(5)}  ${String(x.modelCalls).padStart(5)}  ${x.msPerStep.toFixed(1).padStart(7)}  ${x.msPerMotion.toFixed(0).padStart(9)}  ${rtf.toFixed(2).padStart(11)}`,
      );
    }
  }
}

if (opt('worker') === 'node') {
  await nodeWorker();
} else {
  const rows = [];
  if (!flag('no-node')) for (const t of threadsList) rows.push(...(await runNode(t)));
  if (!flag('no-browser')) rows.push(...(await runBrowser()));
  report(rows);
  if (opt('json')) fs.writeFileSync(opt('json'), JSON.stringify({ frames, reps, rows }, null, 1));
}
