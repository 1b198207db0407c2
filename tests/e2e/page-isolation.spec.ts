// Served without COOP/COEP the page is not cross-origin isolated, so ORT's WebAssembly runs on one
// thread: the page says so, why, and which two headers to send. The test server sends the headers
// (vite.config.ts); here the page's document arrives without them, as from a plain static host.
import { expect, test, type Route } from '@playwright/test';

test('without COOP/COEP the page explains the single thread and how to serve it', async ({ page }) => {
  await page.route((url) => url.pathname === '/', async (r: Route) => {
    const res = await r.fetch();
    const headers = { ...res.headers() };
    delete headers['cross-origin-opener-policy'];
    delete headers['cross-origin-embedder-policy'];
    await r.fulfill({ response: res, headers });
  });
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.crossOriginIsolated)).toBe(false);
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  await page.waitForFunction(() => window.emdm.environment !== null);
  expect(await page.evaluate(() => window.emdm.environment)).toMatchObject({ crossOriginIsolated: false, threads: 1 });
  const note = page.locator('#isolation-note');
  await expect(note).toBeVisible();
  await expect(note).toContainText('not cross-origin isolated');
  await expect(note).toContainText('one CPU thread');
  await expect(note).toContainText('Cross-Origin-Opener-Policy: same-origin');
  await expect(note).toContainText('Cross-Origin-Embedder-Policy: require-corp');
  // it still generates (on one thread)
  const r = await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 1, steps: 1, seed: 3 }));
  expect(r.timings.threads).toBe(1);
});

test('served with COOP/COEP there is no such notice', async ({ page }) => {
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true && window.emdm.environment !== null, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.environment)).toMatchObject({ crossOriginIsolated: true });
  // isolated, ORT may use threads: all cores but one (left to the page's rendering), at most 4
  const env = await page.evaluate(() => window.emdm.environment!);
  expect(env.threads).toBe(Math.max(1, Math.min(4, env.hardwareConcurrency - 1)));
  await expect(page.locator('#isolation-note')).toBeHidden();
});
