// Figures for the demo page in headless Chromium (WASM backend): cold start to ready, generate latency
// for 196 frames at the default steps, playback fps, and the JS heap after 100 generations.
// A benchmark, not a test: it runs only with EMDM_BENCH=1 and prints what it measured (also written to
// its test output folder as bench.json). `UPDATE_SCREENSHOT=1` also refreshes docs/screenshot.png.
import fs from 'node:fs';
import os from 'node:os';
import { expect, test, type Page } from '@playwright/test';

const PROMPT = 'a person walks forward';

async function ready(page: Page, query: string): Promise<number> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 300_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  return page.evaluate(() => window.emdm.startup.readyMs);
}

const median = (xs: number[]) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

test('demo screenshot (test artefact; docs/screenshot.png with UPDATE_SCREENSHOT=1)', async ({ page }) => {
  await page.setViewportSize({ width: 1440, height: 900 });
  await ready(page, `noauto=1&backend=wasm&quality=high`);
  await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 6, seed: 3 }), PROMPT);
  await page.evaluate(() => window.emdm.seek(2.2));
  await page.waitForTimeout(1500); // camera follow settles
  const png = await page.screenshot();
  fs.writeFileSync(test.info().outputPath('screenshot.png'), png);
  if (process.env.UPDATE_SCREENSHOT === '1') fs.writeFileSync('docs/screenshot.png', png);
});

test('benchmark: cold start, 196-frame latency, playback fps, heap over 100 generations', async ({ page }) => {
  test.skip(process.env.EMDM_BENCH !== '1', 'benchmark: set EMDM_BENCH=1 to run it');
  test.setTimeout(1_800_000);
  await page.setViewportSize({ width: 1280, height: 720 });
  const coldMs = await ready(page, 'noauto=1&backend=wasm');
  const info = await page.evaluate(async () => {
    const m = await (await fetch('/models/manifest.json')).json();
    const name = Object.keys(m.models).find((k) => m.models[k].task === 'text')!;
    return { name, steps: m.models[name].defaultSteps as number, bytes: m.files[m.models[name].onnx].bytes as number };
  });

  // 196 frames (9.8 s) at the default step count: one warm-up, then 5 timed runs.
  const runs: Array<{ totalMs: number; stepMs: number[]; encodeMs: number; decodeMs: number; ikMs: number; threads: number }> = [];
  for (let i = 0; i < 6; i++) {
    const r = await page.evaluate(([t, seed]) => window.emdm.generate({ mode: 'text', text: t, seconds: 9.8, seed }), [PROMPT, i] as const);
    expect(r.frames).toBe(196);
    expect(r.modelCalls).toBe(info.steps);
    if (i > 0) runs.push(r.timings);
  }
  const total = median(runs.map((r) => r.totalMs + r.ikMs));
  const step = median(runs.flatMap((r) => r.stepMs));

  // Playback at the display rate while idle.
  await page.evaluate(() => window.emdm.seek(0, true));
  await page.waitForTimeout(5000);
  const fps = await page.evaluate(() => window.emdm.playbackFps());
  const quality = await page.evaluate(() => window.emdm.quality());

  // Heap after 100 generations at the defaults (196 frames, default steps), after GC.
  const cdp = await page.context().newCDPSession(page);
  const heap = async () => {
    await cdp.send('HeapProfiler.collectGarbage');
    return (await cdp.send('Runtime.getHeapUsage')).usedSize;
  };
  const heap0 = await heap();
  const t0 = Date.now();
  await page.evaluate(async (t) => {
    for (let i = 0; i < 100; i++) await window.emdm.generate({ mode: 'text', text: t, seconds: 9.8, seed: 1000 + i });
  }, PROMPT);
  const wall100 = (Date.now() - t0) / 1000;
  const heap100 = await heap();

  const figures = {
    model: info.name, modelBytes: info.bytes, cpuCores: os.cpus().length, loadAverage: os.loadavg()[0],
    coldStartToReadyMs: Math.round(coldMs),
    generate196: { steps: info.steps, medianTotalMs: Math.round(total), medianStepMs: Math.round(step),
      medianEncodeMs: Math.round(median(runs.map((r) => r.encodeMs))), threads: runs[0].threads,
      realTimeFactor: Number((9.8 / (total / 1000)).toFixed(2)) },
    playbackFps: Number(fps.toFixed(1)), renderQuality: quality,
    heap: { beforeMB: Number((heap0 / 2 ** 20).toFixed(1)), after100MB: Number((heap100 / 2 ** 20).toFixed(1)), wallSeconds: Math.round(wall100) },
  };
  console.log(JSON.stringify(figures, null, 1));
  fs.writeFileSync(test.info().outputPath('bench.json'), JSON.stringify(figures, null, 1));
  expect(heap100 - heap0).toBeLessThan(16 * 2 ** 20);
});
