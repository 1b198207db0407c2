// The demo page (web/index.html) in headless Chromium on the WASM backend: it loads, generates from a
// prompt, the character moves, seeds reproduce, the steps slider changes the model calls, and the
// downloads parse with three's loaders. Bad input and faults: tests/e2e/page-faults.spec.ts.
import fs from 'node:fs';
import { expect, test, type Page } from '@playwright/test';
import { BVHLoader } from 'three/addons/loaders/BVHLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { watchExternalRequests, watchPage } from './helpers';

const PROMPT = 'a person walks forward';

async function openReady(page: Page, query = 'noauto=1&backend=wasm'): Promise<void> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

async function manifestModels(page: Page): Promise<Record<string, { task: string; objective?: string; supportedSteps: number[]; defaultSteps: number }>> {
  return page.evaluate(async () => (await (await fetch('/models/manifest.json')).json()).models);
}

/** Fraction of pixels that differ (any channel by > 24/255) between two PNG screenshots, decoded in the page. */
async function changedFraction(page: Page, a: Buffer, b: Buffer): Promise<number> {
  return page.evaluate(async ([a64, b64]) => {
    const decode = async (s: string) => {
      const bytes = Uint8Array.from(atob(s), (c) => c.charCodeAt(0));
      const bmp = await createImageBitmap(new Blob([bytes], { type: 'image/png' }));
      const c = new OffscreenCanvas(bmp.width, bmp.height);
      const g = c.getContext('2d')!;
      g.drawImage(bmp, 0, 0);
      return g.getImageData(0, 0, bmp.width, bmp.height).data;
    };
    const [x, y] = await Promise.all([decode(a64), decode(b64)]);
    let changed = 0;
    for (let i = 0; i < x.length; i += 4) {
      if (Math.abs(x[i] - y[i]) > 24 || Math.abs(x[i + 1] - y[i + 1]) > 24 || Math.abs(x[i + 2] - y[i + 2]) > 24) changed++;
    }
    return changed / (x.length / 4);
  }, [a.toString('base64'), b.toString('base64')] as const);
}

test.describe('demo page', () => {
  test('loads, becomes ready on WASM with a strict CSP and no external requests', async ({ page, baseURL }) => {
    const watch = watchPage(page);
    const external = watchExternalRequests(page, baseURL!);
    await openReady(page);
    expect(await page.evaluate(() => window.emdm.cspViolations)).toEqual([]);
    const csp = await page.locator('meta[http-equiv="Content-Security-Policy"]').getAttribute('content');
    expect(csp).toContain("script-src 'self' 'wasm-unsafe-eval'");
    expect(csp).not.toContain("'unsafe-eval'");
    expect(csp).not.toContain("'unsafe-inline'");
    // eval is refused by the page's policy (run from a timer: DevTools' own evaluate is exempt from CSP)
    const evalResult = await page.evaluate(() => new Promise<string>((resolve) => setTimeout(() => {
      try {
        resolve(`allowed ${(0, eval)('1 + 1')}`);
      } catch (e) {
        resolve((e as Error).name);
      }
    }, 0)));
    expect(evalResult).toBe('EvalError');
    expect(await page.evaluate(() => window.emdm.cspViolations)).toEqual([expect.stringContaining('script-src: eval')]);
    await expect(page.locator('#status-text')).toContainText('Ready');
    await expect(page.locator('#generate')).toBeEnabled();
    expect(await page.evaluate(() => window.emdm.backend)).toBe('wasm');
    const t = await page.evaluate(() => window.emdm.startup);
    console.log(`cold start to ready: ${t.readyMs.toFixed(0)} ms (manifest ${t.manifestMs.toFixed(0)} ms)`);
    expect(external).toEqual([]);
    watch.assertClean();
  });

});

test.describe('demo page: generating', () => {
  // One page for the group (loading the models is the slow part); counters are compared as deltas.
  test.describe.configure({ mode: 'serial' });
  let page: Page;
  test.beforeAll(async ({ browser }) => {
    test.setTimeout(300_000);
    page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
    await openReady(page, 'noauto=1&backend=wasm&quality=high'); // fixed resolution: frames compare like for like
  });
  test.afterAll(async () => {
    await page?.close();
  });

  test('a typed prompt generates on Enter, the character moves, and timings are shown', async () => {
    const watch = watchPage(page);
    const g0 = await page.evaluate(() => window.emdm.counters.generations);
    await page.locator('#prompt').fill(PROMPT);
    await page.locator('#prompt').press('Enter');
    await page.waitForFunction((n) => window.emdm.counters.generations === n + 1, g0, { timeout: 120_000 });
    await expect(page.locator('#caption')).toContainText(PROMPT);
    await expect(page.locator('#timings')).toBeVisible();
    await expect(page.locator('#t-backend')).toContainText('WASM');
    await expect(page.locator('#dl-bvh')).toBeEnabled();
    expect(new URL(page.url()).searchParams.get('text')).toBe(PROMPT);

    // The character visibly moves: two paused frames differ inside the character's region.
    const viewport = page.locator('#viewport');
    await page.evaluate(() => window.emdm.seek(0.2));
    await page.waitForTimeout(700); // camera follow settles
    const a = await viewport.screenshot();
    await page.evaluate(() => window.emdm.seek(2.5));
    await page.waitForTimeout(150);
    const b = await viewport.screenshot();
    const changed = await changedFraction(page, a, b);
    expect(changed).toBeGreaterThan(0.003);
    // Playing advances the frame index.
    await page.evaluate(() => window.emdm.seek(0, true));
    const f0 = await page.evaluate(() => window.emdm.frame());
    await page.waitForTimeout(600);
    expect(await page.evaluate(() => window.emdm.frame())).toBeGreaterThan(f0 + 3);
    // Play/pause, scrubber and speed.
    await page.locator('#play').click();
    expect((await page.evaluate(() => window.emdm.playback())).playing).toBe(false);
    await page.locator('#scrub').fill('0.5');
    const pb = await page.evaluate(() => window.emdm.playback());
    expect(pb.time).toBeCloseTo(pb.duration / 2, 2);
    await page.waitForTimeout(300);
    expect((await page.evaluate(() => window.emdm.playback())).time).toBe(pb.time);
    await page.locator('#speed').selectOption('2');
    await page.locator('#scene').click();
    await page.keyboard.press('Space');
    const pb2 = await page.evaluate(() => window.emdm.playback());
    expect(pb2.speed).toBe(2);
    expect(pb2.playing).toBe(true);
    fs.writeFileSync(test.info().outputPath('demo.png'), await page.screenshot());
    expect(await page.evaluate(() => window.emdm.cspViolations)).toEqual([]);
    watch.assertClean();
  });

  test('same seed gives the same joints; another seed another motion', async () => {
    const run = (seed: number) => page.evaluate(([s, t]) => window.emdm.generate({ mode: 'text', text: t, seed: s, seconds: 2, steps: 2 }), [seed, PROMPT] as const);
    const a = await run(1234);
    const b = await run(1234);
    const c = await run(99);
    expect(a.frames).toBe(40);
    expect(a.joints.length).toBe(40 * 22 * 3);
    expect(b.joints).toEqual(a.joints);
    const diff = c.joints.reduce((m, v, i) => Math.max(m, Math.abs(v - a.joints[i])), 0);
    expect(diff).toBeGreaterThan(0.01);
  });

  test('the steps slider changes the number of model calls', async () => {
    const models = await manifestModels(page);
    const text = Object.values(models).find((m) => m.task === 'text' && m.objective !== 'diffusion')!;
    const steps = [...text.supportedSteps].sort((x, y) => x - y);
    const calls: number[] = [];
    for (const [k, want] of [[0, steps[0]], [steps.length - 1, steps[steps.length - 1]]] as const) {
      await page.locator('#steps').fill(String(k));
      await expect(page.locator('#steps-out')).toHaveText(String(want));
      await page.locator('#seconds').fill('1');
      await page.locator('#prompt').fill(PROMPT);
      const before = await page.evaluate(() => window.emdm.counters.modelCalls);
      await page.locator('#generate').click();
      await page.waitForFunction((n) => window.emdm.counters.modelCalls > n, before, { timeout: 120_000 });
      calls.push((await page.evaluate(() => window.emdm.counters.modelCalls)) - before);
      await expect(page.locator('#t-calls')).toHaveText(String(calls[calls.length - 1]));
      await page.waitForFunction(() => !document.querySelector('#generate')!.classList.contains('busy'));
    }
    expect(calls).toEqual([steps[0], steps[steps.length - 1]]);
  });

  test('BVH, glTF and joints JSON downloads parse with the right frame count', async () => {
    const r = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 3, steps: 2, seed: 7 }), PROMPT);
    expect(r.frames).toBe(60);
    const grab = async (id: string) => {
      const [dl] = await Promise.all([page.waitForEvent('download'), page.locator(id).click()]);
      return { name: dl.suggestedFilename(), bytes: fs.readFileSync((await dl.path())!) };
    };

    // BVH in metres by default (Blender imports at scale 1.0: the pelvis stands ~0.9 m up, not 90 m),
    // centimetres on request; the file name says which
    const pelvisY = r.joints[1];
    expect(await page.locator('#dl-bvh-units').inputValue()).toBe('m');
    const bvh = await grab('#dl-bvh');
    expect(bvh.name).toMatch(/^emdm-a-person-walks-forward-seed7-metres\.bvh$/);
    const parsed = new BVHLoader().parse(bvh.bytes.toString('utf8'));
    expect(parsed.skeleton.bones.length).toBeGreaterThanOrEqual(22);
    const bvhTimes = parsed.clip.tracks[0].times;
    expect(bvhTimes.length).toBe(r.frames);
    expect(parsed.clip.tracks[0].name).toBe('pelvis.position');
    expect(Math.abs(parsed.clip.tracks[0].values[1] - pelvisY), 'pelvis height, metres').toBeLessThan(1e-3);
    await page.locator('#dl-bvh-units').selectOption('cm');
    const bvhCm = await grab('#dl-bvh');
    expect(bvhCm.name).toMatch(/^emdm-a-person-walks-forward-seed7-centimetres\.bvh$/);
    const parsedCm = new BVHLoader().parse(bvhCm.bytes.toString('utf8'));
    expect(Math.abs(parsedCm.clip.tracks[0].values[1] - 100 * pelvisY), 'pelvis height, centimetres').toBeLessThan(0.1);
    await page.locator('#dl-bvh-units').selectOption('m');

    const glb = await grab('#dl-glb');
    expect(glb.name.endsWith('.glb')).toBe(true);
    const ab = glb.bytes.buffer.slice(glb.bytes.byteOffset, glb.bytes.byteOffset + glb.bytes.byteLength);
    const gltf = await new GLTFLoader().parseAsync(ab as ArrayBuffer, '');
    let skinned = 0;
    let bones = 0;
    gltf.scene.traverse((o) => {
      if ((o as { isSkinnedMesh?: boolean }).isSkinnedMesh) skinned++;
      if ((o as { isBone?: boolean }).isBone) bones++;
    });
    expect(skinned).toBe(1);
    expect(bones).toBe(22);
    expect(gltf.animations.length).toBe(1);
    for (const track of gltf.animations[0].tracks) expect(track.times.length).toBe(r.frames);
    expect(gltf.animations[0].tracks.length).toBe(23); // root position + 22 rotations
    const rootTrack = gltf.animations[0].tracks.find((t) => t.name.endsWith('.position'))!;
    expect(Math.abs(rootTrack.values[1] - pelvisY), 'glTF pelvis height stays in metres').toBeLessThan(1e-3);

    const json = await grab('#dl-json');
    const doc = JSON.parse(json.bytes.toString('utf8'));
    expect(doc.frames).toBe(r.frames);
    expect(doc.positions.length).toBe(r.frames);
    expect(doc.positions[0].length).toBe(22);
    expect(doc.positions[5][3][1]).toBeCloseTo(r.joints[(5 * 22 + 3) * 3 + 1], 3);
  });

  test('a URL reproduces the motion it names', async () => {
    const a = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 2, steps: 2, seed: 4242, guidance: 3 }), PROMPT);
    const link = page.url();
    expect(new URL(link).searchParams.get('seed')).toBe('4242');
    await page.goto(link); // auto-generates what the link describes
    await page.waitForFunction(() => window.emdm?.counters.generations === 1, null, { timeout: 120_000 });
    const b = await page.evaluate(() => window.emdm.generate());
    expect(b.state.seed).toBe(4242);
    expect(b.state.guidance).toBe(3);
    expect(b.joints).toEqual(a.joints);
  });
});
