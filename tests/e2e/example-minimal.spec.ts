// The library's minimal example (web/examples/minimal.html, served at /examples/minimal.html by
// `make demo` and by the test server): it generates "a person walks forward" through createGenerator
// (in the generation worker) and plays it on the character from the three.js entry; the bones move.
import { expect, test, type Page } from '@playwright/test';
import { watchExternalRequests, watchPage } from './helpers';

declare global {
  interface Window {
    example?: {
      character: { player: { time: number }; bones: Array<{ name: string; matrixWorld: { elements: number[] } }>; object: { parent: unknown; updateMatrixWorld(force?: boolean): void } };
      motion: { frames: number; fps: number; joints: Float32Array; backend: string; pose: { rootPos: Float32Array } };
      camera: { position: { clone(): { set(x: number, y: number, z: number): { project(c: unknown): { x: number; y: number; z: number } } } } };
      generator: import('../../src/index').MotionGenerator;
    };
  }
}

/** World positions of the named bones and the player's clock, read in the page. */
function bonesNow(page: Page, names: string[]) {
  return page.evaluate((names) => {
    const ch = window.example!.character;
    ch.object.updateMatrixWorld(true);
    const at: Record<string, number[]> = {};
    for (const b of ch.bones) if (names.includes(b.name)) at[b.name] = b.matrixWorld.elements.slice(12, 15);
    return { time: ch.player.time, at };
  }, names);
}

test('minimal example: prompt → motion in the worker → the character moves', async ({ page, baseURL }) => {
  const watch = watchPage(page);
  const external = watchExternalRequests(page, baseURL!);
  const workers: string[] = [];
  page.on('worker', (w) => workers.push(w.url()));
  await page.addInitScript(() => {
    const seen: string[] = ((globalThis as unknown as { cspViolations: string[] }).cspViolations = []);
    document.addEventListener('securitypolicyviolation', (e) => seen.push(`${e.violatedDirective} ${e.blockedURI}`));
  });
  await page.goto('/examples/minimal.html');
  await page.waitForFunction(() => window.example?.motion !== undefined, null, { timeout: 150_000 });
  // the demo's strict CSP holds here too, and nothing the example needs is refused by it (its style is a file)
  const csp = await page.evaluate(() => document.querySelector('meta[http-equiv="Content-Security-Policy"]')?.getAttribute('content'));
  expect(csp).toContain("script-src 'self' 'wasm-unsafe-eval'");
  expect(csp).toContain("style-src 'self';");
  expect(await page.evaluate(() => (globalThis as unknown as { cspViolations: string[] }).cspViolations)).toEqual([]);
  expect(await page.evaluate(() => getComputedStyle(document.getElementById('info')!).position)).toBe('absolute');

  const m = await page.evaluate(() => {
    const { motion, character } = window.example!;
    const r = motion.pose.rootPos;
    const n = motion.frames - 1;
    return {
      frames: motion.frames, fps: motion.fps, joints: motion.joints.length, backend: motion.backend, onStage: character.object.parent !== null,
      travel: Math.hypot(r[n * 3] - r[0], r[n * 3 + 2] - r[2]),
    };
  });
  expect(m).toMatchObject({ frames: 80, fps: 20, joints: 80 * 22 * 3, onStage: true }); // seconds: 4 at 20 fps
  expect(['wasm', 'webgpu']).toContain(m.backend);
  expect(m.travel).toBeGreaterThan(0.3); // "walks forward": the pelvis travels over the 4 s
  await expect(page.locator('#status')).toHaveText(`80 frames at 20 fps, on ${m.backend}`);
  expect(workers.some((u) => /generation\.worker/.test(u))).toBe(true); // generated off the page's thread

  // the camera frames the whole walk: pelvis, head and feet in the picture on every frame (a camera
  // standing on the +Z axis had the character walk through it and out of view for a quarter of the loop)
  const outside = await page.evaluate(() => {
    const { camera, motion } = window.example!;
    const bad: number[] = [];
    for (let f = 0; f < motion.frames; f++) {
      for (const j of [0, 15, 10, 11]) {
        const o = (f * 22 + j) * 3;
        const v = camera.position.clone().set(motion.joints[o], motion.joints[o + 1], motion.joints[o + 2]).project(camera);
        if (!(Math.abs(v.x) <= 1 && Math.abs(v.y) <= 1 && v.z < 1)) {
          bad.push(f);
          break;
        }
      }
    }
    return bad;
  });
  expect(outside, 'frames where the character is out of the picture').toEqual([]);

  // the player runs and the bones follow it: two reads 0.6 s apart differ
  const names = ['pelvis', 'l_ankle', 'r_ankle', 'l_wrist', 'r_wrist'];
  const a = await bonesNow(page, names);
  await page.waitForTimeout(600);
  const b = await bonesNow(page, names);
  expect(Object.keys(a.at).sort()).toEqual([...names].sort());
  expect(b.time).not.toBe(a.time);
  const moved = Math.max(...names.map((n) => Math.hypot(...a.at[n].map((v, i) => v - b.at[n][i]))));
  expect(moved).toBeGreaterThan(0.05);

  expect(external).toEqual([]);
  watch.assertClean();
});

test('the library\'s timeline: one request to the worker, regenerated from a changed segment, bad input named', async ({ page }) => {
  const watch = watchPage(page);
  await page.goto('/examples/minimal.html');
  await page.waitForFunction(() => window.example?.motion !== undefined, null, { timeout: 150_000 });
  const r = await page.evaluate(async () => {
    const g = window.example!.generator;
    const segs = [{ prompt: 'a person walks forward', seconds: 2, seed: 1 }, { prompt: 'a person waves', seconds: 3, seed: 2 }];
    const windows: number[][] = [];
    const t = await g.timeline(segs, { steps: 2, onWindow: (s, d, n) => windows.push([s, d, n]) });
    const again = await g.timeline(segs.map((s, i) => (i === 1 ? { ...s, prompt: 'a person jumps' } : s)), { steps: 2, previous: t });
    const bad = await g.timeline([segs[0], { prompt: ' ', seconds: 1, seed: 3 }], { steps: 2 })
      .then(() => null, (e: Error & { segment?: number }) => ({ name: e.name, segment: e.segment, message: e.message }));
    return {
      frames: t.frames, starts: t.starts, joints: t.joints.length, quats: t.pose.quats.length, windows, made: t.windows.map((w) => w.frames),
      kept: again.features.subarray(0, 40 * 263).every((v, i) => v === t.features[i]),
      changed: again.features.subarray(40 * 263).some((v, i) => v !== t.features[40 * 263 + i]), remade: again.windows.length, bad,
    };
  });
  expect(r).toMatchObject({ frames: 100, starts: [0, 40], joints: 100 * 22 * 3, quats: 100 * 22 * 4, made: [40, 80], kept: true, changed: true, remade: 1 });
  expect(r.windows).toEqual([[0, 0, 2], [0, 0, 2], [1, 1, 2], [1, 2, 2]]);
  expect(r.bad).toMatchObject({ name: 'EditError', segment: 1, message: expect.stringMatching(/segment 2: the prompt is empty/) });
  watch.assertClean();
});
