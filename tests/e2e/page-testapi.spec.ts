// The page's test API (window.emdm, web/ui/testapi.ts) and its URL handling, as a script or a visitor
// meets them: a bad request is refused whole with a message and changes no control, caption or URL; a
// clamped value is clamped everywhere it shows; unknown URL parameters get a notice; with no motion
// loaded the playback bar shows no clock. Model faults: tests/e2e/page-faults.spec.ts.
import { expect, test, type Page } from '@playwright/test';
import { watchPage } from './helpers';

const PROMPT = 'a person walks forward';

async function openReady(page: Page, query = 'noauto=1&backend=wasm'): Promise<void> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

/** Everything a request could change on the page. */
async function snapshot(page: Page): Promise<Record<string, string>> {
  return page.evaluate(() => {
    const v = (id: string) => (document.getElementById(id) as HTMLInputElement).value;
    const t = (id: string) => document.getElementById(id)?.textContent ?? '';
    const tab = document.querySelector('.modes [aria-selected="true"]') as HTMLElement | null;
    return {
      url: location.search, seed: v('seed'), guidance: v('guidance'), seconds: v('seconds'), steps: v('steps'), prompt: v('prompt'),
      action: v('action'), compare: String((document.getElementById('compare') as HTMLInputElement).checked),
      mode: tab?.dataset.mode ?? '', caption: t('caption'), secondsOut: t('seconds-out'), guidanceOut: t('guidance-out'),
    };
  });
}

test.describe('test API and URL', () => {
  test.describe.configure({ mode: 'serial' });
  let page: Page;
  let watch: ReturnType<typeof watchPage>;
  test.beforeAll(async ({ browser }) => {
    test.setTimeout(300_000);
    page = await browser.newPage();
    watch = watchPage(page);
    await openReady(page, `noauto=1&backend=wasm&mode=text&text=${encodeURIComponent(PROMPT)}&seconds=2&steps=1&seed=11&guidance=2`);
  });
  test.afterAll(async () => {
    await page?.close();
  });

  test('with no motion loaded the playback bar shows no pause icon and no "0.0 / 0.0 s"', async () => {
    await expect(page.locator('#time')).not.toHaveText('0.0 / 0.0 s');
    await expect(page.locator('#play')).toBeDisabled();
    await expect(page.locator('#play')).toHaveClass(/paused/); // the play (▶) icon, not pause
    expect(await page.locator('#play').getAttribute('aria-label')).not.toBe('Pause');
  });

  test('a bad request is rejected whole: nothing on the page changes', async () => {
    const before = await snapshot(page);
    const bad: Array<[Record<string, unknown>, RegExp]> = [
      [{ seed: NaN }, /seed must be a finite number, not NaN/],
      [{ guidance: NaN }, /guidance must be a finite number, not NaN/],
      [{ seconds: -1 }, /seconds must be more than 0/],
      [{ seconds: Infinity }, /seconds must be a finite number/],
      [{ seconds: 3, seed: -5 }, /seed must be a whole number/],
      [{ mode: 'dance' }, /mode 'dance' is not text, action or random/],
      [{ steps: 3, seed: 99 }, /steps 3 is not one of/],
      [{ mode: 'action', action: 'no-such-action' }, /unknown action 'no-such-action'/],
      [{ text: '   ', seed: 5 }, /the prompt is empty/],
      [{ length: 4 }, /unknown field 'length'/],
      [{ model: 'no-such-model', seed: 3 }, /no model 'no-such-model'/],
    ];
    for (const [req, message] of bad) {
      const err = await page.evaluate(async (r) => {
        try {
          await window.emdm.generate(r);
          return 'resolved';
        } catch (e) {
          return (e as Error).message;
        }
      }, req);
      expect(err, JSON.stringify(req)).toMatch(message);
      expect(err).toMatch(/^window\.emdm\.generate: /);
      expect(await snapshot(page), `after ${JSON.stringify(req)}`).toEqual(before);
    }
    expect(await page.evaluate(() => window.emdm.counters.requests)).toBe(0);
    watch.assertClean();
  });

  test('clamped seconds are clamped in the caption and the URL too', async () => {
    const r = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 1e9, steps: 1, seed: 4 }), PROMPT);
    expect(r.state.seconds).toBe(9.8);
    expect(r.frames).toBe(196);
    expect(r.adjusted).toEqual(['seconds 1000000000 → 9.8 (1–9.8 s)']);
    await expect(page.locator('#caption small')).toContainText('· 9.8 s');
    await expect(page.locator('#caption')).not.toContainText('1000000000');
    expect(new URL(page.url()).searchParams.get('seconds')).toBe('9.8');
    await expect(page.locator('#seconds-out')).toHaveText('9.8 s');
    // with a motion loaded the bar shows its clock again
    await expect(page.locator('#play')).toBeEnabled();
    await expect(page.locator('#time')).toContainText('/ 9.8 s');
    watch.assertClean();
  });
});

test('unknown URL parameters get a notice naming them and the known ones', async ({ page }) => {
  await page.goto('/?noauto=1&backend=wasm&length=4&mode=text');
  await page.waitForFunction(() => (window.emdm?.notices() ?? []).some((n) => n.text.includes("'length'")), null, { timeout: 60_000 });
  const text = (await page.evaluate(() => window.emdm.notices())).map((n) => n.text).join('\n');
  expect(text).toMatch(/URL parameter 'length' is not known and ignored \(known: mode, text, action, steps, seconds/);
  expect(text).toContain("the motion's length is 'seconds'");
  await expect(page.locator('.notice.warn', { hasText: "'length'" })).toBeVisible();
});
