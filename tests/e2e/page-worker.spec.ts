// The generation worker (src/worker) behind the demo page, in headless Chromium on WASM:
// - the page keeps drawing frames and running timers while a 10-step, 196-frame motion is generated;
// - the newest request wins: five requests 30 ms apart finish only the last, a click on Generate
//   during a generation stops it at the next step boundary;
// - the motions are bit-identical to the same code run on the page's thread (the core harness) and in
//   Node, on the model file the page runs (the manifest's defaultVariant: int8 for the shipped EMDM models):
//   the worker changes where the sampler runs, not what it computes;
// - "Show steps": each step's x̂0 comes back (character + strip), and the final motion is unchanged.
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { expect, test, type Page } from '@playwright/test';
import { openModel, type GenerateOptions } from '../../src/openModel';
import { chooseVariant, loadManifest } from '../../src/manifest';
import { probeResponsiveness, watchPage } from './helpers';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const MODELS = path.join(ROOT, 'public', 'models') + '/';
const PROMPT = 'a person walks forward';

async function openReady(page: Page, query = 'noauto=1&backend=wasm'): Promise<void> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

test.describe('generation worker', () => {
  test('frames and timers keep running during a 10-step, 196-frame generation', async ({ page }) => {
    const watch = watchPage(page);
    // A small view: WebGL runs on SwiftShader (the CPU) here, so a large canvas measures the software
    // rasteriser's share of two cores rather than whether the page's thread is free.
    await page.setViewportSize({ width: 480, height: 360 });
    await openReady(page);
    const req = { mode: 'text' as const, text: PROMPT, seconds: 9.8, steps: 10, seed: 5 };
    await page.evaluate((r) => window.emdm.generate(r), req); // warm-up: WASM tiers up, the character plays
    await page.evaluate(() => window.emdm.seek(0, true));
    const idle = await probeResponsiveness(page, null);
    const busy = await probeResponsiveness(page, { api: 'emdm', req });
    console.log(`frame gap idle: max ${idle.maxFrameGap.toFixed(1)} ms, median ${idle.medianFrameGap.toFixed(1)} ms (${idle.frames} frames in ${idle.ms.toFixed(0)} ms); `
      + `during generation: max ${busy.maxFrameGap.toFixed(1)} ms, median ${busy.medianFrameGap.toFixed(1)} ms (${busy.frames} frames in ${busy.ms.toFixed(0)} ms); `
      + `50 ms timer: max late ${idle.maxTimerDelay.toFixed(1)} ms idle, ${busy.maxTimerDelay.toFixed(1)} ms during`);
    // Before the worker no frame and no timer ran during a generation: one gap as long as the generation.
    // Always: frames and timer ticks keep coming, no gap spans half of the generation.
    // At least 3 frames and 3 ticks: a frozen page draws one frame and ticks once, after the freeze. (5 of each
    // failed on a loaded 2-core machine whose SwiftShader frames kept even an idle 50 ms timer 133 ms late: 4 ticks
    // in a 1 s generation, the page not frozen.)
    expect(busy.frames).toBeGreaterThanOrEqual(3);
    expect(busy.maxFrameGap).toBeLessThan(busy.ms / 2);
    expect(busy.timerTicks).toBeGreaterThanOrEqual(3);
    expect(busy.maxTimerDelay).toBeLessThan(busy.ms / 2);
    // The bounds, where the machine itself keeps them while idle (a 50 ms timer on time within
    // 25 ms, frames within 50 ms): the longest frame gap at most twice the idle one, floored at 50 ms (three
    // 60 Hz frames: ORT's two WASM threads share two cores with the compositor and SwiftShader, and the
    // scheduler may hold one frame back a slice without the page freezing); the timer never more than 50 ms
    // late (a generation's result arrives as one message, so the page's share of work per step is small).
    // On a machine too loaded to meet them idle (other jobs on its cores) they measure the load, not the page.
    const calm = idle.maxTimerDelay <= 25 && idle.maxFrameGap <= 50;
    test.info().annotations.push({ type: 'responsiveness', description: calm ? 'strict bounds applied' : `machine overloaded while idle (timer ${idle.maxTimerDelay.toFixed(0)} ms late, frame gap ${idle.maxFrameGap.toFixed(0)} ms): strict bounds not applied` });
    if (calm) {
      expect(busy.maxFrameGap).toBeLessThanOrEqual(Math.max(2 * idle.maxFrameGap, 50));
      expect(busy.maxTimerDelay).toBeLessThanOrEqual(50);
    } else {
      console.log(`machine overloaded while idle (load average ${os.loadavg()[0].toFixed(1)}): the 2× / 50 ms bounds were not applied`);
    }
    watch.assertClean();
  });

  test('five requests 30 ms apart: only the last runs to the end', async ({ page }) => {
    await openReady(page);
    await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 1, steps: 1, seed: 1 }), PROMPT);
    const c0 = await page.evaluate(() => ({ ...window.emdm.counters }));
    const { out, pending } = await page.evaluate(async (t) => {
      const calls: Promise<unknown>[] = [];
      const settled: boolean[] = [];
      const pending: boolean[] = []; // request i was still running when request i + 1 was sent
      for (let i = 0; i < 5; i++) {
        if (i > 0) pending.push(!settled[i - 1]);
        const call = window.emdm.generate({ mode: 'text', text: t, seconds: 9.8, steps: 10, seed: 100 + i });
        call.then(() => { settled[i] = true; }, () => { settled[i] = true; });
        calls.push(call);
        await new Promise((r) => setTimeout(r, 30));
      }
      const all = await Promise.allSettled(calls);
      return { pending, out: all.map((s) => (s.status === 'fulfilled' ? { ok: true, seed: (s.value as { state: { seed: number } }).state.seed } : { ok: false, name: (s.reason as Error).name })) };
    }, PROMPT);
    expect(out[4]).toEqual({ ok: true, seed: 104 });
    // Every request still running when a newer one came is cancelled. On a calm machine that is all four (a 10-step,
    // 196-frame motion takes ~0.5 s, the requests come 30 ms apart); a machine so loaded that the page's 30 ms timer
    // fires after a whole generation sends the next request only once the last has finished, and nothing is left
    // to cancel (seen once, under a second test run on the same two cores).
    expect(out.slice(0, 4)).toEqual(pending.map((p, i) => (p ? { ok: false, name: 'AbortError' } : { ok: true, seed: 100 + i })));
    const cancelled = pending.filter(Boolean).length;
    if (cancelled < 4) test.info().annotations.push({ type: 'load', description: `machine overloaded: ${4 - cancelled} of the first four requests finished before the next was sent` });
    const c1 = await page.evaluate(() => ({ ...window.emdm.counters }));
    expect(c1.generations - c0.generations).toBe(5 - cancelled);
    expect(c1.cancelled - c0.cancelled).toBe(cancelled);
    // the cancelled ones stopped early (before the worker all five ran their 10 steps: 50). How many steps
    // they ran depends on when the 30 ms timers fire on a loaded machine, so only the total is bounded.
    console.log(`five requests: ${c1.stepsRun - c0.stepsRun} steps run in all (10 for each of the ${5 - cancelled} that finished)`);
    if (cancelled > 0) expect(c1.stepsRun - c0.stepsRun).toBeLessThan(5 * 10);
    await expect(page.locator('#caption')).toContainText('seed 104');
  });

  test('a click on Generate during a generation cancels it at the next step boundary', async ({ page }) => {
    // a small view, as above: at full size SwiftShader's frames held the page's thread long enough on a loaded
    // machine that the wait for step 2 below saw the generation only when all 10 steps were done
    await page.setViewportSize({ width: 480, height: 360 });
    await openReady(page);
    // warm-up, and the duration of one step on this machine now
    const warm = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 9.8, steps: 10, seed: 1 }), PROMPT);
    const stepMax = Math.max(...warm.timings.stepMs);
    const idle = await probeResponsiveness(page, null); // is the machine calm enough for the page to see step 2 in time?
    const r = await page.evaluate(async (t) => {
      const before = window.emdm.counters.stepsRun;
      const first = window.emdm.generate({ mode: 'text', text: t, seconds: 9.8, steps: 10, seed: 7 });
      const firstDone = first.then(() => 'finished', (e: Error) => e.name).then((how) => ({ how, at: performance.now() }));
      // click once the first generation has run two steps
      while (window.emdm.counters.stepsRun < before + 2) await new Promise((res) => setTimeout(res, 5));
      const clicked = performance.now();
      document.querySelector<HTMLButtonElement>('#generate')!.click();
      const f = await firstDone;
      const stepsOfFirst = window.emdm.counters.stepsRun - before;
      return { how: f.how, stopMs: f.at - clicked, stepsOfFirst };
    }, PROMPT);
    console.log(`click → running generation stopped in ${r.stopMs.toFixed(0)} ms after ${r.stepsOfFirst} of 10 steps (one step takes up to ${stepMax.toFixed(0)} ms now)`);
    // A machine too loaded to keep a 50 ms timer within 25 ms while idle can hold the page's thread until the worker
    // has sent all 10 steps: the click then comes after the end, and there is nothing left to stop (seen once, under
    // a second test run on the same two cores). On a calm machine the click always stops it.
    const calm = idle.maxTimerDelay <= 25 && idle.maxFrameGap <= 50;
    if (!calm && r.how === 'finished') {
      test.info().annotations.push({ type: 'load', description: `machine overloaded (idle timer ${idle.maxTimerDelay.toFixed(0)} ms late): the generation finished before the click reached it` });
      return;
    }
    expect(r.how).toBe('AbortError');
    expect(r.stepsOfFirst).toBeLessThan(10);
    // at most the step under way finishes, plus a message each way (before the worker the click waited for
    // all remaining steps: ≥ 7 steps here)
    expect(r.stopMs).toBeLessThan(2 * stepMax + 250);
    await page.waitForFunction(() => !document.querySelector('#generate')!.classList.contains('busy'), null, { timeout: 120_000 });
  });

  test('worker motions are bit-identical to the page-thread harness and to Node', async ({ page }) => {
    test.setTimeout(300_000);
    const manifest = await loadManifest(MODELS);
    const actionModel = Object.entries(manifest.models).find(([, e]) => e.task === 'action');
    await openReady(page);
    const common = { frames: 60, steps: 4, guidance: 2.5, seed: 31, smooth: true, footCleanup: true };
    // like with like: Node opens the file the page runs (chooseVariant, the one place that decides)
    const node = async (model: string, condition: GenerateOptions['condition']) => {
      const gen = await openModel({ manifest, baseUrl: MODELS, model, variant: chooseVariant(manifest, model), backend: 'wasm', threads: 1 });
      try {
        return Array.from((await gen.generate({ ...common, condition })).motion.joints);
      } finally {
        await gen.dispose();
      }
    };
    // text: the worker's prompt embedding comes from the same ORT-web build as the harness's (page
    // thread); Node gets that embedding, since its encoder runs on onnxruntime-node (last-bit differences)
    const viaWorker = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 3, steps: 4, guidance: 2.5, seed: 31 }), PROMPT);
    expect(viaWorker.frames).toBe(60);
    const harness = await page.context().newPage();
    await harness.goto('/harness/?threads=1&backend=wasm');
    await harness.waitForFunction(() => window.coreHarness?.ready === true, null, { timeout: 120_000 });
    const emb = await harness.evaluate((t) => window.coreHarness.encode(t), PROMPT);
    await harness.close();
    const textModel = viaWorker.model;
    expect(viaWorker.joints).toEqual(await node(textModel, { type: 'vector', vector: Float32Array.from(emb.values) }));
    if (actionModel) {
      const [name, entry] = actionModel;
      const label = entry.condition.type === 'action' ? entry.condition.labels[1] : '';
      const a = await page.evaluate((act) => window.emdm.generate({ mode: 'action', action: act, seconds: 3, steps: 4, guidance: 2.5, seed: 31 }), label);
      expect(a.model).toBe(name);
      expect(a.joints).toEqual(await node(name, { type: 'action', label: 1 }));
    }
  });

  test('show steps: one preview per step, a strip of thumbnails, the same final motion', async ({ page }) => {
    await openReady(page);
    const req = { mode: 'text' as const, text: PROMPT, seconds: 3, steps: 4, guidance: 2.5, seed: 23 };
    await page.evaluate((r) => window.emdm.generate(r), req); // warm-up: WASM tiers up
    const off = await page.evaluate((r) => window.emdm.generate(r), req);
    expect(await page.evaluate(() => window.emdm.previews().length)).toBe(0); // off by default: none sent
    await expect(page.locator('#step-strip')).toBeHidden();
    // the toggle is labelled and reachable from the keyboard
    const box = page.getByLabel('Show steps');
    await box.focus();
    await page.keyboard.press('Space');
    await expect(box).toBeChecked();
    const r = await page.evaluate(async (q) => {
      const out = await window.emdm.generate(q);
      return { out, previews: window.emdm.previews(), end: performance.now() };
    }, req);
    expect(r.previews.map((p) => p.step)).toEqual([1, 2, 3, 4]);
    expect(r.previews.every((p) => p.steps === 4 && p.frames === 60 && p.joints.length === 60 * 22 * 3)).toBe(true);
    expect(r.previews.every((p) => p.joints.every(Number.isFinite))).toBe(true);
    // the predictions change from step to step and come closer to the final motion (it sharpens)
    const dist = (j: number[]) => j.reduce((acc, v, i) => acc + Math.abs(v - r.out.joints[i]), 0) / j.length;
    const d = r.previews.map((p) => dist(p.joints));
    console.log(`show steps: mean |x̂0 joints − final| per step ${d.map((v) => v.toFixed(4)).join(', ')} m`);
    expect(r.previews[0].joints).not.toEqual(r.previews[3].joints);
    expect(d[3]).toBeLessThan(d[0]);
    // each arrived on its own, as its step ended (not all at once with the result), and the character played it
    for (let i = 1; i < 4; i++) expect(r.previews[i].at).toBeGreaterThan(r.previews[i - 1].at);
    expect(r.previews[0].at).toBeLessThan(r.end);
    expect(r.previews.every((p) => p.played)).toBe(true);
    console.log(`show steps: previews arrived ${r.previews.map((p) => (r.end - p.at).toFixed(0)).join(', ')} ms before the result was shown`);
    await expect(page.locator('#step-strip .step-thumb canvas')).toHaveCount(4);
    await expect(page.locator('#step-strip')).toBeVisible();
    // the final motion is bit-identical with and without previews (they draw no random numbers)
    expect(r.out.joints).toEqual(off.joints);
    const ms = r.previews.map((p) => p.ms);
    const mean = (a: number[]) => a.reduce((x, y) => x + y, 0) / a.length;
    console.log(`show steps: preview decode + IK ${mean(ms).toFixed(1)} ms per step in the worker (max ${Math.max(...ms).toFixed(1)}); `
      + `total ${r.out.timings.totalMs.toFixed(0)} ms with previews, ${off.timings.totalMs.toFixed(0)} ms without; step ${mean(r.out.timings.stepMs).toFixed(1)} vs ${mean(off.timings.stepMs).toFixed(1)} ms`);
    // turning it off clears the strip, and the next generation sends none
    await box.uncheck();
    await expect(page.locator('#step-strip')).toBeHidden();
    await page.evaluate((q) => window.emdm.generate(q), req);
    expect(await page.evaluate(() => window.emdm.previews().length)).toBe(0);
  });
});
