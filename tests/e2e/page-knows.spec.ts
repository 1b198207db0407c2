// What the model knows (issue 30), through the real prompt box: a prompt far from everything the text model does well,
// or nearest an action it does not do well (named),
// says so under the box and offers three prompts that work (each one, clicked, generates without the notice), and still
// generates; a covered prompt shows no notice; the list of actions the model does well and does not is one click from
// the prompt; the Action tab marks the labels its model does not make yet.
import fs from 'node:fs';
import path from 'node:path';
import { expect, test, type Page } from '@playwright/test';
import { watchPage } from './helpers';

async function open(page: Page): Promise<void> {
  await page.goto('/?noauto=1&backend=wasm&steps=4&seconds=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

/** Click Generate (or run `start`) and wait until the page counted one more finished generation. */
async function generated(page: Page, start: () => Promise<void>): Promise<void> {
  const n = await page.evaluate(() => window.emdm.counters.generations);
  await start();
  await page.waitForFunction((k) => window.emdm.counters.generations === k + 1, n, { timeout: 120_000 });
}

test('gibberish is far from everything, not an action named; French is not English; Enter on a suggestion keeps the focus; on a phone the notice is in view', async ({ page }) => {
  test.setTimeout(300_000);
  const watch = watchPage(page);
  await open(page);
  const notice = page.locator('#prompt-check');
  // it lands nearest "respond" (cosine 0.33): a visitor read "reads as respond" for their typo
  await page.locator('#prompt').fill('asdf qwerty');
  await generated(page, () => page.locator('#generate').click());
  await expect(notice).toContainText('The model has not learned anything close to “asdf qwerty”');
  // the chip goes with the notice when its prompt is generated: the keyboard focus was left on the page's body
  await notice.locator('button.chip').first().focus();
  await generated(page, () => page.keyboard.press('Enter'));
  await expect(notice).toBeHidden();
  await expect(page.locator('#generate')).toBeFocused();
  // another language (it landed nearest "dance"): the model reads English only, and the notice says so first
  await page.locator('#prompt').fill('une personne marche en avant');
  await generated(page, () => page.locator('#generate').click());
  await expect(notice).toContainText('“une personne marche en avant” does not read as English, and the model understands English prompts only');
  // a phone: the side panel scrolls on its own; the notice, added above the chips, went out of its view
  await page.setViewportSize({ width: 390, height: 844 });
  for (const p of ['a person waves with both hands', 'a person swims', 'a person plays the guitar']) {
    await page.locator('#prompt').fill(p);
    await generated(page, () => page.locator('#generate').click());
  }
  await expect(notice).toBeVisible();
  const [box, panel] = await Promise.all([notice.boundingBox(), page.locator('#panel').boundingBox()]);
  expect(box!.y, 'notice top below the panel top').toBeGreaterThanOrEqual(panel!.y - 1);
  expect(box!.y + box!.height, 'notice bottom above the panel bottom').toBeLessThanOrEqual(panel!.y + panel!.height + 1);
  watch.assertClean();
});

test('a far prompt gets the notice and three working prompts, and still generates; a covered one none', async ({ page }) => {
  test.setTimeout(300_000);
  const watch = watchPage(page);
  await open(page);
  const notice = page.locator('#prompt-check');

  // an action the model does not do, worded near one it does (a wave is close to raising the hand, which it does):
  // the notice names the action it reads as
  await page.locator('#prompt').fill('a person waves the right hand');
  await generated(page, () => page.locator('#generate').click());
  await expect(page.locator('#play')).toBeEnabled();                     // it generated all the same
  await expect(notice).toBeVisible();
  await expect(notice).toContainText(
    '“a person waves the right hand” reads as wave right hand, which this model does not do well yet');
  const chips = notice.locator('button.chip');
  await expect(chips).toHaveCount(3);
  const suggestions = await chips.allTextContents();
  expect(new Set(suggestions).size).toBe(3);
  expect(suggestions[0]).toBe('a person raises the right hand'); // the wave's close covered relative leads (RELATED)

  // editing the prompt hides the notice of the old one
  await page.locator('#prompt').fill('a person waves the right hand twice');
  await expect(notice).toBeHidden();

  // each suggestion works: clicked, it becomes the prompt, generates, and draws no notice
  await page.locator('#prompt').fill('a person does a cartwheel');
  await generated(page, () => page.locator('#generate').click());
  await expect(notice).toBeVisible();
  const first = (await chips.first().textContent())!;
  await generated(page, () => chips.first().click());
  await expect(page.locator('#prompt')).toHaveValue(first);
  await expect(notice).toBeHidden();

  await page.locator('#prompt').fill('a person walks forward');
  await generated(page, () => page.locator('#generate').click());
  await expect(notice).toBeHidden();
  watch.assertClean();
});

test('the list of what the model knows opens from the prompt; weak action labels are marked', async ({ page }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await open(page);
  const button = page.locator('#knows-open');
  await expect(button).toBeVisible();
  await expect(button).toHaveAttribute('aria-expanded', 'false');
  await button.click();
  const list = page.locator('#knows');
  await expect(list).toBeVisible();
  await expect(button).toHaveAttribute('aria-expanded', 'true');
  // as many as the shipped file says the model does well (it is rebuilt whenever a model or the sampler changes)
  const covered = JSON.parse(fs.readFileSync(path.join(process.cwd(), 'public/models/capabilities-emdm-t2m-web.json'), 'utf8'))
    .actions.filter((a: { covered: boolean }) => a.covered).length;
  expect(covered).toBeGreaterThan(5);
  await expect(page.locator('#knows-good li')).toHaveCount(covered);
  await expect(page.locator('#knows-good')).toContainText('walk backward');
  await expect(page.locator('#knows-weak')).toContainText('kick');
  await expect(page.locator('#knows-weak')).toContainText('dance');
  // punch: the classifier names its motions punches, but they hold a boxer's guard (the realism benchmark's moving)
  const punch = page.locator('#knows-weak li', { hasText: 'punch' });
  await expect(punch).toContainText('holds a pose');
  await expect(page.locator('#knows-good li', { hasText: 'holds a pose' })).toHaveCount(0);
  await expect(page.locator('#knows-source')).toContainText('of its motions moving as real clips of the action do');
  // who judged the rates: the file's judge (emdm.eval.judge), three classifiers by their mean probability
  await expect(page.locator('#knows-source')).toContainText("the project's action classifiers recognised (3, by their mean probability; coverage benchmark, emdm-t2m-web)");
  // a covered action's prompt is a chip that generates it
  await generated(page, () => page.locator('#knows-good button.chip').first().click());

  await page.locator('#mode-action').click();
  await expect(page.locator('#action option[value="kick"]')).toHaveText('kick (weak)');
  await expect(page.locator('#action option[value="walk"]')).toHaveText('walk');
  await expect(page.locator('#action-hint')).toContainText('(weak)');
  watch.assertClean();
});

test('a running generation can be cancelled; the link can be copied; sliders say steps and seconds', async ({ page, context }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await open(page);
  await expect(page.locator('#steps')).toHaveAttribute('aria-valuetext', '4 steps');
  await expect(page.locator('#seconds')).toHaveAttribute('aria-valuetext', '2.0 s');

  // Cancel stops the request mid-denoising: nothing more is generated, the page is idle again with no error
  await page.locator('#prompt').fill('a person walks');
  await page.locator('#steps').fill(await page.locator('#steps').getAttribute('max') ?? '0');   // the most steps
  // and the longest motion: each step then takes long enough that a loaded CPU's main thread sees step 1 while the
  // worker is still denoising (with 2 s at 10 steps the whole run could finish before the cancel arrived)
  await page.locator('#seconds').fill(await page.locator('#seconds').getAttribute('max') ?? '0');
  const g0 = await page.evaluate(() => window.emdm.counters.generations);
  const cancelledAt = await page.evaluate(() => new Promise<string>((resolve) => {
    const text = document.getElementById('progress-text')!;
    new MutationObserver((_, obs) => {
      if (!/Denoising step 1 \//.test(text.textContent ?? '')) return;
      obs.disconnect();
      document.getElementById('cancel')!.click();      // pressed while the request runs
      resolve(text.textContent ?? '');
    }).observe(text, { childList: true, characterData: true, subtree: true });
    document.getElementById('generate')!.click();
  }));
  expect(cancelledAt).toMatch(/Denoising step 1 \/ \d+/);
  await page.waitForFunction(() => window.emdm.counters.cancelled >= 1, null, { timeout: 60_000 });
  await expect(page.locator('#cancel')).toBeHidden();
  await expect(page.locator('#generate')).toHaveText('Generate');
  expect(await page.evaluate(() => window.emdm.counters.generations)).toBe(g0);
  await expect(page.locator('#error-panel')).toBeHidden();

  await context.grantPermissions(['clipboard-read', 'clipboard-write']);
  await page.locator('#copy-link').click();
  await expect(page.locator('#copy-link')).toHaveText('Link copied');
  expect(await page.evaluate(() => navigator.clipboard.readText())).toBe(page.url());
  watch.assertClean();
});
