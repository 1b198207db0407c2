// The "Timeline & editing" panel (web/ui/timeline.ts, issue 14) on the built page: a 3-segment 30 s
// timeline (frames, its BVH in three's BVHLoader, the URL restoring it), an in-between (kept frames
// unchanged), an upper-body edit (legs and root unchanged), a loop (first and last pose meet; in place
// stays put), bad input (a message naming the segment, the other segments kept), and the keyboard.
// Prints the time of a 3 × 5 s timeline against one 5 s motion (figures, not asserted).
import fs from 'node:fs';
import { expect, test, type Page } from '@playwright/test';
import { BVHLoader } from 'three/addons/loaders/BVHLoader.js';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { watchPage } from './helpers';

const STEPS = 1; // the fewest the shipped text model supports: the test checks bookkeeping, not quality
const D = 263;
const J = 22;

test.describe.configure({ mode: 'serial' });

let page: Page;
let watch: ReturnType<typeof watchPage>;
/** the text model's files the page (and its worker) fetched */
const modelFiles: string[] = [];

test.beforeAll(async ({ browser }) => {
  page = await browser.newPage();
  page.context().on('request', (r) => {
    const name = new URL(r.url()).pathname.split('/').pop() ?? '';
    if (name.startsWith('emdm-t2m-web.') && name.endsWith('.onnx')) modelFiles.push(name);
  });
  watch = watchPage(page);
  await page.goto(`/?noauto=1&backend=wasm&steps=${STEPS}&mode=text&text=a+person+walks+forward`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  expect(await page.evaluate(() => typeof window.emdm.edit)).toBe('object');
  // the panel starts folded (the character keeps the room); open it
  await page.locator('#edit-panel summary').click();
  await expect(page.locator('#edit-panel details')).toHaveAttribute('open', '');
});

test.afterAll(async () => {
  await page?.close();
});

/** Frames × 22 joints, position of joint j at frame f. */
const at = (joints: number[], f: number, j: number) => joints.slice((f * J + j) * 3, (f * J + j) * 3 + 3);

/** Heading of frame f (about +Y) from the hips and shoulders, as src/motion/stitch.ts headingAt measures it. */
function heading(joints: number[], f: number): number {
  const [lh, rh, ls, rs] = [1, 2, 16, 17].map((j) => at(joints, f, j));
  const ax = rh[0] - lh[0] + rs[0] - ls[0];
  const az = rh[2] - lh[2] + rs[2] - ls[2];
  return Math.atan2(az, -ax);
}

/** Largest per-joint distance between two frames' poses: each relative to its pelvis x/z and turned to face +Z. */
function poseDistance(a: number[], fa: number, b: number[], fb: number): number {
  const local = (js: number[], f: number, j: number) => {
    const r = at(js, f, 0);
    const p = at(js, f, j);
    const t = -heading(js, f);
    const x = p[0] - r[0];
    const z = p[2] - r[2];
    return [Math.cos(t) * x + Math.sin(t) * z, p[1], -Math.sin(t) * x + Math.cos(t) * z];
  };
  let m = 0;
  for (let j = 0; j < J; j++) {
    const p = local(a, fa, j);
    const q = local(b, fb, j);
    m = Math.max(m, Math.hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
  }
  return m;
}

test('a 3-segment 30 s timeline: 600 frames, one BVH and one GLB of 600 frames, kept in the URL', async ({ browser }) => {
  const segs = [
    { prompt: 'a person walks forward', seconds: 10, seed: 11 },
    { prompt: 'a person waves with the right hand', seconds: 10, seed: 12 },
    { prompt: 'a person walks backward', seconds: 10, seed: 13 },
  ];
  await page.evaluate((s) => window.emdm.edit!.setSegments(s), segs);
  const r = await page.evaluate(() => window.emdm.edit!.generateAll());
  expect(r.kind).toBe('timeline');
  expect(r.frames).toBe(600);
  expect(r.starts).toEqual([0, 200, 400]);
  expect(r.windows).toBe(6); // 10 s = 200 frames: two windows each (a window holds at most 196 frames)
  await expect(page.locator('#t-calls')).toHaveText(String(6 * STEPS)); // one step: none is begun together
  // every window ran the file the page's own generations run (the manifest's default variant), not a second download
  const variant = await page.evaluate(async () => (await (await fetch('/models/manifest.json')).json()).models['emdm-t2m-web'].defaultVariant as string | undefined);
  const expected = variant ? `emdm-t2m-web.${variant}.onnx` : 'emdm-t2m-web.onnx';
  expect(modelFiles).toContain(expected);
  expect(modelFiles.filter((f) => f !== expected), 'model files fetched besides the page default').toEqual([]);
  expect(await page.evaluate(() => window.emdm.edit!.message())).toBe('');
  // the player plays the whole sequence and scrubs it
  const pb = await page.evaluate(() => window.emdm.playback());
  expect(pb.duration).toBeCloseTo(30, 2); // frames 0…599 at 20 fps: 30 s, as the caption says
  await page.evaluate(() => window.emdm.seek(25, false));
  expect(await page.evaluate(() => window.emdm.frame())).toBeCloseTo(500, 0);
  // the stitched motion has no jump at the seams: the pelvis moves no more across one than within the segments
  const cur = (await page.evaluate(() => window.emdm.edit!.current()))!;
  const step = (f: number) => Math.hypot(cur.joints[f * 66] - cur.joints[(f - 1) * 66], cur.joints[f * 66 + 2] - cur.joints[(f - 1) * 66 + 2]);
  const steps = Array.from({ length: 599 }, (_, k) => step(k + 1)).sort((a, b) => a - b);
  const p99 = steps[Math.floor(0.99 * steps.length)];
  for (const seam of [100, 200, 300, 400, 500]) expect(step(seam), `pelvis step at frame ${seam}`).toBeLessThanOrEqual(Math.max(p99 * 1.5, 0.05));

  const [dl] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-bvh').click()]);
  const parsed = new BVHLoader().parse(fs.readFileSync((await dl.path())!, 'utf8'));
  expect(parsed.clip.tracks[0].times.length).toBe(600);
  expect(parsed.skeleton.bones.length).toBeGreaterThanOrEqual(22);
  const [glbDl] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-glb').click()]);
  const glb = fs.readFileSync((await glbDl.path())!);
  const gltf = await new GLTFLoader().parseAsync(glb.buffer.slice(glb.byteOffset, glb.byteOffset + glb.byteLength) as ArrayBuffer, '');
  expect(gltf.animations.length).toBe(1);
  for (const track of gltf.animations[0].tracks) expect(track.times.length).toBe(600);

  // the URL holds the timeline: a reload (or a shared link) restores the segments
  const url = page.url();
  expect(new URL(url).searchParams.get('tl')).toBe(JSON.stringify(segs.map((s) => [s.prompt, s.seconds, s.seed])));
  const other = await browser.newPage();
  await other.goto(`${url}&noauto=1`);
  await other.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await other.evaluate(() => window.emdm.edit!.segments())).toEqual(segs);
  expect(await other.locator('#edit-panel details').getAttribute('open')).not.toBeNull();
  await other.close();
});

test('a shared link with a timeline generates that timeline on load', async ({ browser }) => {
  const segs = [{ prompt: 'a person walks forward', seconds: 2, seed: 1 }, { prompt: 'a person waves', seconds: 1.5, seed: 2 }];
  const other = await browser.newPage();
  const tl = encodeURIComponent(JSON.stringify(segs.map((s) => [s.prompt, s.seconds, s.seed])));
  await other.goto(`/?backend=wasm&steps=${STEPS}&tl=${tl}`);
  await other.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  await other.waitForFunction(() => window.emdm.edit?.current()?.frames === 70, null, { timeout: 120_000 });
  expect(await other.evaluate(() => window.emdm.edit!.segments())).toEqual(segs);
  expect(new URL(other.url()).searchParams.get('tl')).toBe(JSON.stringify(segs.map((s) => [s.prompt, s.seconds, s.seed])));
  expect(await other.evaluate(() => window.emdm.notices().filter((n) => /not known/.test(n.text)))).toEqual([]);
  await other.close();
});

test('a link whose timeline cannot be used says why, keeps saying it, and generates nothing in its place', async ({ browser }) => {
  const cases: [string, RegExp][] = [
    ['[[', /could not be read: not JSON/],
    [`[${'['.repeat(1000)}${']'.repeat(1000)}]`, /segment 1 must be \[prompt, seconds, seed\], got a list of 1 entry/],
    [JSON.stringify(Array.from({ length: 201 }, (_, i) => ['walk', 0.1, i])), /201 segments; at most 200/],
    [JSON.stringify([['a person walks forward', 2, 1], ['a person waves', 1e308, 2]]), /segment 2 is 1\.00e\+308 s long; a timeline is at most 60 s/],
  ];
  for (const [tl, msg] of cases) {
    const other = await browser.newPage();
    await other.goto(`/?backend=wasm&steps=${STEPS}&tl=${encodeURIComponent(tl)}`);
    await other.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
    await expect.poll(() => other.evaluate(() => window.emdm.edit!.message()), { timeout: 30_000 }).toMatch(msg);
    await other.waitForTimeout(2000); // the message stays: nothing generated over it
    expect(await other.evaluate(() => window.emdm.edit!.message())).toMatch(msg);
    await expect(other.locator('#edit-panel .tl-body > .tl-message')).toBeVisible();
    expect(await other.evaluate(() => [window.emdm.counters.generations, window.emdm.counters.stepsRun])).toEqual([0, 0]);
    // the address keeps the link's timeline as it was: the visitor can see, copy and mend what they opened
    expect(await other.evaluate(() => new URLSearchParams(location.search).get('tl'))).toBe(tl);
    await other.close();
  }
});

test('a regenerated timeline\'s link reproduces it exactly (every window depends on its own request only)', async ({ browser }) => {
  // 2 steps: the step above t = 0.55 is the one a timeline's windows begin together (with 1 step none is); the int8
  // file's windows are begun one by one, or the link's all-at-once load would round them differently (up to 22 cm)
  const mine = await browser.newPage();
  await mine.goto('/?noauto=1&backend=wasm&steps=2&mode=text&text=a+person+walks');
  await mine.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  const segs = [
    { prompt: 'a person walks forward', seconds: 2, seed: 21 },
    { prompt: 'a person waves', seconds: 2, seed: 22 },
    { prompt: 'a person sits down', seconds: 2, seed: 23 },
  ];
  await mine.evaluate((x) => window.emdm.edit!.setSegments(x), segs);
  await mine.evaluate(() => window.emdm.edit!.generateAll());
  // every step of every window is a model call, the one begun together too (the count left it out)
  await expect(mine.locator('#t-calls')).toHaveText('6');
  await expect(mine.locator('#t-step')).toContainText('× 3 (and 3 begun together)');
  await mine.evaluate(() => window.emdm.edit!.regenerate(1));
  const made = (await mine.evaluate(() => window.emdm.edit!.current()))!;
  const other = await browser.newPage();
  await other.goto(mine.url().replace(/([?&])noauto=1&?/, '$1'));
  await other.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  await other.waitForFunction(() => window.emdm.edit?.current()?.frames === 120, null, { timeout: 120_000 });
  expect(await other.evaluate(() => window.emdm.edit!.segments())).toEqual(await mine.evaluate(() => window.emdm.edit!.segments()));
  expect((await other.evaluate(() => window.emdm.edit!.current()))!.features).toEqual(made.features);
  await Promise.all([mine.close(), other.close()]);
});

/** The joints JSON the page's download writes now. */
async function downloadJson(p: Page): Promise<{ frames: number; generator: Record<string, unknown> }> {
  const [dl] = await Promise.all([p.waitForEvent('download'), p.locator('#dl-json').click()]);
  return JSON.parse(fs.readFileSync((await dl.path())!, 'utf8'));
}

test('the link and the JSON say what is on screen: a timeline stays in the link, an edit is named, a new Generate replaces it', async ({ browser }) => {
  const mine = await browser.newPage();
  const watchMine = watchPage(mine);
  await mine.goto(`/?noauto=1&backend=wasm&steps=${STEPS}&mode=text&text=a+person+walks`);
  await mine.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  const segs = [
    { prompt: 'a person walks forward', seconds: 2, seed: 1 },
    { prompt: 'a person waves', seconds: 1.5, seed: 2 },
    { prompt: 'a person sits down', seconds: 1, seed: 3 },
  ];
  const tl = JSON.stringify(segs.map((s) => [s.prompt, s.seconds, s.seed]));
  // the page's own address (page.url() follows history.replaceState only when its event arrives: late on a loaded machine)
  const param = (name: string) => mine.evaluate((n) => new URLSearchParams(location.search).get(n), name);
  await mine.evaluate((x) => window.emdm.edit!.setSegments(x), segs);
  await mine.evaluate(() => window.emdm.edit!.generateAll());
  expect(await param('tl')).toBe(tl);

  // Length nudged, the prompt box typed in: the link still makes the timeline on screen
  await mine.locator('#seconds').fill('4');
  await mine.locator('#prompt').fill('a person jumps');
  expect(await Promise.all([param('seconds'), param('text'), param('tl')])).toEqual(['4', 'a person jumps', tl]);
  await expect(mine.locator('#link-note')).toBeHidden();
  // the JSON names every segment, and the first one (not the prompt box) stands for the timeline
  const json = await downloadJson(mine);
  expect(json.frames).toBe(90);
  expect(json.generator).toMatchObject({ kind: 'timeline', mode: 'text', text: 'a person walks forward', seed: 1, steps: STEPS });
  expect((json.generator.segments as { prompt: string; seconds: number; seed: number }[]).map((g) => [g.prompt, g.seconds, g.seed])).toEqual(JSON.parse(tl));

  // the same timeline again: nothing is regenerated, and "Last generation" says so (no "0 threads", no "× 0")
  expect((await mine.evaluate(() => window.emdm.edit!.generateAll())).windows).toBe(0);
  await expect(mine.locator('#t-step')).toHaveText('none: nothing was regenerated');
  await expect(mine.locator('#t-backend')).not.toContainText('0 threads');
  await expect(mine.locator('#t-encode')).toHaveText('–');

  // an in-between: a link cannot hold it; the link stays the timeline's and the note under Copy link says so
  await mine.evaluate(() => window.emdm.edit!.inBetween('a person spins around'));
  expect(await param('tl')).toBe(tl);
  await expect(mine.locator('#link-note')).toBeVisible();
  await expect(mine.locator('#link-note')).toContainText('The in-between on screen is not in this link');
  await expect(mine.locator('#copy-link')).toHaveAttribute('aria-describedby', 'link-note');
  await mine.locator('#prompt').fill('a person walks');
  expect(await Promise.all([param('text'), param('tl')])).toEqual(['a person walks', tl]);
  const edited = await downloadJson(mine);
  const seed = Number(/seed (\d+)/.exec((await mine.locator('#caption small').textContent())!)![1]);
  expect(edited.generator).toMatchObject({ kind: 'edit', text: 'a person spins around', seed, edit: { type: 'inbetween', keepFirstSeconds: 1, keepLastSeconds: 1 } });
  expect(edited.generator.base).toEqual(json.generator);

  // one motion generated: it replaces the timeline in the link, the note goes, the JSON is that generation's
  await mine.evaluate((s) => window.emdm.generate({ mode: 'text', text: 'a person walks', seconds: 1, steps: s, seed: 3 }), STEPS);
  expect(await param('tl')).toBeNull();
  expect(await param('seed')).toBe('3');
  await expect(mine.locator('#link-note')).toBeHidden();
  expect(await mine.locator('#copy-link').getAttribute('aria-describedby')).toBeNull();
  expect((await downloadJson(mine)).generator).toEqual({ kind: 'generate', model: 'emdm-t2m-web', mode: 'text', text: 'a person walks', steps: STEPS, guidance: expect.any(Number), seed: 3 });
  watchMine.assertClean();
  await mine.close();
});

test('regenerating segment 2 keeps segment 1 as it was', async () => {
  const before = (await page.evaluate(() => window.emdm.edit!.current()))!;
  const r = await page.evaluate(() => window.emdm.edit!.regenerate(1));
  expect(r.windows).toBe(4); // segments 2 and 3, two windows each; segment 1 reused
  const after = (await page.evaluate(() => window.emdm.edit!.current()))!;
  expect(after.frames).toBe(600);
  expect(after.features.slice(0, 200 * D)).toEqual(before.features.slice(0, 200 * D));
  expect(after.features.slice(200 * D, 400 * D)).not.toEqual(before.features.slice(200 * D, 400 * D));
});

test('edits refuse a motion longer than one model window; another step count regenerates every segment', async () => {
  await expect(page.evaluate(() => window.emdm.edit!.inBetween('a person jumps'))).rejects.toThrow(/at most 196 frames/);
  expect(await page.evaluate(() => window.emdm.edit!.message())).toMatch(/in-betweening works on a motion of at most 196 frames \(9\.8 s\).*this one is 600 frames/);
  // the same segments with another step count: nothing is reused
  await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks', seconds: 1, steps: 2, seed: 3 }));
  expect((await page.evaluate(() => window.emdm.edit!.generateAll())).windows).toBe(6);
  await page.evaluate((s) => window.emdm.generate({ mode: 'text', text: 'a person walks', seconds: 1, steps: s, seed: 3 }), STEPS);
});

test('in-between: the first and last second stay as they were, the middle is new', async () => {
  await page.evaluate((s) => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 5, steps: s, seed: 21 }), STEPS);
  const before = (await page.evaluate(() => window.emdm.edit!.current()))!;
  expect(before.frames).toBe(100);
  const r = await page.evaluate(() => window.emdm.edit!.inBetween('a person jumps'));
  expect(r.frames).toBe(100);
  const after = (await page.evaluate(() => window.emdm.edit!.current()))!;
  let kept = 0;
  let middle = 0;
  for (let f = 0; f < 100; f++) {
    for (let c = f === 19 ? 3 : 0; c < D; c++) {
      const d = Math.abs(after.features[f * D + c] - before.features[f * D + c]);
      if (f < 20 || f >= 80) kept = Math.max(kept, d);
      else middle = Math.max(middle, d);
    }
  }
  expect(kept, 'kept features (first and last second)').toBeLessThan(1e-4);
  // but the last kept frame's root velocity, its step into the new middle, is the step before it (easeSeams)
  for (let c = 0; c < 3; c++) expect(Math.abs(after.features[19 * D + c] - before.features[18 * D + c]), `frame 19's step, channel ${c}`).toBeLessThan(1e-4);
  expect(middle, 'the middle is regenerated').toBeGreaterThan(1e-2);
  // kept frames decode where they were, ≤ 1 mm (the later second is pinned in the world)
  for (const f of [0, 19, 80, 99]) {
    for (let j = 0; j < J; j++) {
      const p = at(after.joints, f, j);
      const q = at(before.joints, f, j);
      expect(Math.hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]), `frame ${f} joint ${j}`).toBeLessThan(1e-3);
    }
  }
  // any marked range: keep the first 0.5 s and the last 2 s
  await page.evaluate(() => window.emdm.edit!.inBetween('a person sits down', 0.5, 2));
  const again = (await page.evaluate(() => window.emdm.edit!.current()))!;
  const diff = (f: number, from = 0) => Math.max(...Array.from({ length: D - from }, (_, c) => Math.abs(again.features[f * D + from + c] - after.features[f * D + from + c])));
  for (const f of [0, 60, 99]) expect(diff(f), `kept frame ${f}`).toBeLessThan(1e-4);
  expect(diff(9, 3), 'kept frame 9 but its step into the middle').toBeLessThan(1e-4);
  expect(Math.max(diff(20), diff(40))).toBeGreaterThan(1e-2);
  // keeping all of it: said in seconds, nothing generated, the motion stays
  const steps0 = await page.evaluate(() => window.emdm.counters.stepsRun);
  await expect(page.evaluate(() => window.emdm.edit!.inBetween('a person jumps', 3, 2))).rejects.toThrow(
    /keeping the first 3 s and the last 2 s of this 5 s motion leaves no middle to regenerate; keep at least 0\.05 s at each end and at most 4\.95 s in all/);
  expect(await page.evaluate(() => window.emdm.counters.stepsRun)).toBe(steps0);
  expect((await page.evaluate(() => window.emdm.edit!.current()))!.features).toEqual(again.features);
});

test('the edit tools as a visitor uses them: an example prompt ready to run, messages inside the tool', async () => {
  const box = page.locator('fieldset.tl-tool', { has: page.locator('#tl-ib-prompt') });
  // the prompt box holds an example (a value, not only grey placeholder text): one click runs it
  expect(await page.locator('#tl-ib-prompt').inputValue()).not.toBe('');
  expect(await page.locator('#tl-body-prompt').inputValue()).not.toBe('');
  const before = (await page.evaluate(() => window.emdm.edit!.current()))!;
  await box.getByRole('button', { name: 'Regenerate the middle' }).click();
  await page.waitForFunction((f0) => {
    const c = window.emdm.edit!.current();
    return !!c && c.features.slice(40 * 263, 41 * 263).some((v, i) => Math.abs(v - f0[i]) > 1e-3);
  }, before.features.slice(40 * 263, 41 * 263), { timeout: 60_000 });
  await expect(box.locator('.tl-progress')).toBeHidden();
  // an empty prompt: the message is said next to the tool (not under the timeline, out of view on a phone)
  await page.locator('#tl-ib-prompt').fill('');
  await box.getByRole('button', { name: 'Regenerate the middle' }).click();
  await expect(box.locator('.tl-message')).toBeVisible();
  await expect(box.locator('.tl-message')).toHaveText(/prompt is empty/);
  expect(await page.locator('#edit-panel .tl-body > .tl-message').isHidden()).toBe(true);
  await page.locator('#tl-ib-prompt').fill('a person jumps up');
});

test('upper-body edit: legs and root unchanged on every frame, a new upper body', async () => {
  const before = (await page.evaluate(() => window.emdm.edit!.current()))!;
  await page.locator('#tl-body-keep').selectOption('lower');
  await page.locator('#tl-body-prompt').fill('a person waves both hands');
  const r = await page.evaluate(() => window.emdm.edit!.bodyEdit('lower', 'a person waves both hands'));
  expect(r.kind).toBe('body');
  const after = (await page.evaluate(() => window.emdm.edit!.current()))!;
  // lower body: root [0:4] and the pelvis/legs' positions, rotations and velocities (src/sampler/mask.ts groups)
  const legs = [1, 2, 4, 5, 7, 8, 10, 11];
  const lower = new Set<number>([0, 1, 2, 3, 193, 194, 195, 259, 260, 261, 262]);
  for (const j of legs) {
    for (let k = 0; k < 3; k++) lower.add(4 + 3 * (j - 1) + k);
    for (let k = 0; k < 6; k++) lower.add(67 + 6 * (j - 1) + k);
    for (let k = 0; k < 3; k++) lower.add(193 + 3 * j + k);
  }
  let keptDiff = 0;
  let upperDiff = 0;
  for (let f = 0; f < after.frames; f++) {
    for (let c = 0; c < D; c++) {
      const d = Math.abs(after.features[f * D + c] - before.features[f * D + c]);
      if (lower.has(c)) keptDiff = Math.max(keptDiff, d);
      else upperDiff = Math.max(upperDiff, d);
    }
  }
  expect(keptDiff).toBeLessThan(1e-4);
  expect(upperDiff).toBeGreaterThan(1e-2);
});

test('loop: the pose at the wrap is the first pose; in place the pelvis does not travel', async () => {
  const base = (await page.evaluate(() => window.emdm.edit!.current()))!;
  const r = await page.evaluate(() => window.emdm.edit!.loop(false));
  expect(r.frames).toBe(base.frames - 10);
  const full = (await page.evaluate(() => window.emdm.edit!.lastLoopFull()))!;
  expect(full.frames).toBe(base.frames);
  // frame N−K (where the clip wraps to) repeats frame 0's pose, ≤ 2 cm per joint
  expect(poseDistance(full.joints, base.frames - 10, full.joints, 0)).toBeLessThan(0.02);
  expect(await page.evaluate(() => window.emdm.playback().duration)).toBeCloseTo((base.frames - 10) / 20, 2); // the N − 10 frames of the clip, the last one 0.05 s before the first again

  await page.evaluate((s) => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 5, steps: s, seed: 31 }), STEPS);
  await page.locator('#tl-loop-in-place').check();
  await page.evaluate(() => window.emdm.edit!.loop(true));
  const clip = (await page.evaluate(() => window.emdm.edit!.current()))!;
  let travel = 0;
  for (let f = 0; f < clip.frames; f++) travel = Math.max(travel, Math.hypot(clip.joints[f * 66] - clip.joints[0], clip.joints[f * 66 + 2] - clip.joints[2]));
  expect(travel, 'in-place root travel, metres').toBeLessThan(0.05);
});

test('bad input: a clear message naming the segment, the other segments kept, nothing generated', async () => {
  const good = [{ prompt: 'a person walks forward', seconds: 3, seed: 1 }, { prompt: 'a person waves', seconds: 3, seed: 2 }];
  const shown = await page.evaluate(() => window.emdm.edit!.current()!.frames);
  const calls0 = await page.evaluate(() => window.emdm.counters.stepsRun);
  const cases: [object[], RegExp, number | null][] = [
    [[good[0], { prompt: 'a person sits down', seconds: 0, seed: 3 }, good[1]], /segment 2 is 0 s long; a segment needs at least one frame/, 1],
    [[good[0], good[1], { prompt: 'a person runs', seconds: 55, seed: 3 }], /the timeline is 61 s in all; at most 60 s/, null],
    [[good[0], good[1], { prompt: '  ', seconds: 2, seed: 3 }], /segment 3: the prompt is empty/, 2],
  ];
  for (const [segs, msg, invalid] of cases) {
    await page.evaluate((s) => window.emdm.edit!.setSegments(s as never), segs);
    await expect(page.evaluate(() => window.emdm.edit!.generateAll())).rejects.toThrow(msg);
    expect(await page.evaluate(() => window.emdm.edit!.message())).toMatch(msg);
    await expect(page.locator('#edit-panel .tl-body > .tl-message')).toBeVisible();
    expect(await page.evaluate(() => window.emdm.edit!.segments())).toEqual(segs);
    const rows = page.locator('.tl-seg');
    await expect(rows).toHaveCount(3);
    for (let i = 0; i < 3; i++) {
      if (i === invalid) await expect(rows.nth(i)).toHaveAttribute('aria-invalid', 'true');
      else await expect(rows.nth(i)).not.toHaveAttribute('aria-invalid', 'true');
    }
  }
  expect(await page.evaluate(() => window.emdm.counters.stepsRun)).toBe(calls0);
  expect(await page.evaluate(() => window.emdm.edit!.current()!.frames)).toBe(shown);
});

test('a timeline shows its progress per segment and gives way to a newer request (cancelled at a step)', async () => {
  await page.evaluate(() => window.emdm.edit!.setSegments([
    { prompt: 'a person walks forward', seconds: 9, seed: 61 }, { prompt: 'a person waves', seconds: 9, seed: 62 }, { prompt: 'a person walks backward', seconds: 9, seed: 63 },
  ]));
  // 10 steps (the timeline takes the page's step count): a whole timeline in the worker at 1 step can end before
  // the newer request below is even sent
  await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 1, steps: 10, seed: 70 }));
  const cancelled0 = await page.evaluate(() => window.emdm.counters.cancelled);
  const running = page.evaluate(() => window.emdm.edit!.generateAll().then(() => 'finished', (e: Error) => e.name));
  // while it runs: its windows' early steps run together, then each window's last steps (segments 1 and 2's can pass
  // between two polls of a loaded CPU's page, so the windows' joint phase is the one always seen)
  await expect(page.locator('#progress-text')).toContainText(/windows together: step|Segment [12] of 3: step/);
  // the main button says what a click does meanwhile: one motion of the side bar in place of the timeline
  await expect(page.locator('#generate')).toHaveText('Generate (stops the timeline)');
  const single = await page.evaluate((s) => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 2, steps: s, seed: 71 }), STEPS);
  expect(await running).toBe('AbortError');
  expect(single.frames).toBe(40);
  expect(await page.evaluate(() => window.emdm.counters.cancelled)).toBeGreaterThan(cancelled0);
  expect(await page.evaluate(() => window.emdm.edit!.current()!.frames)).toBe(40); // the newer motion is on screen
});

test('segments reorder and go with their buttons; the last one stays', async () => {
  const a = { prompt: 'a person walks forward', seconds: 2, seed: 1 };
  const b = { prompt: 'a person waves', seconds: 3, seed: 2 };
  await page.evaluate((s) => window.emdm.edit!.setSegments(s), [a, b]);
  await page.getByRole('button', { name: 'Segment 2: Move up' }).click();
  expect(await page.evaluate(() => window.emdm.edit!.segments())).toEqual([b, a]);
  await expect(page.getByLabel('Segment 1 prompt')).toHaveValue(b.prompt);
  await page.getByRole('button', { name: 'Segment 1: Remove' }).click();
  expect(await page.evaluate(() => window.emdm.edit!.segments())).toEqual([a]);
  await page.getByRole('button', { name: 'Segment 1: Remove' }).click();
  expect(await page.evaluate(() => window.emdm.edit!.segments())).toEqual([a]);
  expect(await page.evaluate(() => window.emdm.edit!.message())).toMatch(/at least one segment/);
});

test('keyboard: open the panel, add a segment, type it and generate with Enter', async () => {
  await page.evaluate(() => window.emdm.edit!.setSegments([{ prompt: 'a person walks forward', seconds: 1.5, seed: 5 }]));
  const summary = page.locator('#edit-panel summary');
  const details = page.locator('#edit-panel details');
  if ((await details.getAttribute('open')) !== null) {
    await summary.focus();
    await page.keyboard.press('Enter'); // closes
  }
  await summary.focus();
  await page.keyboard.press('Enter');
  await expect(details).toHaveAttribute('open', '');
  await page.getByRole('button', { name: 'Add segment' }).focus();
  await page.keyboard.press('Enter');
  await expect(page.locator('.tl-seg')).toHaveCount(2);
  await expect(page.getByLabel('Segment 2 prompt')).toBeFocused();
  await page.keyboard.type('a person waves');
  await page.getByLabel('Segment 2 seconds').fill('1');
  await page.getByLabel('Segment 2 prompt').focus();
  const before = await page.evaluate(() => window.emdm.counters.generations);
  await page.keyboard.press('Enter');
  await page.waitForFunction((n) => window.emdm.counters.generations > n, before, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.edit!.current()!.frames)).toBe(50);
  watch.assertClean();
});

test('a 60 s timeline keeps the page drawing: no frame waits for the whole decode and stitch', async () => {
  const segs = Array.from({ length: 6 }, (_, k) => ({ prompt: k % 2 ? 'a person waves' : 'a person walks forward', seconds: 10, seed: 60 + k }));
  await page.evaluate((s) => window.emdm.edit!.setSegments(s), segs);
  // requestAnimationFrame gaps on the page's thread while the timeline is made (12 windows) and shown
  const r = await page.evaluate(async () => {
    const frames: number[] = [];
    const tasks: { at: number; ms: number }[] = [];
    const lt = new PerformanceObserver((l) => l.getEntries().forEach((e) => tasks.push({ at: e.startTime, ms: e.duration })));
    lt.observe({ type: 'longtask', buffered: false });
    let on = true;
    const raf = (t: number) => {
      frames.push(t);
      if (on) requestAnimationFrame(raf);
    };
    requestAnimationFrame(raf);
    const t0 = performance.now();
    await new Promise((res) => setTimeout(res, 2000)); // idle: what this machine's load alone does to frames
    const idleFrames = frames.length;
    const t1 = performance.now();
    const summary = await window.emdm.edit!.generateAll();
    on = false;
    lt.disconnect();
    const gapsOf = (f: number[]) => f.slice(1).map((t, i) => t - f[i]).sort((a, b) => b - a);
    return {
      summary, idle: gapsOf(frames.slice(0, idleFrames)).slice(0, 3), idleFrames, frames: frames.length - idleFrames, gaps: gapsOf(frames.slice(idleFrames - 1)).slice(0, 5),
      tasks: tasks.filter((x) => x.at >= t1).sort((a, b) => b.ms - a.ms).slice(0, 5).map((x) => ({ at: x.at - t1, ms: x.ms })), idleTasks: tasks.filter((x) => x.at >= t0 && x.at < t1).length,
    };
  });
  expect(r.summary.frames).toBe(1200);
  expect(r.summary.windows).toBe(12);
  const p = r.summary.parts;
  const load = fs.existsSync('/proc/loadavg') ? fs.readFileSync('/proc/loadavg', 'utf8').split(' ')[0] : '?';
  const f = (v: number[]) => v.map((g) => g.toFixed(0)).join(', ');
  console.log(`[timeline 60 s] load average ${load}: idle 2 s first: ${r.idleFrames} frames, longest gaps ${f(r.idle)} ms, ${r.idleTasks} long tasks; `
    + `during the timeline: ${r.frames} frames in ${r.summary.ms.toFixed(0)} ms, longest gaps ${f(r.gaps)} ms; longest tasks on this thread `
    + `${r.tasks.map((x) => `${x.ms.toFixed(0)} ms at ${(x.at / 1000).toFixed(1)} s`).join(', ')}; `
    + `this thread's edit work ${p.mainMs.toFixed(0)} ms in all, show ${p.showMs.toFixed(0)} ms, IK (worker) ${p.ikMs.toFixed(0)} ms`);
  // the page draws all along: no gap spans half the request (the inference on this thread used to hold every frame)
  expect(r.frames).toBeGreaterThan(3);
  expect(r.gaps[0]).toBeLessThan(r.summary.ms / 2);
  watch.assertClean();
});

test('loop of a 60 s timeline: its last window ends on the first pose, the frames before it stay', async () => {
  const base = (await page.evaluate(() => window.emdm.edit!.current()))!; // the 60 s timeline of the test before
  expect(base.frames).toBe(1200);
  const r = await page.evaluate(() => window.emdm.edit!.loop(false));
  expect(r.frames).toBe(1190);
  expect(r.windows).toBe(1); // one model window (196 frames) sampled, with the last segment's prompt
  const full = (await page.evaluate(() => window.emdm.edit!.lastLoopFull()))!;
  expect(full.frames).toBe(1200);
  expect(poseDistance(full.joints, 1190, full.joints, 0)).toBeLessThan(0.02); // frame N−K repeats frame 0's pose
  const cur = (await page.evaluate(() => window.emdm.edit!.current()))!;
  expect(cur.features.slice(0, (1200 - 196) * D)).toEqual(base.features.slice(0, (1200 - 196) * D)); // before the window
  expect(cur.features.slice(1100 * D, 1180 * D)).not.toEqual(base.features.slice(1100 * D, 1180 * D));
  // said beside the loop button: only the end was regenerated, with the last segment's prompt (news, not an error)
  expect(await page.evaluate(() => window.emdm.edit!.message())).toMatch(/^Only the last 9\.8 s were regenerated \(with “a person waves”, the last segment's\) to lead back to the first pose; the 50\.2 s before them are as they were\.$/);
  await expect(page.locator('#edit-panel .tl-message.tl-note[role="status"]:visible')).toBeVisible();
});

test('timing: a 3 × 5 s timeline against one 5 s motion (printed)', async () => {
  const med = (v: number[]) => [...v].sort((a, b) => a - b)[v.length >> 1];
  for (const [steps, runs] of [[STEPS, 1], [10, 3]] as const) {
    const ones: { ms: number; encode: number; steps: number; decode: number; ik: number; worker: number }[] = [];
    const tls: { ms: number; parts: { encodeMs: number; stepMs: number; decodeMs: number; beginMs: number; workerEditMs: number; roundTripMs: number; mainMs: number; ikMs: number; showMs: number; windowStepMs: number[] } }[] = [];
    for (let k = 0; k < runs; k++) { // interleaved: both see the same load
      // the single motion sets the page's step count, which the timeline then uses too
      ones.push(await page.evaluate(async ([s, seed]) => {
        const t0 = performance.now();
        const r = await window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 5, steps: s, seed });
        const t = r.timings;
        return { ms: performance.now() - t0, encode: t.encodeMs, steps: t.stepMs.reduce((a, b) => a + b, 0), decode: t.decodeMs, ik: t.ikMs, worker: t.totalMs };
      }, [steps, 41 + k] as const));
      await page.evaluate((n) => window.emdm.edit!.setSegments([
        { prompt: 'a person walks forward', seconds: 5, seed: n + 1 }, { prompt: 'a person waves', seconds: 5, seed: n + 2 }, { prompt: 'a person walks backward', seconds: 5, seed: n + 3 },
      ]), steps * 10 + 3 * k);
      const tl = await page.evaluate(() => window.emdm.edit!.generateAll());
      expect(tl.frames).toBe(300);
      expect(tl.windows).toBe(3);
      tls.push(tl);
    }
    const threads = await page.evaluate(() => window.emdm.environment?.threads ?? 0);
    const load = fs.existsSync('/proc/loadavg') ? fs.readFileSync('/proc/loadavg', 'utf8').split(' ')[0] : '?';
    const ms = (v: number) => v.toFixed(0);
    const o = (f: (x: (typeof ones)[0]) => number) => ms(med(ones.map(f)));
    const t = (f: (x: (typeof tls)[0]['parts']) => number) => ms(med(tls.map((x) => f(x.parts))));
    const one = med(ones.map((x) => x.ms));
    const all = med(tls.map((x) => x.ms));
    console.log(`[timeline timing] ${steps} step(s), WASM ${threads} thread(s), medians of ${runs} interleaved run(s), load average ${load}: `
      + `one 5 s motion ${ms(one)} ms (encode ${o((x) => x.encode)}, steps ${o((x) => x.steps)}, decode ${o((x) => x.decode)}, IK ${o((x) => x.ik)}, `
      + `the rest ${o((x) => x.ms - x.worker - x.ik)}); 3 × 5 s timeline ${ms(all)} ms, one request to the worker (windows of 100/120/120 frames: `
      + `early steps begun together ${t((p) => p.beginMs)}, then encode ${t((p) => p.encodeMs)}, steps ${t((p) => p.stepMs)}, decode ${t((p) => p.decodeMs)}, `
      + `the worker's seam easing, stitching and decoding ${t((p) => p.workerEditMs)}, round trips ${t((p) => p.roundTripMs)}, this thread's edit work `
      + `${t((p) => p.mainMs)}, IK ${t((p) => p.ikMs)}, show ${t((p) => p.showMs)}; later steps per window `
      + `${[0, 1, 2].map((w) => ms(med(tls.map((x) => x.parts.windowStepMs[w])))).join(' / ')}); ratio ${(all / one).toFixed(2)}, steps alone (begun + later) `
      + `${(med(tls.map((x) => x.parts.beginMs + x.parts.stepMs)) / med(ones.map((x) => x.steps))).toFixed(2)} (this machine, under the load of the moment)`);
  }
});
