// src/manifest.ts on the real shipped manifest, and refusal of tampered / missing / malformed files.
import { afterAll, beforeAll, describe, expect, test } from 'vitest';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { pathToFileURL } from 'node:url';
import { fetchVerified, loadManifest, looksLikeHtml, ModelFileError, sha256Hex, validateManifest, type Manifest } from '../../src/manifest';

const MODELS = path.resolve(__dirname, '../../public/models') + '/';
const ONNX = 'text/all-MiniLM-L6-v2/onnx/model_quantized.onnx';
let tmp = '';

beforeAll(() => {
  tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-manifest-'));
});
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

function copyModels(files: string[]): string {
  const dir = fs.mkdtempSync(path.join(tmp, 'm-'));
  for (const rel of ['manifest.json', ...files]) {
    fs.mkdirSync(path.dirname(path.join(dir, rel)), { recursive: true });
    fs.copyFileSync(path.join(MODELS, rel), path.join(dir, rel));
  }
  return dir + '/';
}

async function rejection(p: Promise<unknown>): Promise<ModelFileError> {
  try {
    await p;
  } catch (e) {
    expect(e).toBeInstanceOf(ModelFileError);
    return e as ModelFileError;
  }
  throw new Error('expected a ModelFileError');
}

describe('the shipped manifest', () => {
  test('loads (path and file:// URL) and lists the MiniLM encoder with sizes and hashes', async () => {
    const m = await loadManifest(MODELS);
    const viaUrl = await loadManifest(pathToFileURL(MODELS).href);
    expect(viaUrl).toEqual(m);
    expect(m.schema).toBe(1);
    expect(m.skeleton.joints).toHaveLength(22);
    const enc = m.textEncoders['all-MiniLM-L6-v2'];
    expect(enc.kind).toBe('minilm');
    expect(enc.dim).toBe(384);
    expect(enc.files).toContain(ONNX);
    expect(m.files[ONNX].bytes).toBeGreaterThan(15e6);
  });

  test('fetchVerified returns the bytes of the shipped ONNX file, with progress', async () => {
    const m = await loadManifest(MODELS);
    const seen: number[] = [];
    const buf = await fetchVerified(MODELS, m, ONNX, (loaded, total) => {
      expect(total).toBe(m.files[ONNX].bytes);
      seen.push(loaded);
    });
    expect(buf.byteLength).toBe(m.files[ONNX].bytes);
    expect(await sha256Hex(buf)).toBe(m.files[ONNX].sha256);
    expect(seen.at(-1)).toBe(buf.byteLength);
  });
});

describe('refusals', () => {
  test('a tampered file is refused with reason sha256, naming the file', async () => {
    const dir = copyModels(['text/all-MiniLM-L6-v2/tokenizer_config.json']);
    const m = await loadManifest(dir);
    const f = path.join(dir, 'text/all-MiniLM-L6-v2/tokenizer_config.json');
    const txt = fs.readFileSync(f, 'utf8');
    fs.writeFileSync(f, txt.replace('"do_lower_case": true', '"do_lower_case": fals'));
    const e = await rejection(fetchVerified(dir, m, 'text/all-MiniLM-L6-v2/tokenizer_config.json'));
    expect(e.reason).toBe('sha256');
    expect(e.path).toBe('text/all-MiniLM-L6-v2/tokenizer_config.json');
    expect(e.message).toMatch(/sha256 [0-9a-f]{64} differs from the manifest's/);
    fs.appendFileSync(f, 'x');
    expect((await rejection(fetchVerified(dir, m, 'text/all-MiniLM-L6-v2/tokenizer_config.json'))).message).toMatch(/size \d+ bytes differs/);
  });

  test('a missing file and an unlisted file are refused with reason missing', async () => {
    const dir = copyModels([]);
    const m = await loadManifest(dir);
    const e = await rejection(fetchVerified(dir, m, ONNX));
    expect(e.reason).toBe('missing');
    expect(e.message).toContain('not found at');
    const u = await rejection(fetchVerified(dir, m, 'text/evil.onnx'));
    expect(u.reason).toBe('missing');
    expect(u.message).toContain('refusing an unverified file');
  });

  test('a server without the file: HTTP 404, or its index.html with status 200, is reported missing with the path, never as corrupt', async () => {
    const m = await loadManifest(MODELS);
    const BASE = 'http://models.test/models/';
    const page = '<!doctype html>\n<html><head><title>EMDM</title></head><body></body></html>\n';
    const answers: Record<string, () => Response> = {
      // a SPA fallback that says it is HTML
      'emdm-t2m-web.onnx': () => new Response(page, { status: 200, headers: { 'content-type': 'text/html; charset=utf-8' } }),
      // one that sends the page with a neutral type: caught by its first bytes when it fails verification
      [ONNX]: () => new Response(`\uFEFF  ${page}`, { status: 200, headers: { 'content-type': 'application/octet-stream' } }),
      'emdm-t2m-web.meanstd.f32': () => new Response('Not Found', { status: 404 }),
      'manifest.json': () => new Response(page, { status: 200 }),
    };
    const realFetch = globalThis.fetch;
    globalThis.fetch = (async (input: string | URL | Request) => {
      const rel = String(input instanceof Request ? input.url : input).slice(BASE.length);
      return answers[rel]?.() ?? new Response('', { status: 500 });
    }) as typeof fetch;
    try {
      for (const [file, how] of [['emdm-t2m-web.onnx', /answered with an HTML page \(HTTP 200\)/], [ONNX, /is an HTML page/], ['emdm-t2m-web.meanstd.f32', /\(HTTP 404\)/]] as const) {
        const e = await rejection(fetchVerified(BASE, m, file));
        expect(e.reason, file).toBe('missing');
        expect(e.path).toBe(file);
        expect(e.message).toContain(file);
        expect(e.message).toMatch(how);
        expect(e.message).not.toMatch(/corrupt|sha256/);
      }
      const e = await rejection(loadManifest(BASE));
      expect(e.reason).toBe('missing');
      expect(e.message).toContain(`${BASE}manifest.json`);
    } finally {
      globalThis.fetch = realFetch;
    }
    // a real file that merely differs is still a checksum refusal, and bytes that are not HTML are not "missing"
    expect(looksLikeHtml(new TextEncoder().encode('{"a": 1}'))).toBe(false);
    expect(looksLikeHtml(new Uint8Array(fs.readFileSync(path.join(MODELS, 'emdm-t2m-web.meanstd.f32'))))).toBe(false);
    expect(looksLikeHtml(new TextEncoder().encode('  <HTML lang="en">'))).toBe(true);
  });

  test('a malformed manifest names the field', async () => {
    const base = JSON.parse(fs.readFileSync(path.join(MODELS, 'manifest.json'), 'utf8')) as Manifest;
    const bad = (mut: (m: Record<string, any>) => void): string => {
      const m = structuredClone(base) as Record<string, any>;
      mut(m);
      try {
        validateManifest(m);
      } catch (e) {
        expect(e).toBeInstanceOf(ModelFileError);
        expect((e as ModelFileError).reason).toBe('incompatible');
        return (e as Error).message;
      }
      throw new Error('accepted a malformed manifest');
    };
    expect(bad((m) => (m.schema = 2))).toContain("field 'schema' is 2");
    expect(bad((m) => (m.files[ONNX].sha256 = 'abc'))).toContain(`files["${ONNX}"].sha256`);
    expect(bad((m) => m.textEncoders['all-MiniLM-L6-v2'].files.push('x.bin'))).toContain('"x.bin", which is not listed');
    expect(bad((m) => (m.textEncoders['all-MiniLM-L6-v2'].kind = 'bert'))).toContain('textEncoders.all-MiniLM-L6-v2.kind');
    // every path it names stays inside the models folder; every size it sets is bounded (emdm.manifest has the same)
    const model = 'emdm-t2m-web';
    const inside = /it must be a relative path inside the models folder/;
    expect(bad((m) => (m.models[model].meanStd = '../../../../etc/passwd'))).toMatch(new RegExp(`field 'models.${model}.meanStd' is "../../../../etc/passwd"; ` + inside.source));
    expect(bad((m) => (m.models[model].onnx = '/etc/passwd'))).toMatch(inside);
    expect(bad((m) => (m.models[model].variants.int8 = 'a/../../x.onnx'))).toContain(`models.${model}.variants.int8`);
    expect(bad((m) => (m.textEncoders['all-MiniLM-L6-v2'].dir = '..'))).toContain('textEncoders.all-MiniLM-L6-v2.dir');
    expect(bad((m) => (m.files['../x.onnx'] = m.files[ONNX]))).toContain('files["../x.onnx"]');
    expect(bad((m) => (m.files['C:/x.onnx'] = m.files[ONNX]))).toMatch(inside);
    expect(bad((m) => (m.models[model].supportedSteps = [1, 100000]))).toContain(`field 'models.${model}.supportedSteps' is [1,100000]; it must be a list of step counts in 1…1000`);
    expect(bad((m) => (m.models[model].defaultSteps = 1e6))).toContain(`models.${model}.defaultSteps`);
    expect(bad((m) => (m.models[model].x0Smoothing = 1e9))).toContain(`field 'models.${model}.x0Smoothing' is 1000000000; it must be a σ ≥ 0 in frames, at most 50`);
    expect(bad((m) => (m.models[model].speedCap = -1))).toContain(`field 'models.${model}.speedCap' is -1; it must be a multiple ≥ 0 of the first step's root speed`);
    expect(bad((m) => (m.models[model].maxFrames = 1e9))).toContain(`models.${model}.maxFrames`);
    const dir = fs.mkdtempSync(path.join(tmp, 'j-'));
    fs.writeFileSync(path.join(dir, 'manifest.json'), '{"schema": 1,');
    expect((await rejection(loadManifest(dir + '/'))).message).toContain('not valid JSON');
  });
});
