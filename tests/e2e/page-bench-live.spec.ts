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
import fs from 'node:fs';
import os from 'node:os';
import { expect, test, type Page } from '@playwright/test';

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

const gapFigures = (g: number[]) => ({ frames: g.length, median: Number(quantile(g, 0.5).toFixed(1)), p95: Number(quantile(g, 0.95).toFixed(1)), max: Number(Math.max(...g).toFixed(1)) });

test('benchmark: live mode — prompt latency, underruns, repeated frames, frame gaps live vs idle', async ({ page }) => {
  test.skip(process.env.EMDM_BENCH !== '1', 'benchmark: set EMDM_BENCH=1 to run it');
  const seconds = Number(process.env.EMDM_BENCH_LIVE_SECONDS ?? 160);
  const idleSeconds = Number(process.env.EMDM_BENCH_IDLE_SECONDS ?? 10);
  test.setTimeout((seconds + idleSeconds + 240) * 1000);
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  const env = await page.evaluate(() => ({ env: window.emdm.environment, steps: Number(document.querySelector<HTMLOutputElement>('#steps-out')!.textContent) }));

  // idle: a motion playing, nothing generating
  await page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', seconds: 9.8, seed: 1 }));
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
});
