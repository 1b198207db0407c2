// The production build (`vite build`, what gets deployed) contains the demo and the library's examples
// (web/examples/*.html, served at /examples/minimal.html by `make demo`): the test harness
// (web/harness/: no CSP, loads models from ?models=<any URL>) is built only in the test mode that
// Playwright's server uses.
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { build } from 'vite';
import { E2E_MODE, pageInputs } from '../../vite.config';

const ROOT = path.resolve(__dirname, '../..');
const out = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-build-'));
afterAll(() => fs.rmSync(out, { recursive: true, force: true }));

const sha256 = (file: string) => createHash('sha256').update(fs.readFileSync(file)).digest('hex');
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
    // one ONNX Runtime: every .wasm in the build is a file of the project's onnxruntime-web (transformers.js
    // no longer brings its own nested ORT and its 21 MB jsep .wasm)
    const ortDist = path.join(ROOT, 'node_modules/onnxruntime-web/dist');
    const ours = new Set(fs.readdirSync(ortDist).filter((f) => f.endsWith('.wasm')).map((f) => sha256(path.join(ortDist, f))));
    const wasm = built.filter((f) => f.endsWith('.wasm'));
    expect(wasm.length).toBeGreaterThan(0);
    for (const f of wasm) expect(ours.has(sha256(path.join(out, f))), `${f} is not one of onnxruntime-web's own .wasm files`).toBe(true);
  }, 180_000);

  it("public/ort/ holds the project's ORT .wasm files and files.json with their sizes and sha256 (the runtime is fetched as a verified file)", () => {
    const dir = path.join(ROOT, 'public/ort');
    const list = JSON.parse(fs.readFileSync(path.join(dir, 'files.json'), 'utf8')) as Record<string, { bytes: number; sha256: string }>;
    expect(Object.keys(list)).toContain('ort-wasm-simd-threaded.wasm');
    for (const [name, meta] of Object.entries(list)) {
      expect(fs.statSync(path.join(dir, name)).size).toBe(meta.bytes);
      expect(sha256(path.join(dir, name))).toBe(meta.sha256);
    }
    expect(fs.existsSync(path.join(ROOT, 'public/ort-tfjs')), 'transformers.js has no ORT of its own any more').toBe(false);
  });

  it('the test mode adds the harness (served to Playwright, never deployed)', () => {
    expect(Object.keys(pageInputs())).toEqual(['main', 'examples/minimal']);
    expect(Object.keys(pageInputs(undefined, { testPages: true }))).toEqual(expect.arrayContaining(['main', 'harness', 'examples/minimal']));
    expect(E2E_MODE).toBe('e2e');
  });
});
