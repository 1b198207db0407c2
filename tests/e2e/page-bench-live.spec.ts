// Live mode benchmark on the demo page in headless Chromium (issue 33's page bars; WASM, the page's defaults: the
// shipped text model, its default file and steps). First the idle page: a generated motion playing, no generation,
// its requestAnimationFrame gaps (again after the session). Then a live session through the real prompt box (Enter) with a prompt at a random
// moment of every 5 s (a seeded draw): prompt → first new frame latency on the live clock (the
// stream's stats: median, 95th percentile), underruns, frames displayed and repeated, and the page's frame gaps live
// against idle (95th percentile, max). A benchmark, not a test: it runs only with EMDM_BENCH=1, asserts nothing about
// speed, and writes bench-live.json to the test output folder.
//
//   EMDM_BENCH=1 npx playwright test tests/e2e/page-bench-live.spec.ts
//
// EMDM_BENCH_LIVE_SECONDS (default 160: 32 prompts) is the session's length; EMDM_BENCH_IDLE_SECONDS (default 10).
// EMDM_BENCH_OUT=docs/results/json/live-emdm-t2m-web-page-wasm.json also writes the results JSON RESULTS.md's "Live
// stream" section reads (task "live-page", emdm.eval.live_section).
//
// The soak (the issue's long-run bar): EMDM_BENCH_SOAK_MINUTES=10 runs a live session through the prompt box with a
// prompt every 5 s (cycling PROMPTS) for that many minutes, samples every 10 s the JS heap after a forced GC (CDP),
// the DOM nodes, the stream's buffered frames and list lengths, and follows every displayed frame's pelvis height
// and root distance from the stage centre; EMDM_BENCH_SOAK_OUT=docs/results/json/live-emdm-t2m-web-page-soak.json
// writes its results JSON (task "live-soak").
//
//   EMDM_BENCH=1 EMDM_BENCH_SOAK_MINUTES=10 npx playwright test tests/e2e/page-bench-live.spec.ts -g soak
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { expect, test, type Page } from '@playwright/test';
import { LIVE_DEFAULTS } from '../../src/live/core';

/** One prompt in each slot of this length, at a random moment of it. */
const SLOT_MS = 5000;
const PROMPTS = ['a person walks forward', 'a person waves with the right hand', 'a person raises both hands', 'a person runs forward',
  'a person squats down', 'a person walks backward', 'a person turns around', 'a person jumps', 'a person bows', 'a person kicks'];

/** A seeded uniform draw in [0, 1) (mulberry32). */
function rng(seed: number): () => number {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

const quantile = (a: number[], p: number) => {
  const s = [...a].sort((x, y) => x - y);
  return s.length ? s[Math.min(s.length - 1, Math.floor(p * s.length))] : NaN;
};

/** Start recording requestAnimationFrame gaps in the page; the returned function stops and gives them (ms). */
async function recordGaps(page: Page): Promise<() => Promise<number[]>> {
  await page.evaluate(() => {
    const w = window as unknown as { gaps: { list: number[]; on: boolean } };
    const g = (w.gaps = { list: [] as number[], on: true });
    let last = -1;
    const tick = (t: number) => {
      if (last >= 0) g.list.push(t - last);
      last = t;
      if (g.on) requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  });
  return () => page.evaluate(() => {
    const g = (window as unknown as { gaps: { list: number[]; on: boolean } }).gaps;
    g.on = false;
    return g.list;
  });
}

/** The real clips' pelvis height range (m): min / max of joint 0's y over every frame of the 7,202 windows of the
 * prepared dataset (data/dataset/new_joints/*.npy, 664,250 frames; lying down to climbing). Computed with
 * `np.concatenate([np.load(f)[:, 0, 1] for f in glob('data/dataset/new_joints/*.npy')])`: min 0.047, max 1.777
 * (1st / 99th percentiles 0.625 / 1.483). kinematics.py records only pelvis drops, not heights. */
const REAL_PELVIS_M = { min: 0.047, max: 1.777, p01: 0.625, p99: 1.483, source: 'data/dataset/new_joints (7,202 windows, 664,250 frames)' };

/** Where the runs happened, for the results JSON. */
const where = (page: Page, load: number[]) => ({
  runtime: `Chromium ${page.context().browser()?.version() ?? '?'} headless`, hardware: `${os.cpus()[0]?.model.trim()}, ${os.cpus().length} cores`,
  load: Number(Math.max(...load).toFixed(2)), loadAverage: load.map((v) => Number(v.toFixed(2))),
});

/** Write a results JSON (schema 1, emdm.eval.report) to `file` when set. */
function writeResults(file: string | undefined, body: Record<string, unknown>): void {
  if (!file) return;
  fs.mkdirSync(path.dirname(file), { recursive: true });
  fs.writeFileSync(file, JSON.stringify({ schema: 1, ...body }, null, 1) + '\n');
  console.log(`wrote ${file}`);
}

/** The page ready on WASM without a motion: the worker's environment and the steps slider's value. */
async function openPage(page: Page) {
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  return page.evaluate(() => ({ env: window.emdm.environment, steps: Number(document.querySelector<HTMLOutputElement>('#steps-out')!.textContent) }));
}

const gapFigures = (g: number[]) => ({ frames: g.length, median: Number(quantile(g, 0.5).toFixed(1)), p95: Number(quantile(g, 0.95).toFixed(1)), max: Number(Math.max(...g).toFixed(1)) });

test('benchmark: live mode — prompt latency, underruns, repeated frames, frame gaps live vs idle', async ({ page }) => {
  test.skip(process.env.EMDM_BENCH !== '1', 'benchmark: set EMDM_BENCH=1 to run it');
  const seconds = Number(process.env.EMDM_BENCH_LIVE_SECONDS ?? 160);
  const idleSeconds = Number(process.env.EMDM_BENCH_IDLE_SECONDS ?? 10);
  test.setTimeout((seconds + idleSeconds + 240) * 1000);
  const env = await openPage(page);

  // idle: a motion playing, nothing generating
  const model = (await page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', seconds: 9.8, seed: 1 }))).model;
  const load0 = os.loadavg()[0];
  let stop = await recordGaps(page);
  await page.waitForTimeout(idleSeconds * 1000);
  const idle = await stop();

  // live: the real prompt box, Enter at random moments
  await page.locator('#prompt').fill(PROMPTS[0]);
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live!.active, null, { timeout: 120_000 });
  const startShown = await page.evaluate(() => ({ displayed: window.emdm.live!.displayed, repeated: window.emdm.live!.repeated, poseMs: window.emdm.live!.poseMs }));
  stop = await recordGaps(page);
  const draw = rng(33);
  const t0 = Date.now();
  let sent = 0;
  // one prompt in each 5 s slot, at a random moment of it
  for (let k = 0; (k + 1) * SLOT_MS <= seconds * 1000; k++) {
    await page.waitForTimeout(Math.max(0, t0 + (k + draw()) * SLOT_MS - Date.now()));
    await page.locator('#prompt').fill(PROMPTS[(1 + sent) % PROMPTS.length]);
    await page.locator('#prompt').press('Enter');
    sent++;
  }
  await page.waitForTimeout(Math.max(0, seconds * 1000 - (Date.now() - t0)));
  const live = await stop();
  const load1 = os.loadavg()[0];
  const r = await page.evaluate(() => {
    const l = window.emdm.live!;
    return { stats: l.stats()!, displayed: l.displayed, repeated: l.repeated, poseMs: l.poseMs, prompts: l.prompts() };
  });
  // idle again after live mode (the page's adaptive quality may have changed meanwhile: both idle figures are printed)
  await page.locator('#live').click();
  await page.waitForFunction(() => !window.emdm.live!.on);
  stop = await recordGaps(page);
  await page.waitForTimeout(idleSeconds * 1000);
  const idleAfter = await stop();

  const lat = r.stats.latencies;
  const summary = {
    cpuCores: os.cpus().length, loadAverage: [Number(load0.toFixed(2)), Number(load1.toFixed(2))], environment: env.env, steps: env.steps,
    seconds, promptsSent: sent, latencies: lat.length,
    latencyMedianS: Number(quantile(lat, 0.5).toFixed(3)), latencyP95S: Number(quantile(lat, 0.95).toFixed(3)), latencyMaxS: Number(Math.max(...lat).toFixed(3)),
    windows: r.stats.windows, dropped: r.stats.dropped, windowMsMedian: Math.round(quantile(r.stats.windowMs, 0.5)), windowMsP95: Math.round(quantile(r.stats.windowMs, 0.95)),
    underruns: r.stats.underruns, coastedFrames: r.stats.coastedFrames,
    displayed: r.displayed - startShown.displayed, repeated: r.repeated - startShown.repeated,
    poseMsPerFrame: Number(((r.poseMs - startShown.poseMs) / Math.max(1, r.displayed - startShown.displayed)).toFixed(3)),
    frameGapMs: {
      idle: gapFigures(idle), live: gapFigures(live), idleAfter: gapFigures(idleAfter),
    },
  };
  console.log(`live benchmark: ${sent} prompts in ${seconds} s at ${env.steps} steps (${env.env?.threads} WASM threads), load ${load0.toFixed(2)} → ${load1.toFixed(2)} on ${os.cpus().length} cores\n`
    + `  prompt → first new frame: median ${summary.latencyMedianS} s, p95 ${summary.latencyP95S} s, max ${summary.latencyMaxS} s (${lat.length} of ${sent} prompts)\n`
    + `  windows ${summary.windows} (dropped ${summary.dropped}), window ms median ${summary.windowMsMedian} / p95 ${summary.windowMsP95}\n`
    + `  underruns ${summary.underruns} (${summary.coastedFrames} frames played back), frames displayed ${summary.displayed}, repeated ${summary.repeated}, `
    + `posing from the stream ${summary.poseMsPerFrame} ms per displayed frame\n`
    + `  frame gaps (rAF, ms): ${(['idle', 'live', 'idleAfter'] as const).map((k) => `${k} median ${summary.frameGapMs[k].median} p95 ${summary.frameGapMs[k].p95} max ${summary.frameGapMs[k].max}`).join('; ')}\n`
    + `  live p95 / idle p95: ${(summary.frameGapMs.live.p95 / summary.frameGapMs.idle.p95).toFixed(2)} (before), ${(summary.frameGapMs.live.p95 / summary.frameGapMs.idleAfter.p95).toFixed(2)} (after)`);
  fs.writeFileSync(test.info().outputPath('bench-live.json'), JSON.stringify({ summary, latencies: lat, prompts: r.prompts }, null, 1));
  writeResults(process.env.EMDM_BENCH_OUT, {
    task: 'live-page', name: `live-${model}-page-wasm`, model, ...where(page, [load0, load1]), steps: env.steps,
    threads: env.env?.threads ?? null, live: LIVE_DEFAULTS, summary, latencies: lat,
  });
});

interface SoakSample {
  /** seconds since the session started */
  t: number;
  heapMB: number;
  /** CDP's Nodes (DOM nodes alive, detached ones included) and the document's elements */
  nodes: number;
  elements: number;
  bufferedFrames: number;
  lists: { latencies: number; windowMs: number; blends: number; prompts: number };
  /** the displayed frames since the sample before: pelvis height min/max (m), largest root distance from the stage centre (m) */
  pelvis: [number, number];
  rootDistance: number;
  frames: number;
}

const mean = (a: number[]) => a.reduce((x, y) => x + y, 0) / a.length;
const mb = (v: number) => Number(v.toFixed(2));

/** Follow every displayed frame in the page: its pelvis height and root distance, min/max since the last `take()`. */
async function followFrames(page: Page): Promise<() => Promise<{ pelvis: [number, number]; rootDistance: number; frames: number }>> {
  await page.evaluate(() => {
    const w = window as unknown as { soak: { lo: number; hi: number; dist: number; frames: number; last: number } };
    const s = (w.soak = { lo: Infinity, hi: -Infinity, dist: 0, frames: 0, last: -1 });
    const tick = () => {
      const l = window.emdm.live!;
      const f = l.shownFrame();
      const r = l.last();
      if (f && f.frame !== s.last) {
        s.last = f.frame;
        s.lo = Math.min(s.lo, f.joints[1]);
        s.hi = Math.max(s.hi, f.joints[1]);
        s.frames++;
      }
      if (r) s.dist = Math.max(s.dist, Math.hypot(r.root[0], r.root[2]));
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  });
  return () => page.evaluate(() => {
    const s = (window as unknown as { soak: { lo: number; hi: number; dist: number; frames: number } }).soak;
    const out = { pelvis: [s.lo, s.hi] as [number, number], rootDistance: s.dist, frames: s.frames };
    Object.assign(s, { lo: Infinity, hi: -Infinity, dist: 0, frames: 0 });
    return out;
  });
}

test('benchmark: live mode soak — heap, DOM nodes, stream buffers, pelvis height over minutes', async ({ page }) => {
  const minutes = Number(process.env.EMDM_BENCH_SOAK_MINUTES ?? 0);
  test.skip(process.env.EMDM_BENCH !== '1' || !(minutes > 0), 'benchmark: set EMDM_BENCH=1 and EMDM_BENCH_SOAK_MINUTES to run it');
  const seconds = minutes * 60;
  test.setTimeout((seconds + 300) * 1000);
  const env = await openPage(page);
  const model = (await page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', seconds: 2, seed: 1 }))).model;
  const cdp = await page.context().newCDPSession(page);
  await cdp.send('Performance.enable');
  const load0 = os.loadavg()[0];

  await page.locator('#prompt').fill(PROMPTS[0]);
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live!.active, null, { timeout: 120_000 });
  const take = await followFrames(page);
  const start = await page.evaluate(() => ({ displayed: window.emdm.live!.displayed, repeated: window.emdm.live!.repeated }));
  const t0 = Date.now();
  const samples: SoakSample[] = [];
  const sample = async () => {
    await cdp.send('HeapProfiler.collectGarbage');
    const { metrics } = await cdp.send('Performance.getMetrics');
    const metric = (name: string) => metrics.find((m) => m.name === name)?.value ?? NaN;
    const p = await page.evaluate(() => {
      const l = window.emdm.live!;
      const st = l.stats()!;
      return {
        elements: document.getElementsByTagName('*').length, bufferedFrames: st.bufferedFrames,
        lists: { latencies: st.latencies.length, windowMs: st.windowMs.length, blends: st.blends.length, prompts: l.prompts().length },
      };
    });
    const f = await take();
    samples.push({ t: Math.round((Date.now() - t0) / 1000), heapMB: metric('JSHeapUsedSize') / 2 ** 20, nodes: metric('Nodes'), ...p, ...f });
  };
  await sample();
  let sent = 0;
  let nextSample = t0 + 10_000;
  // a prompt every 5 s, a sample every 10 s (between prompts: the GC does not land on a prompt's Enter)
  for (let k = 1; k * SLOT_MS <= seconds * 1000; k++) {
    await page.waitForTimeout(Math.max(0, t0 + k * SLOT_MS - Date.now()));
    await page.locator('#prompt').fill(PROMPTS[(1 + sent) % PROMPTS.length]);
    await page.locator('#prompt').press('Enter');
    sent++;
    if (Date.now() + 2500 >= nextSample) {
      await page.waitForTimeout(Math.max(0, nextSample - Date.now()));
      await sample();
      nextSample += 10_000;
    }
  }
  const load1 = os.loadavg()[0];
  const r = await page.evaluate(() => {
    const l = window.emdm.live!;
    return { stats: l.stats()!, displayed: l.displayed, repeated: l.repeated };
  });
  await page.locator('#live').click();
  await page.waitForFunction(() => !window.emdm.live!.on);

  const heap = samples.map((s) => s.heapMB);
  const first = samples.filter((s) => s.t <= 60).map((s) => s.heapMB);
  const last = samples.filter((s) => s.t >= seconds - 60).map((s) => s.heapMB);
  const lo = Math.min(...samples.map((s) => s.pelvis[0]));
  const hi = Math.max(...samples.map((s) => s.pelvis[1]));
  const lat = r.stats.latencies;
  const summary = {
    minutes, promptsSent: sent, samples: samples.length, framesFollowed: samples.reduce((a, s) => a + s.frames, 0),
    heapMB: { first: mb(heap[0]), last: mb(heap[heap.length - 1]), max: mb(Math.max(...heap)), firstMinuteMean: mb(mean(first)), lastMinuteMean: mb(mean(last)) },
    heapGrowthMB: mb(mean(last) - mean(first)),
    nodes: { first: samples[0].nodes, last: samples[samples.length - 1].nodes, max: Math.max(...samples.map((s) => s.nodes)) },
    bufferedFramesMax: Math.max(...samples.map((s) => s.bufferedFrames)),
    listsLast: samples[samples.length - 1].lists,
    pelvisM: { min: mb(lo), max: mb(hi) }, realPelvisM: REAL_PELVIS_M,
    pelvisWithinReal: lo >= REAL_PELVIS_M.min && hi <= REAL_PELVIS_M.max,
    rootDistanceMaxM: mb(Math.max(...samples.map((s) => s.rootDistance))),
    underruns: r.stats.underruns, coastedFrames: r.stats.coastedFrames, windows: r.stats.windows, dropped: r.stats.dropped,
    displayed: r.displayed - start.displayed, repeated: r.repeated - start.repeated,
    latencyMedianS: Number(quantile(lat, 0.5).toFixed(3)), latencyP95S: Number(quantile(lat, 0.95).toFixed(3)), latencies: lat.length,
  };
  const h = summary.heapMB;
  console.log(`live soak: ${minutes} min, ${sent} prompts, ${samples.length} samples, load ${load0.toFixed(2)} → ${load1.toFixed(2)} on ${os.cpus().length} cores\n`
    + `  JS heap after GC (MB): first ${h.first}, last ${h.last}, max ${h.max}; first-minute mean ${h.firstMinuteMean} → last-minute mean ${h.lastMinuteMean}: growth ${summary.heapGrowthMB} MB (bar 20)\n`
    + `  DOM nodes ${summary.nodes.first} → ${summary.nodes.last} (max ${summary.nodes.max}); buffered frames max ${summary.bufferedFramesMax}; lists at the end ${JSON.stringify(summary.listsLast)}\n`
    + `  pelvis height over ${summary.framesFollowed} displayed frames: ${summary.pelvisM.min}–${summary.pelvisM.max} m (real clips ${REAL_PELVIS_M.min}–${REAL_PELVIS_M.max} m: ${summary.pelvisWithinReal ? 'within' : 'OUTSIDE'}); root at most ${summary.rootDistanceMaxM} m from the stage centre\n`
    + `  underruns ${summary.underruns} (${summary.coastedFrames} frames played back), repeated ${summary.repeated} of ${summary.displayed} displayed; latency median ${summary.latencyMedianS} s, p95 ${summary.latencyP95S} s`);
  fs.writeFileSync(test.info().outputPath('bench-live-soak.json'), JSON.stringify({ summary, samples }, null, 1));
  writeResults(process.env.EMDM_BENCH_SOAK_OUT, {
    task: 'live-soak', name: `live-${model}-page-soak`, model, ...where(page, [load0, load1]), steps: env.steps,
    threads: env.env?.threads ?? null, summary, samples: samples.map((s) => ({ ...s, heapMB: mb(s.heapMB), pelvis: s.pelvis.map(mb), rootDistance: mb(s.rootDistance) })),
  });
  // a benchmark: it asserts only that it ran
  expect(samples.length).toBeGreaterThan(1);
  expect(summary.framesFollowed).toBeGreaterThan(0);
});
