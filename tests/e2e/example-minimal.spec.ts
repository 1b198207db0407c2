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
  await page.goto('/examples/minimal.html');
  await page.waitForFunction(() => window.example?.motion !== undefined, null, { timeout: 150_000 });

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
