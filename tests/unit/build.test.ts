// The production build (`vite build`, what gets deployed) contains the demo and the library's examples
// (web/examples/*.html, served at /examples/minimal.html by `make demo`): the test harness
// (web/harness/: no CSP, loads models from ?models=<any URL>) is built only in the test mode that
// Playwright's server uses.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { build } from 'vite';
import { E2E_MODE, pageInputs } from '../../vite.config';

const ROOT = path.resolve(__dirname, '../..');
const out = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-build-'));
afterAll(() => fs.rmSync(out, { recursive: true, force: true }));

const files = (dir: string): string[] => fs.readdirSync(dir, { recursive: true, encoding: 'utf8' }).map((f) => f.split(path.sep).join('/'));

describe('vite build', () => {
  it('production: dist/ holds the demo page, the minimal example and no harness', async () => {
    // the real config and mode; only the output folder differs, and public/ (models, ORT wasm) is not copied
    await build({ configFile: path.join(ROOT, 'vite.config.ts'), mode: 'production', logLevel: 'error', build: { outDir: out, copyPublicDir: false } });
    const built = files(out);
    expect(built.filter((f) => f.endsWith('.html')).sort()).toEqual(['examples/minimal.html', 'index.html']);
    expect(built.some((f) => f.startsWith('harness'))).toBe(false);
    const js = built.filter((f) => f.endsWith('.js')).map((f) => fs.readFileSync(path.join(out, f), 'utf8'));
    expect(js.length).toBeGreaterThan(0);
    expect(js.some((src) => src.includes('coreHarness'))).toBe(false);
  }, 180_000);

  it('the test mode adds the harness (served to Playwright, never deployed)', () => {
    expect(Object.keys(pageInputs())).toEqual(['main', 'examples/minimal']);
    expect(Object.keys(pageInputs(undefined, { testPages: true }))).toEqual(expect.arrayContaining(['main', 'harness', 'examples/minimal']));
    expect(E2E_MODE).toBe('e2e');
  });
});
