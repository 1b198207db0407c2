// Retargeting a long motion onto the visitor's character (web/ui/character-picker.ts, src/character/retarget)
// without freezing the page: a 60 s timeline (1,200 frames) is put on three.js's RobotExpressive in slices
// (retargetMotionAsync), so animation frames keep being drawn while it runs, and a newer motion cancels
// the retargeting under way (newest wins; the older clip never replaces the newer one).
// Before the slicing the whole retargeting ran in one task: no frame at all was drawn during it.
// With EMDM_BENCH=1 a benchmark repeats the measure and prints the figures (frame gaps, not asserted).
import os from 'node:os';
import path from 'node:path';
import { expect, test, type Page } from '@playwright/test';
import { watchPage } from './helpers';

interface Stats { started: number; finished: number; cancelled: number; last: { frames: number; ms: number; slices: number; start: number; end: number; firstSliceMs: number; longestSliceMs: number } | null }

/** (window as unknown as WithProbe).emdmCharacter (web/ui/character-picker.ts: CharacterProbe), the fields read here */
interface Probe { active: boolean; retargeting: boolean; frames: number; name: string; status: string; retargets: Stats; jointWorld(j: string): [number, number, number] | null }
type WithProbe = { emdmCharacter: Probe };

/** Six 10 s segments: a 60 s timeline, 1,200 frames at 20 fps. */
const SIXTY = Array.from({ length: 6 }, (_, i) => ({ prompt: i % 2 ? 'a person walks backward' : 'a person walks forward', seconds: 10, seed: 20 + i }));

async function openWithRobot(page: Page): Promise<void> {
  // a small view: WebGL runs on SwiftShader (the CPU) here; a large canvas measures the rasteriser, not the page's thread
  await page.setViewportSize({ width: 480, height: 360 });
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  // one step: the page's step count, which the timeline uses too (the generation is not what is measured)
  await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 2, steps: 1, seed: 1 }));
  await page.locator('#char-file').setInputFiles(path.join(process.cwd(), 'tests/fixtures/rigs/RobotExpressive.glb'));
  await page.waitForFunction(() => (window as unknown as WithProbe).emdmCharacter.active && (window as unknown as WithProbe).emdmCharacter.name === 'RobotExpressive.glb', null, { timeout: 60_000 });
}

interface Gaps { frames: number; maxGap: number; medianGap: number; ms: number; longTasks: number; longestTask: number }
interface Run { idle: Gaps; during: Gaps; retarget: NonNullable<Stats['last']>; before: Stats; after: Stats }

/**
 * Animation-frame gaps on the page's thread: for 2 s idle, then while the 60 s timeline is generated and
 * put on the character, counting the frames drawn and the gaps that overlap the retargeting itself.
 */
async function measure(page: Page, seed = 20): Promise<Run> {
  await page.evaluate((s) => window.emdm.edit!.setSegments(s), SIXTY.map((g, i) => ({ ...g, seed: seed + i })));
  return page.evaluate(async () => {
    // tasks of 50 ms or more on the page's thread (Long Tasks API): [start, end]
    const long: [number, number][] = [];
    const obs = new PerformanceObserver((l) => l.getEntries().forEach((e) => long.push([e.startTime, e.startTime + e.duration])));
    obs.observe({ type: 'longtask', buffered: false });
    const record = async (during: () => Promise<void>) => {
      const frames: number[] = [];
      let on = true;
      const raf = (t: number) => {
        frames.push(t);
        if (on) requestAnimationFrame(raf);
      };
      frames.push(performance.now()); // from now: a task that starts before the first frame is a gap too
      requestAnimationFrame(raf);
      await during();
      await new Promise((r) => requestAnimationFrame(r)); // the frame after the end closes the last gap
      on = false;
      return frames;
    };
    const gapsOf = (frames: number[], from: number, to: number) => {
      // gaps [t_i, t_i+1] overlapping [from, to], and the frames drawn within it
      const gaps = frames.slice(1).map((t, i) => [frames[i], t]).filter(([a, b]) => b >= from && a <= to).map(([a, b]) => b - a);
      const sorted = [...gaps].sort((x, y) => x - y);
      const tasks = long.filter(([a, b]) => b >= from && a <= to).map(([a, b]) => b - a);
      return { frames: frames.filter((t) => t > from && t < to).length, maxGap: Math.max(...gaps), medianGap: sorted[sorted.length >> 1], ms: to - from, longTasks: tasks.length, longestTask: Math.max(0, ...tasks) };
    };
    const t0 = performance.now();
    const idleFrames = await record(() => new Promise((r) => setTimeout(r, 2000)));
    const idle = gapsOf(idleFrames, t0, t0 + 2000);
    const before = (window as unknown as WithProbe).emdmCharacter.retargets;
    const busy = await record(async () => {
      await window.emdm.edit!.generateAll();
      while ((window as unknown as WithProbe).emdmCharacter.retargeting || (window as unknown as WithProbe).emdmCharacter.retargets.finished === before.finished) await new Promise((r) => setTimeout(r, 20));
    });
    const after = (window as unknown as WithProbe).emdmCharacter.retargets;
    const last = after.last!;
    await new Promise((r) => setTimeout(r, 100)); // long-task entries arrive after the task
    obs.disconnect();
    return { idle, during: gapsOf(busy, last.start, last.end), retarget: last, before, after };
  });
}

const fmt = (g: Gaps) => `max ${g.maxGap.toFixed(1)} ms, median ${g.medianGap.toFixed(1)} ms, ${g.frames} frames in ${g.ms.toFixed(0)} ms, ${g.longTasks} task(s) ≥ 50 ms (longest ${g.longestTask.toFixed(0)} ms)`;

test('a 60 s motion is put on a dropped character while the page keeps drawing; a newer motion cancels it', async ({ page }) => {
  test.setTimeout(300_000);
  const watch = watchPage(page);
  await openWithRobot(page);
  const r = await measure(page);
  console.log(`[retarget 1200 frames on RobotExpressive] ${r.retarget.ms.toFixed(0)} ms in ${r.retarget.slices} slices (first ${r.retarget.firstSliceMs.toFixed(0)} ms, longest ${r.retarget.longestSliceMs.toFixed(0)} ms); frame gaps idle: ${fmt(r.idle)}; during the retargeting: ${fmt(r.during)} (load average ${os.loadavg()[0].toFixed(1)} on ${os.cpus().length} cores)`);
  expect(r.retarget.frames).toBe(1200);
  expect(r.after.finished - r.before.finished).toBe(1);
  expect(await page.evaluate(() => [(window as unknown as WithProbe).emdmCharacter.active, (window as unknown as WithProbe).emdmCharacter.frames])).toEqual([true, 1200]);
  // Before the slicing: one task, one gap as long as the whole retargeting and no frame drawn in it. Now
  // it is cut into many slices, frames are drawn all along and no gap spans half of it.
  expect(r.retarget.slices).toBeGreaterThan(10);
  expect(r.during.frames).toBeGreaterThanOrEqual(5);
  expect(r.during.maxGap).toBeLessThan(r.retarget.ms / 2);
  // Where the machine is calm enough while idle (frames within 50 ms), the longest gap stays within a
  // few idle ones: a slice is ~8 ms, plus the frame's own work (the robot's skinning on SwiftShader).
  const calm = r.idle.maxGap <= 50;
  test.info().annotations.push({ type: 'responsiveness', description: calm ? 'idle-relative bound applied' : `machine overloaded while idle (frame gap ${r.idle.maxGap.toFixed(0)} ms): idle-relative bound not applied` });
  if (calm) expect(r.during.maxGap).toBeLessThanOrEqual(Math.max(3 * r.idle.maxGap, 100));

  // newest wins: a new 60 s timeline, and while it is being put on the robot, a 2 s motion (generated once
  // before, so the worker is warm for it). Whether it arrives before the retargeting ends depends on the
  // machine, so up to three tries; old code never cancelled (the retargeting ran in one task).
  const SHORT = { mode: 'text' as const, text: 'a person walks forward', seconds: 2, steps: 1, seed: 3 };
  await page.evaluate((q) => window.emdm.generate(q), SHORT);
  await page.waitForFunction(() => !(window as unknown as WithProbe).emdmCharacter.retargeting);
  let cancelled = 0;
  for (let attempt = 0; attempt < 3 && !cancelled; attempt++) {
    await page.evaluate((s) => window.emdm.edit!.setSegments(s), SIXTY.map((g, i) => ({ ...g, seed: 50 + 10 * attempt + i })));
    const c = await page.evaluate(async (q) => {
      const probe = () => (window as unknown as WithProbe).emdmCharacter;
      const before = probe().retargets;
      await window.emdm.edit!.generateAll();
      const longUnderWay = probe().retargeting;
      await window.emdm.generate(q);
      const statusAtNewer = probe().status;
      while (probe().retargeting) await new Promise((r) => setTimeout(r, 20));
      await new Promise((r) => setTimeout(r, 300)); // nothing older arrives later
      return { before, after: probe().retargets, longUnderWay, statusAtNewer, frames: probe().frames, active: probe().active };
    }, SHORT);
    const n = (k: 'started' | 'finished' | 'cancelled') => c.after[k] - c.before[k];
    console.log(`[retarget newest wins] try ${attempt + 1}: status when the 2 s motion was shown: '${c.statusAtNewer}'; retargetings started ${n('started')}, finished ${n('finished')}, cancelled ${n('cancelled')}`);
    expect(c.longUnderWay).toBe(true);
    expect(n('started')).toBe(2);
    expect(n('finished') + n('cancelled')).toBe(2);
    // whatever the order, the character ends on the newer motion
    expect([c.active, c.frames, c.after.last!.frames]).toEqual([true, 40, 40]);
    cancelled += n('cancelled');
  }
  expect(cancelled, 'a 2 s motion shown while the 60 s one was being retargeted cancelled it').toBe(1);
  // the robot performs the newer motion
  const at = (t: number) => page.evaluate(async (time) => {
    window.emdm.seek(time);
    await new Promise((res) => setTimeout(res, 200));
    return (window as unknown as WithProbe).emdmCharacter.jointWorld('l_ankle');
  }, t);
  const a = await at(0.2);
  const b = await at(1.5);
  expect(Math.hypot(a![0] - b![0], a![1] - b![1], a![2] - b![2])).toBeGreaterThan(0.05);
  await expect(page.locator('#char-status')).toContainText('RobotExpressive.glb: 18/22 joints mapped');
  watch.assertClean();
});

test('benchmark: frame gaps while a 60 s motion is retargeted onto RobotExpressive (printed)', async ({ page }) => {
  test.skip(process.env.EMDM_BENCH !== '1', 'benchmark: set EMDM_BENCH=1 to run it');
  test.setTimeout(900_000);
  await openWithRobot(page);
  const reps = Number(process.env.EMDM_BENCH_REPS ?? 3);
  for (let i = 0; i < reps; i++) {
    const r = await measure(page, 100 * (i + 1));
    console.log(`[retarget bench ${i + 1}/${reps}] 1200 frames on RobotExpressive: ${r.retarget.ms.toFixed(0)} ms in ${r.retarget.slices} slice(s) (first ${r.retarget.firstSliceMs.toFixed(0)} ms, longest ${r.retarget.longestSliceMs.toFixed(0)} ms); frame gaps idle: ${fmt(r.idle)}; during: ${fmt(r.during)}; load average ${os.loadavg().map((l) => l.toFixed(1)).join(' ')} on ${os.cpus().length} cores`);
  }
});
