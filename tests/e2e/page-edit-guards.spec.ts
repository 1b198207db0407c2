// What the audit of the timeline, live and compare views found (a visitor's path through them):
// - with the compare view at DDIM's 20/50/100 steps, a timeline failed ("100 steps not supported"): it runs EMDM's
//   count for the slider, as the compare view's EMDM side does;
// - in live mode "Generate timeline" ran under the stream, unseen: it says to stop live mode first;
// - Enter on "Record last 60 s" left the keyboard focus on the page's body (the button is disabled while it works).
import { expect, test, type Page } from '@playwright/test';
import { skipWithoutDiffusion, watchPage } from './helpers';

async function open(page: Page): Promise<void> {
  await page.goto('/?noauto=1&backend=wasm&mode=text&text=a+person+walks+forward&seconds=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  await page.locator('#edit-panel summary').click();
}

test('a timeline with the compare view at 100 steps runs EMDM at its maximum', async ({ page }) => {
  test.setTimeout(180_000);
  await skipWithoutDiffusion(page);
  const watch = watchPage(page);
  await open(page);
  await page.locator('#compare').check();
  const info = await page.evaluate(() => window.emdm.compareInfo());
  await page.locator('#steps').fill(String(info.steps.length - 1));
  await expect(page.locator('#steps-out')).toHaveText('100');
  const before = await page.evaluate(() => window.emdm.counters.generations);
  await page.locator('.tl-generate').click();
  await page.waitForFunction((n) => window.emdm.counters.generations > n, before, { timeout: 120_000 });
  // the timeline is EMDM's alone, and the panel says so (news, not an error)
  expect(await page.evaluate(() => window.emdm.edit?.message() ?? '')).toBe('Compare is for one generation: this result is EMDM\'s alone (no diffusion run beside it).');
  await expect(page.locator('#edit-panel .tl-message.tl-note[role="status"]:visible')).toBeVisible();
  watch.assertClean();
});

test('live mode leaves the compare view on screen and says so', async ({ page }) => {
  test.setTimeout(240_000);
  await skipWithoutDiffusion(page);
  const watch = watchPage(page);
  await open(page);
  await page.locator('#compare').check();
  await page.locator('#generate').click();
  await page.waitForFunction(() => window.emdm.compareInfo().ddimCharacterVisible, null, { timeout: 120_000 });
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live?.active, null, { timeout: 60_000 });
  // the DDIM character had no stream to play: it stood in a split view beside the stream with its last motion
  expect(await page.evaluate(() => { const c = window.emdm.compareInfo(); return [c.ddimCharacterVisible, c.split, c.panelsVisible]; })).toEqual([false, false, false]);
  await expect(page.locator('#live-hint')).toContainText('Compare is off while live: the stream is EMDM\'s alone.');
  await page.locator('#live').click();
  watch.assertClean();
});

test('live mode: the timeline asks to stop it first; Enter on Record keeps the focus there', async ({ page }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await open(page);
  await page.locator('#live').click();
  await page.waitForFunction(() => window.emdm.live?.active, null, { timeout: 60_000 });
  await page.locator('.tl-generate').click();
  await expect.poll(() => page.evaluate(() => window.emdm.edit?.message() ?? '')).toContain('Live mode is on: stop it with the Live button first');
  await page.waitForTimeout(2500); // something to record
  await page.locator('#live-record').focus();
  await page.keyboard.press('Enter');
  await expect(page.locator('#live-record')).toBeEnabled({ timeout: 30_000 });
  await expect(page.locator('#live-record')).toBeFocused();
  await page.locator('#live').click();
  watch.assertClean();
});
