// The demo page's loading path in headless Chromium: the ONNX Runtime .wasm is fetched beside the models
// (not after them) and counted as a file; a file the server does not have — HTTP 404, or the site's
// index.html answered with status 200 by a single-page-app fallback — is reported as MISSING with its
// path (never as a checksum mismatch, "corrupt or replaced file"), and the status line says it failed.
import fs from 'node:fs';
import { expect, test, type Page, type Route } from '@playwright/test';
import { stepFileOf, validateManifest } from '../../src/manifest';

/** The step-model file the page loads for text (the manifest's default variant of emdm-t2m-web). */
const STEP_FILE = stepFileOf(validateManifest(JSON.parse(fs.readFileSync('public/models/manifest.json', 'utf8'))), 'emdm-t2m-web');

async function open(page: Page): Promise<void> {
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 180_000 });
}

/** What the page shows after a failed load: the error panel's text and the file's row in the file list. */
async function failure(page: Page, file: string) {
  await expect(page.locator('#error-panel')).toBeVisible();
  const reason = (await page.locator('#error-reason').textContent()) ?? '';
  const hint = (await page.locator('#error-hint').textContent()) ?? '';
  const row = (await page.evaluate(() => window.emdm.files())).find((f) => f.path.endsWith(file));
  const status = (await page.locator('#status-text').textContent()) ?? '';
  return { reason, hint, row, status, error: await page.evaluate(() => window.emdm.error) };
}

function expectMissing(f: Awaited<ReturnType<typeof failure>>, file: string) {
  expect(f.reason).toContain(`${file}: the file is missing`);
  expect(`${f.reason} ${f.hint} ${f.error}`).not.toMatch(/checksum|corrupt|sha256/i);
  expect(f.error).toContain(file);
  expect(f.row?.state).toBe('failed');
  expect(f.status).not.toMatch(/Downloading/);
}

test('a model file answered with the site\'s index.html (SPA fallback, status 200) is reported missing with its path', async ({ page }) => {
  const html = await (await page.request.get('/')).text();
  expect(html).toMatch(/<!doctype html/i);
  await page.route(`**/models/${STEP_FILE}`, (r: Route) => r.fulfill({ status: 200, contentType: 'text/html', body: html }));
  await open(page);
  const f = await failure(page, STEP_FILE);
  expectMissing(f, STEP_FILE);
  expect(f.hint).toMatch(/answered with an HTML page \(HTTP 200\)/);
});

test('the same page sent as application/octet-stream is caught by its bytes: missing, not corrupt', async ({ page }) => {
  const html = await (await page.request.get('/')).text();
  await page.route('**/models/text/all-MiniLM-L6-v2/onnx/model_quantized.onnx', (r: Route) => r.fulfill({ status: 200, contentType: 'application/octet-stream', body: html }));
  await open(page);
  const f = await failure(page, 'model_quantized.onnx');
  expectMissing(f, 'text/all-MiniLM-L6-v2/onnx/model_quantized.onnx');
  expect(f.hint).toMatch(/is an HTML page/);
});

test('HTTP 404 for an encoder file: missing, with the path and URL', async ({ page }) => {
  await page.route('**/models/text/all-MiniLM-L6-v2/tokenizer.json', (r: Route) => r.fulfill({ status: 404, body: 'Not Found' }));
  await open(page);
  const f = await failure(page, 'tokenizer.json');
  expectMissing(f, 'text/all-MiniLM-L6-v2/tokenizer.json');
  expect(f.hint).toMatch(/models\/text\/all-MiniLM-L6-v2\/tokenizer\.json \(HTTP 404\)/);
  await expect(page.locator('#file-list li[title="text/all-MiniLM-L6-v2/tokenizer.json"]')).toContainText('missing on the server');
});

test('HTTP 404 for the ONNX Runtime .wasm: missing, with the path and URL', async ({ page }) => {
  await page.route('**/ort/ort-wasm-simd-threaded.wasm', (r: Route) => r.fulfill({ status: 404, body: 'Not Found' }));
  await open(page);
  const g = await failure(page, 'ort-wasm-simd-threaded.wasm');
  expectMissing(g, 'ort-wasm-simd-threaded.wasm');
  expect(g.hint).toMatch(/ort\/ort-wasm-simd-threaded\.wasm \(HTTP 404\)/);
});

test('the runtime .wasm is requested beside the models, before they have arrived, and is listed as a verified file', async ({ page }) => {
  const seen: Array<{ path: string; start: number; end: number }> = [];
  page.on('requestfinished', (r) => {
    const t = r.timing();
    seen.push({ path: new URL(r.url()).pathname, start: t.startTime, end: t.startTime + t.responseEnd });
  });
  await open(page);
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  const at = (suffix: string) => {
    const hit = seen.find((s) => s.path.endsWith(suffix));
    if (!hit) throw new Error(`no request for ${suffix}: ${seen.map((s) => s.path).join(', ')}`);
    return hit;
  };
  const wasm = at('/ort/ort-wasm-simd-threaded.wasm');
  const encoder = at('/onnx/model_quantized.onnx');
  expect(wasm.start, 'the .wasm was requested only after the encoder model had arrived').toBeLessThan(encoder.end);
  expect(seen.some((s) => s.path.includes('/ort-tfjs/')), 'a second ONNX Runtime was downloaded').toBe(false);
  const files = await page.evaluate(() => window.emdm.files());
  const runtime = files.find((f) => f.path === 'ort-wasm-simd-threaded.wasm');
  const list = await (await page.request.get('/ort/files.json')).json() as Record<string, { bytes: number }>;
  expect(runtime).toMatchObject({ state: 'done', total: list['ort-wasm-simd-threaded.wasm'].bytes });
});

test("the page loads each model's default file (the text model's int8, not fp32), and the fp32 one with ?variant=fp32", async ({ page, context }) => {
  const stepFiles = (p: Page) => {
    const seen: string[] = [];
    p.on('request', (r) => {
      const m = new URL(r.url()).pathname.match(/\/models\/([^/]+\.onnx)$/);
      if (m) seen.push(m[1]);
    });
    return seen;
  };
  const dflt = stepFiles(page);
  await open(page);
  expect(STEP_FILE).toBe('emdm-t2m-web.int8.onnx');
  expect(dflt).toEqual([STEP_FILE]);
  const fp32Page = await context.newPage();
  const fp32 = stepFiles(fp32Page);
  await fp32Page.goto('/?noauto=1&backend=wasm&variant=fp32');
  await fp32Page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 180_000 });
  expect(await fp32Page.evaluate(() => window.emdm.error)).toBe('');
  expect(fp32).toEqual(['emdm-t2m-web.onnx']);
});
