// The production build (`vite build`, what gets deployed) contains the demo and the library's examples
// (web/examples/*.html, served at /examples/minimal.html by `make demo`): the test harness
// (web/harness/: no CSP, loads models from ?models=<any URL>) is built only in the test mode that
// Playwright's server uses.
import { createHash, randomBytes } from 'node:crypto';
import fs from 'node:fs';
import { Writable } from 'node:stream';
import zlib from 'node:zlib';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { build } from 'vite';
import { E2E_MODE, pageInputs } from '../../vite.config';
// @ts-expect-error -- plain ESM build script without type declarations
import { compressedStatic, pickEncoding, precompressDir } from '../../scripts/build/precompress.mjs';

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
    // the package's plugin wires it (src/vite.ts), with `webgpu: true` here: WASM's and WebGPU's runtimes in ort/, no
    // copies under assets/ (a consumer's default build holds only WASM's: tests/unit/package.test.ts)
    const wasm = built.filter((f) => f.endsWith('.wasm')).sort();
    expect(wasm).toEqual(['ort/ort-wasm-simd-threaded.asyncify.wasm', 'ort/ort-wasm-simd-threaded.wasm']);
    for (const f of wasm) expect(ours.has(sha256(path.join(out, f))), `${f} is not one of onnxruntime-web's own .wasm files`).toBe(true);
  }, 180_000);

  it("the build's ort/ holds ORT's .wasm files and files.json with their sizes and sha256 (the runtime is fetched as a verified file)", () => {
    const dir = path.join(out, 'ort');
    const list = JSON.parse(fs.readFileSync(path.join(dir, 'files.json'), 'utf8')) as Record<string, { bytes: number; sha256: string }>;
    expect(Object.keys(list)).toContain('ort-wasm-simd-threaded.wasm');
    for (const [name, meta] of Object.entries(list)) {
      expect(fs.statSync(path.join(dir, name)).size).toBe(meta.bytes);
      expect(sha256(path.join(dir, name))).toBe(meta.sha256);
    }
    expect(fs.existsSync(path.join(ROOT, 'public/ort-tfjs')), 'transformers.js has no ORT of its own any more').toBe(false);
    expect(fs.existsSync(path.join(ROOT, 'public/ort')), 'the plugin serves ORT; an old public/ort/ would be copied beside it').toBe(false);
  });

  it('the test mode adds the harness (served to Playwright, never deployed)', () => {
    expect(Object.keys(pageInputs())).toEqual(['main', 'examples/minimal']);
    expect(Object.keys(pageInputs(undefined, { testPages: true }))).toEqual(expect.arrayContaining(['main', 'harness', 'examples/minimal']));
    expect(E2E_MODE).toBe('e2e');
  });
});

describe('compressed delivery (scripts/build/precompress.mjs)', () => {
  it('writes .br/.gz beside files that shrink by 10 %, not beside incompressible ones; preview serves them with Content-Encoding', async () => {
    const dir = fs.mkdtempSync(path.join(out, 'site-'));
    const cacheDir = fs.mkdtempSync(path.join(out, 'cache-'));
    fs.mkdirSync(path.join(dir, 'models'));
    const json = JSON.stringify({ joints: Array.from({ length: 400 }, (_, i) => ({ name: `joint_${i % 22}`, offset: [0, 0.1, 0] })) });
    fs.writeFileSync(path.join(dir, 'models/manifest.json'), json);
    const noise = randomBytes(8192); // nothing to compress
    fs.writeFileSync(path.join(dir, 'models/noise.onnx'), noise);
    const t = precompressDir(dir, { cacheDir });
    expect(t.files).toBe(2);
    const br = fs.readFileSync(path.join(dir, 'models/manifest.json.br'));
    expect(zlib.brotliDecompressSync(br).toString()).toBe(json);
    expect(zlib.gunzipSync(fs.readFileSync(path.join(dir, 'models/manifest.json.gz'))).toString()).toBe(json);
    expect(fs.existsSync(path.join(dir, 'models/noise.onnx.br'))).toBe(false);
    // a rebuild takes the compressed bytes from the cache, by sha256
    fs.rmSync(path.join(dir, 'models/manifest.json.br'));
    expect(precompressDir(dir, { cacheDir }).br).toBe(t.br);
    expect(fs.readFileSync(path.join(dir, 'models/manifest.json.br'))).toEqual(br);

    expect(pickEncoding('gzip, deflate, br')).toEqual({ ext: 'br', name: 'br' });
    expect(pickEncoding('gzip, br;q=0')).toEqual({ ext: 'gz', name: 'gzip' });
    expect(pickEncoding('identity')).toBeNull();

    const serve = compressedStatic(dir, { 'Cross-Origin-Embedder-Policy': 'require-corp' });
    const call = (url: string, headers: Record<string, string>) => new Promise<{ status: number; headers: Record<string, string>; body: Buffer; next: boolean }>((resolve) => {
      const h: Record<string, string> = {};
      const chunks: Buffer[] = [];
      const res = Object.assign(new Writable({ write(c: Buffer, _e: string, cb: () => void) { chunks.push(c); cb(); } }), {
        statusCode: 0, setHeader: (k: string, v: string) => { h[k.toLowerCase()] = v; },
      });
      res.on('finish', () => resolve({ status: res.statusCode, headers: h, body: Buffer.concat(chunks), next: false }));
      serve({ method: 'GET', url, headers }, res, () => resolve({ status: 0, headers: h, body: Buffer.alloc(0), next: true }));
    });
    const r = await call('/models/manifest.json?x=1', { 'accept-encoding': 'gzip, br' });
    expect(r.status).toBe(200);
    expect(r.headers['content-encoding']).toBe('br');
    expect(r.headers['content-type']).toBe('application/json');
    expect(r.headers['cross-origin-embedder-policy']).toBe('require-corp');
    expect(zlib.brotliDecompressSync(r.body).toString()).toBe(json);
    expect((await call('/models/manifest.json', { 'accept-encoding': 'br', 'if-none-match': r.headers.etag })).status).toBe(304);
    expect((await call('/models/manifest.json', {})).next, 'no Accept-Encoding: the plain file').toBe(true);
    expect((await call('/models/noise.onnx', { 'accept-encoding': 'br' })).next).toBe(true);
    expect((await call('/../build.test.ts', { 'accept-encoding': 'br' })).next).toBe(true);
  });
});
