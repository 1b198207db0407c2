// The shipped MiniLM encoder in headless Chromium (WASM, self-hosted ORT, no network beyond the
// test server): same vectors as Python, hostile prompts handled, tampered files refused.
import { expect, test } from '@playwright/test';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { buildAndServe } from '../../scripts/build/serve-pages.mjs';
import { isCrossOriginIsolated, watchExternalRequests, watchPage } from './helpers';

const HERE = path.dirname(fileURLToPath(import.meta.url));
const FIXTURE = JSON.parse(fs.readFileSync(path.join(HERE, '../fixtures/text/minilm_vectors.json'), 'utf8')) as {
  prompts: string[];
  vectors: number[][];
};

function cosine(a: number[], b: number[]): number {
  let ab = 0, aa = 0, bb = 0;
  for (let i = 0; i < a.length; i++) {
    ab += a[i] * b[i];
    aa += a[i] * a[i];
    bb += b[i] * b[i];
  }
  return ab / Math.sqrt(aa * bb);
}

type TextPage = {
  crossOriginIsolated: boolean;
  load(id?: string): Promise<{ id: string; dim: number; loadMs: number; bytes: number }>;
  encode(t: string): Promise<{ vector: number[]; ms: number }>;
};
declare global {
  interface Window {
    textPage: TextPage;
  }
}

let server: Awaited<ReturnType<typeof buildAndServe>>;
test.beforeAll(async () => {
  server = await buildAndServe({ pagesDir: path.join(HERE, 'pages') });
});
test.afterAll(async () => {
  await server?.close();
});

test('MiniLM in Chromium matches Python (cosine >= 0.999) and handles hostile prompts', async ({ page }) => {
  const watch = watchPage(page);
  const external = watchExternalRequests(page, server.url);
  await page.goto(`${server.url}/text/`);
  await page.waitForFunction(() => !!window.textPage);
  expect(await isCrossOriginIsolated(page)).toBe(true);
  const info = await page.evaluate(() => window.textPage.load());
  expect(info.id).toBe('all-MiniLM-L6-v2');
  expect(info.dim).toBe(384);
  expect(info.bytes).toBeGreaterThan(15e6);
  for (let i = 0; i < FIXTURE.prompts.length; i++) {
    const { vector } = await page.evaluate((t) => window.textPage.encode(t), FIXTURE.prompts[i]);
    expect(vector).toHaveLength(384);
    expect(cosine(vector, FIXTURE.vectors[i]), `prompt ${i}`).toBeGreaterThanOrEqual(0.999);
  }
  const err = await page.evaluate(() => window.textPage.encode(7 as unknown as string).then(() => 'ok', (e: Error) => e.message));
  expect(err).toMatch(/expects a string, got number/);
  expect((await page.evaluate(() => window.textPage.encode('still works'))).vector).toHaveLength(384);
  // concurrent prompts (e.g. repeated clicks) are queued, each gets its own vector
  const many = await page.evaluate(() => Promise.all(['walk', 'run', 'jump', 'walk'].map((t) => window.textPage.encode(t))));
  expect(many.map((r) => r.vector.length)).toEqual([384, 384, 384, 384]);
  expect(cosine(many[0].vector, many[3].vector)).toBeGreaterThan(0.99999);
  expect(cosine(many[0].vector, many[1].vector)).toBeLessThan(0.99);
  expect(external, 'requests left the test server (CDN?)').toEqual([]);
  watch.assertClean();
});

test('a tampered model file is refused with a message naming it', async ({ page }) => {
  await page.route('**/models/text/all-MiniLM-L6-v2/tokenizer_config.json', async (route) => {
    const res = await route.fetch();
    const body = (await res.text()).replace('"do_lower_case": true', '"do_lower_case": fals');
    await route.fulfill({ response: res, body });
  });
  await page.goto(`${server.url}/text/`);
  await page.waitForFunction(() => !!window.textPage);
  const msg = await page.evaluate(() => window.textPage.load().then(() => 'loaded', (e: Error) => `${e.name}: ${e.message}`));
  expect(msg).toMatch(/^ModelFileError: text\/all-MiniLM-L6-v2\/tokenizer_config\.json: sha256 [0-9a-f]{64} differs/);
});
