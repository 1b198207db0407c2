// Live mode (issue 33) through the page as a visitor uses it: the Live toggle by keyboard, the character moving on
// its own, prompts sent with Enter (and an example chip) listed in the strip with their latency, the unknown-prompt
// notice for a live prompt, every displayed frame from the stream, Record → the BVH download, and the toggle off
// closing the stream. No timing thresholds: latencies must exist and be finite (their size is the benchmark's,
// tests/e2e/page-bench-live.spec.ts).
import fs from 'node:fs';
import { expect, test, type Page } from '@playwright/test';
import { RIGS, buildRigGlb } from '../unit/retargetRigs';
import { watchPage } from './helpers';

const live = (page: Page) => page.evaluate(() => {
  const l = window.emdm.live!;
  return { on: l.on, active: l.active, displayed: l.displayed, repeated: l.repeated, last: l.last(), prompts: l.prompts(), stats: l.stats(), started: l.started, closed: l.closed };
});

/** Type a prompt into the focused prompt box and press Enter; wait until its first new frame has played. */
async function sendByEnter(page: Page, text: string): Promise<void> {
  const n = (await live(page)).prompts.length;
  await page.keyboard.press('ControlOrMeta+a');
  await page.keyboard.type(text);
  await page.keyboard.press('Enter');
  await page.waitForFunction(([k, t]) => {
    const p = window.emdm.live!.prompts();
    return p.length === k + 1 && p[k].text === t && p[k].latency !== null;
  }, [n, text] as const, { timeout: 60_000 });
}

test('live mode: keyboard toggle, a character that keeps moving, prompts by Enter and chip, record → BVH, toggle off', async ({ page }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await page.goto('/?noauto=1&backend=wasm&steps=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  await page.locator('#prompt').fill('a person walks');
  // a motion on screen before live mode: its downloads are on
  await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks', seconds: 1, steps: 2 }));
  await expect(page.locator('#dl-bvh')).toBeEnabled();
  const streamSeed = Number(await page.locator('#seed').inputValue());

  // on by keyboard: the toggle says it is pressed, the prompt box has the focus, the playback bar gives way
  const toggle = page.locator('#live');
  await expect(toggle).toHaveAttribute('aria-pressed', 'false');
  await toggle.focus();
  await page.keyboard.press('Enter');
  await expect(toggle).toHaveAttribute('aria-pressed', 'true');
  await page.waitForFunction(() => window.emdm.live!.active, null, { timeout: 60_000 });
  await expect(page.locator('#prompt')).toBeFocused();
  await expect(page.locator('#playback')).toBeHidden();
  await expect(page.locator('#generate')).toBeDisabled();
  // nothing recorded yet: the downloads would write the motion from before live mode, so they are off, saying why
  for (const id of ['#dl-bvh', '#dl-glb', '#dl-json']) {
    await expect(page.locator(id)).toBeDisabled();
    await expect(page.locator(id)).toHaveAttribute('aria-describedby', 'dl-note');
  }
  await expect(page.locator('#dl-note')).toBeVisible();
  await expect(page.locator('#dl-note')).toContainText('Record last 60 s');

  // the character moves on its own: two looks at the live clock, two poses
  await page.waitForFunction(() => window.emdm.live!.last() !== null);
  const a = (await live(page)).last!;
  await page.waitForFunction((t) => window.emdm.live!.last()!.time > t + 0.5, a.time);
  const b = (await live(page)).last!;
  expect(Math.hypot(b.root[0] - a.root[0], b.root[1] - a.root[1], b.root[2] - a.root[2]), 'the pelvis moved').toBeGreaterThan(0);
  // the stream frame under the pose shown (the soak follows its pelvis height): 22 joints, its pelvis where the drawn
  // root is, up to the one frame's step the pose was interpolated over
  const shown = await page.evaluate(() => ({ f: window.emdm.live!.shownFrame(), r: window.emdm.live!.last() }));
  expect(shown.f!.joints).toHaveLength(66);
  const [px, py, pz] = shown.f!.joints;
  expect(Math.hypot(px - shown.r!.root[0], py - shown.r!.root[1], pz - shown.r!.root[2]), 'pelvis of the shown frame vs drawn root (m)').toBeLessThan(0.3);

  // three prompts by Enter (one the model does not know: the page says so, as for a generated one)
  await sendByEnter(page, 'a person raises both hands');
  await sendByEnter(page, 'a person kicks');
  const notice = page.locator('#prompt-check');
  await expect(notice).toBeVisible();
  await expect(notice).toContainText('“a person kicks” reads as kick, which this model does not do well yet');
  await sendByEnter(page, 'a person squats down');
  // the caption names the live prompt now playing, not the last generation; the generation timings give way
  await expect(page.locator('#caption')).toContainText('“a person squats down”');
  await expect(page.locator('#caption')).toContainText('live');
  await expect(page.locator('#timings')).toBeHidden();
  // an example chip sends its prompt to the stream too
  const chip = page.locator('#examples button.chip').first();
  const chipText = (await chip.textContent())!.trim();
  const before = (await live(page)).prompts.length;
  await chip.click();
  await page.waitForFunction(([k, t]) => window.emdm.live!.prompts()[k]?.text === t, [before, chipText] as const);

  const s = await live(page);
  const sent = s.prompts.slice(1, 4);
  expect(sent.map((p) => p.text)).toEqual(['a person raises both hands', 'a person kicks', 'a person squats down']);
  for (const p of sent) expect(Number.isFinite(p.latency), `latency of “${p.text}”`).toBe(true);
  expect(s.stats!.latencies.length).toBeGreaterThanOrEqual(3);
  for (const l of s.stats!.latencies) expect(Number.isFinite(l)).toBe(true);
  // the strip: an ordered list, newest last
  const items = page.locator('#live-prompts > li');
  await expect(items.last()).toContainText(chipText);
  const strip = await items.allTextContents();
  expect(strip.length).toBe(s.prompts.length);
  expect(strip.findIndex((t) => t.includes('raises both hands'))).toBeLessThan(strip.findIndex((t) => t.includes('squats down')));
  expect(strip[1]).toMatch(/^0:\d\d\.\d “a person raises both hands” · in \d+\.\d\d s$/);

  // every displayed frame came from the stream: counted, none showing the pose of the one before
  expect(s.displayed).toBeGreaterThan(30);
  expect(s.repeated).toBeLessThanOrEqual(Math.floor(s.displayed * 0.05));
  expect(typeof s.stats!.underruns).toBe('number');
  expect(s.stats!.windows).toBeGreaterThan(3);

  // another seed in the controls does not change the stream's (the recording's JSON names the stream's)
  await page.evaluate(() => {
    const seed = document.getElementById('seed') as HTMLInputElement;
    seed.value = '123';
    seed.dispatchEvent(new Event('input'));
  });
  // Record: the last seconds become the page's motion, the BVH download writes them
  await page.locator('#live-record').click();
  await expect(page.locator('#live-hint')).toContainText('Recorded the last');
  await expect(page.locator('#dl-bvh')).toBeEnabled();
  await expect(page.locator('#dl-note')).toBeHidden();
  expect(await page.locator('#dl-json').getAttribute('aria-describedby')).toBeNull();
  // the JSON says what was recorded: the prompts (times in the recording), the stream's seed
  const [jsonDl] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-json').click()]);
  const doc = JSON.parse(fs.readFileSync((await jsonDl.path())!, 'utf8'));
  const recorded = doc.frames / doc.fps;
  expect(doc.generator).toMatchObject({ kind: 'live', mode: 'text', text: chipText, seed: streamSeed, steps: 2 });
  const texts = (doc.generator.prompts as { text: string; at: number }[]).map((p) => p.text);
  expect(texts.at(-1)).toBe(chipText);
  expect(texts).toContain('a person squats down');
  for (const p of doc.generator.prompts.slice(1) as { at: number }[]) expect(p.at).toBeGreaterThan(0);
  for (const p of doc.generator.prompts as { at: number }[]) expect(p.at).toBeLessThanOrEqual(recorded + 0.1);
  const [dl] = await Promise.all([page.waitForEvent('download'), page.locator('#dl-bvh').click()]);
  const bvh = fs.readFileSync((await dl.path())!, 'utf8');
  expect(bvh.split('\n')[0].trim()).toBe('HIERARCHY');
  const frames = Number(/Frames:\s*(\d+)/.exec(bvh)![1]);
  expect(frames).toBeGreaterThan(20);

  // fewer steps while live: a new stream with them takes over (the old one closed once it is ready)
  await page.locator('#steps').focus();
  await page.keyboard.press('ArrowLeft');
  await page.waitForFunction(() => window.emdm.live!.started === 2 && window.emdm.live!.active, null, { timeout: 60_000 });
  expect((await live(page)).closed).toBe(1);
  await expect(page.locator('#live-hint')).toContainText('Live: type a prompt');

  // off: the stream closes, the page plays the recording with its playback bar
  await toggle.click();
  await expect(toggle).toHaveAttribute('aria-pressed', 'false');
  const off = await live(page);
  expect(off.active).toBe(false);
  expect(off.closed).toBe(off.started);
  await expect(page.locator('#playback')).toBeVisible();
  await expect(page.locator('#live-panel')).toBeHidden();
  await expect(page.locator('#generate')).toBeEnabled();
  await expect(page.locator('#caption')).not.toContainText('live ·');
  const pb = await page.evaluate(() => window.emdm.playback());
  expect(Math.abs(pb.duration - frames / 20)).toBeLessThan(1e-6);
  watch.assertClean();
});

test('live mode on a phone (390×844): the toggle, the strip and Record fit the width, nothing scrolls sideways', async ({ page }) => {
  test.setTimeout(120_000);
  const watch = watchPage(page);
  await page.setViewportSize({ width: 390, height: 844 });
  await page.goto('/?noauto=1&backend=wasm&steps=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  await expect(page.locator('#live')).toBeVisible();
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live!.active, null, { timeout: 60_000 });
  await page.locator('#prompt').fill('a person walks and then turns to the left, slowly, looking around the room as it goes');
  await page.locator('#prompt').press('Enter');
  await expect(page.locator('#live-prompts > li')).toHaveCount(2);
  for (const id of ['#live', '#generate', '#prompt', '#live-panel', '#live-prompts', '#live-record']) {
    const box = (await page.locator(id).boundingBox())!;
    expect(box, `${id} is laid out`).not.toBeNull();
    expect(box.x, `${id} left edge`).toBeGreaterThanOrEqual(0);
    expect(box.x + box.width, `${id} right edge`).toBeLessThanOrEqual(390 + 0.5);
  }
  expect(await page.evaluate(() => document.documentElement.scrollWidth), 'no sideways scrolling').toBeLessThanOrEqual(390);
  watch.assertClean();
});

type CharacterProbe = { active: boolean; builtInVisible: boolean; retargets: { finished: number }; jointWorld(j: string): [number, number, number] | null };
const probe = (page: Page) => page.evaluate(() => {
  const c = (window as unknown as { emdmCharacter: CharacterProbe }).emdmCharacter;
  return { active: c.active, builtIn: c.builtInVisible, finished: c.retargets.finished, pelvis: c.jointWorld('pelvis'), t: window.emdm.live!.last()?.time ?? 0 };
});

test('live mode on the visitor\'s character: it keeps performing the stream, piece after piece', async ({ page }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await page.goto('/?noauto=1&backend=wasm&steps=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  await page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', seconds: 2, steps: 1, seed: 3 }));
  const manifest = JSON.parse(fs.readFileSync('public/models/manifest.json', 'utf8'));
  const rig = buildRigGlb(manifest.skeleton, RIGS[0]);
  const b64 = Buffer.from(rig).toString('base64');
  const dt = await page.evaluateHandle((data) => {
    const d = new DataTransfer();
    d.items.add(new File([Uint8Array.from(atob(data), (c) => c.charCodeAt(0))], 'hero.glb'));
    return d;
  }, b64);
  await page.dispatchEvent('#viewport', 'drop', { dataTransfer: dt });
  await page.waitForFunction(() => (window as unknown as { emdmCharacter: CharacterProbe }).emdmCharacter.active, null, { timeout: 30_000 });

  await page.locator('#prompt').fill('a person walks');
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live!.active, null, { timeout: 60_000 });
  const start = await probe(page);
  // well past the first piece (what was made when live mode began: at most a few seconds)
  await page.waitForFunction((t) => (window.emdm.live!.last()?.time ?? 0) > t + 6, start.t, { timeout: 60_000 });
  const a = await probe(page);
  await page.waitForFunction((t) => window.emdm.live!.last()!.time > t + 0.5, a.t);
  const b = await probe(page);
  expect(b.builtIn, 'the built-in character stays hidden').toBe(false);
  expect(b.finished - start.finished, 'pieces of the stream retargeted').toBeGreaterThanOrEqual(2);
  expect(a.pelvis && b.pelvis && a.pelvis.concat(b.pelvis).every(Number.isFinite)).toBe(true);
  expect(Math.hypot(a.pelvis![0] - b.pelvis![0], a.pelvis![1] - b.pelvis![1], a.pelvis![2] - b.pelvis![2]), 'the pelvis still moves').toBeGreaterThan(0.01);

  // another mode leaves live mode, saying why
  await page.locator('#mode-action').click();
  await expect(page.locator('#live')).toHaveAttribute('aria-pressed', 'false');
  expect(await page.evaluate(() => [window.emdm.live!.active, window.emdm.live!.closed])).toEqual([false, 1]);
  expect((await page.evaluate(() => window.emdm.notices())).map((n) => n.text)).toContain('Live mode takes text prompts: it was turned off when you chose another mode.');
  watch.assertClean();
});
