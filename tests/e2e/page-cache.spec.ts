// Model files kept in Cache Storage (src/cache/modelCache.ts) for the next visit, in headless Chromium:
// a second visit in the same browser profile downloads no model byte, a corrupt cached file is dropped
// and downloaded again with a notice, a manifest that names a new sha256 replaces the entry, and the
// page's "Clear cached models" button empties the cache. Prints cold vs second-visit ready time and bytes.
import { expect, test, type BrowserContext, type Page, type Route } from '@playwright/test';
import { stepFileOf, validateManifest } from '../../src/manifest';
import { watchPage } from './helpers';

const CACHE = 'emdm-models-v1';

/** Requests to /models/ other than the manifest (which is fetched every visit: it is the root of trust). */
function watchModelRequests(page: Page): { urls: string[]; bytes: () => number } {
  const urls: string[] = [];
  let bytes = 0;
  page.on('request', (r) => {
    const u = new URL(r.url());
    if (u.pathname.includes('/models/') && !u.pathname.endsWith('/manifest.json')) urls.push(u.pathname);
  });
  page.on('requestfinished', async (r) => {
    const u = new URL(r.url());
    if (!u.pathname.includes('/models/') || u.pathname.endsWith('/manifest.json')) return;
    bytes += (await r.sizes()).responseBodySize; // bytes on the wire (the server may compress)
  });
  return { urls, bytes: () => bytes };
}

async function openReady(page: Page): Promise<number> {
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  // the capabilities files (the "what this model knows" list) are verified files too, loaded beside the models:
  // the page has all its files once that list is filled
  await page.locator('#knows-good li').first().waitFor({ state: 'attached', timeout: 60_000 });
  return page.evaluate(() => window.emdm.startup.readyMs);
}

async function cacheKeys(page: Page): Promise<string[]> {
  return page.evaluate(async (name) => (await (await caches.open(name)).keys()).map((r) => new URL(r.url).pathname + new URL(r.url).search), CACHE);
}

test.describe('model cache', () => {
  let context: BrowserContext;
  test.beforeEach(async ({ browser }) => {
    context = await browser.newContext(); // a fresh profile: empty Cache Storage
  });
  test.afterEach(async () => {
    await context?.close();
  });

  test('a second visit downloads no model file; the clear button empties the cache', async () => {
    test.setTimeout(300_000);
    const cold = await context.newPage();
    const watchCold = watchPage(cold);
    const coldReq = watchModelRequests(cold);
    const coldMs = await openReady(cold);
    expect(coldReq.urls.length).toBeGreaterThan(0);
    const files = await cold.evaluate(() => window.emdm.files());
    expect(files.every((f) => f.state === 'done' && !f.cached)).toBe(true);
    const usage = await cold.evaluate(() => window.emdm.cache.usage());
    expect(usage.files).toBe(files.length);
    expect(usage.bytes).toBe(files.reduce((s, f) => s + f.total, 0));
    await expect(cold.locator('#clear-cache')).toContainText('Clear cached models');
    watchCold.assertClean();
    await cold.close();

    const second = await context.newPage();
    const watchSecond = watchPage(second);
    const secondReq = watchModelRequests(second);
    const secondMs = await openReady(second);
    expect(secondReq.urls, 'model files requested on the second visit').toEqual([]);
    const files2 = await second.evaluate(() => window.emdm.files());
    expect(files2.length).toBe(files.length);
    expect(files2.every((f) => f.cached && f.state === 'done')).toBe(true);
    // it generates from the cached files
    const r = await second.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks forward', seconds: 1, steps: 1, seed: 2 }));
    expect(r.frames).toBe(20);
    // where the time goes: files in hand (downloaded or read from the cache and verified), then sessions
    const filesMs = (fs: { at: number }[]) => Math.max(...fs.map((f) => f.at));
    console.log(`model cache: cold visit ready ${coldMs.toFixed(0)} ms (files verified at ${filesMs(files).toFixed(0)} ms), `
      + `${(coldReq.bytes() / 2 ** 20).toFixed(1)} MB of model files on the wire in ${coldReq.urls.length} requests; `
      + `second visit ready ${secondMs.toFixed(0)} ms (files verified at ${filesMs(files2).toFixed(0)} ms), ${secondReq.urls.length} model requests, `
      + `${(usage.bytes / 2 ** 20).toFixed(1)} MB read from Cache Storage`);

    // the button empties the cache and says so
    await second.locator('#clear-cache').click();
    await expect(second.locator('#clear-cache')).toHaveText('No models cached');
    expect(await second.evaluate(() => window.emdm.cache.usage())).toEqual({ files: 0, bytes: 0 });
    watchSecond.assertClean();
  });

  test('a corrupt cached file is dropped and downloaded again, with a notice', async () => {
    test.setTimeout(300_000);
    const page = await context.newPage();
    await openReady(page);
    const manifest = validateManifest(await page.evaluate(async () => (await fetch('/models/manifest.json')).json()));
    const text = Object.entries(manifest.models).find(([, m]) => m.task === 'text' && m.objective !== 'diffusion')![0];
    const onnx = stepFileOf(manifest, text); // the step-model file the page runs (its default variant)
    // flip one byte of the cached step model, keeping its key and headers
    const flipped = await page.evaluate(async ([name, file]) => {
      const cache = await caches.open(name);
      const key = (await cache.keys()).find((k) => new URL(k.url).pathname.endsWith(`/models/${file}`));
      if (!key) return false;
      const hit = (await cache.match(key))!;
      const bytes = new Uint8Array(await hit.arrayBuffer());
      bytes[bytes.length >> 1] ^= 0xff;
      await cache.put(key, new Response(bytes, { headers: hit.headers }));
      return true;
    }, [CACHE, onnx] as const);
    expect(flipped).toBe(true);
    await page.close();

    const again = await context.newPage();
    const req = watchModelRequests(again);
    await openReady(again);
    expect(req.urls).toEqual([`/models/${onnx}`]); // only the corrupt file comes from the network
    const notices = (await again.evaluate(() => window.emdm.notices())).map((n) => n.text).join('\n');
    expect(notices).toContain(`The cached copy of ${onnx} was corrupt`);
    const state = (await again.evaluate(() => window.emdm.files())).find((f) => f.path === onnx)!;
    expect(state).toMatchObject({ state: 'done', cached: false });
    // the cache holds the good file again: a third visit reads everything from it
    await again.close();
    const third = await context.newPage();
    const req3 = watchModelRequests(third);
    await openReady(third);
    expect(req3.urls).toEqual([]);
  });

  test('a manifest naming a new sha256 replaces the cached entry of that file', async () => {
    test.setTimeout(300_000);
    const page = await context.newPage();
    await openReady(page);
    const m = await page.evaluate(async () => (await (await fetch('/models/manifest.json')).json()) as { models: Record<string, { task: string; objective?: string; meanStd: string }>; files: Record<string, { bytes: number; sha256: string }> });
    const meanStd = Object.values(m.models).find((x) => x.task === 'text' && x.objective !== 'diffusion')!.meanStd;
    const oldSha = m.files[meanStd].sha256;
    expect((await cacheKeys(page)).filter((k) => k.includes(`/models/${meanStd}?`))).toEqual([`/models/${meanStd}?sha256=${oldSha}`]);
    await page.close();

    // a new build: the same file with its last std value changed by 1 %, and its new sha256
    const next = await context.newPage();
    const orig = Buffer.from(await (await next.request.get(`/models/${meanStd}`)).body());
    const changed = Buffer.from(orig);
    changed.writeFloatLE(orig.readFloatLE(orig.length - 4) * 1.01, changed.length - 4);
    const { createHash } = await import('node:crypto');
    const newSha = createHash('sha256').update(changed).digest('hex');
    await next.route('**/models/manifest.json', async (r: Route) => {
      const res = await r.fetch();
      const doc = await res.json();
      doc.files[meanStd] = { bytes: changed.length, sha256: newSha };
      await r.fulfill({ response: res, body: JSON.stringify(doc) });
    });
    await next.route(`**/models/${meanStd}`, (r: Route) => r.fulfill({ status: 200, body: changed, contentType: 'application/octet-stream' }));
    const req = watchModelRequests(next);
    await openReady(next);
    expect(req.urls).toEqual([`/models/${meanStd}`]);
    expect((await cacheKeys(next)).filter((k) => k.includes(`/models/${meanStd}?`))).toEqual([`/models/${meanStd}?sha256=${newSha}`]);
  });
});
