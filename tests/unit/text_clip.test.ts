// The CLIP (EMDM's encoder) path in transformers.js: EMDM truncation, the real CLIP tokenizer
// (ids equal Python's and CLIP's known ids), and a randomly initialised text tower of the real
// configuration exported by Python into a temp dir, run here and compared with PyTorch (1e-4).
import { afterAll, beforeAll, describe, expect, test } from 'vitest';
import { execFileSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { loadManifest } from '../../src/manifest';
import { createTextEncoder, emdmClipIds, truncateKeepingEnd, type TextEncoder } from '../../src/text';
import { loadTransformers } from '../../src/text/transformersEnv';

const ROOT = path.resolve(__dirname, '../..');
const SHARED = process.env.EMDM_SHARED_DATA ?? path.resolve(ROOT, '../shared/data');
const CLIP_DIR = path.join(SHARED, 'clip-vit-base-patch32');
const HAVE_CLIP = fs.existsSync(path.join(CLIP_DIR, 'tokenizer.json'));
const PYTHON = path.join(ROOT, '.venv/bin/python');
const HAVE_PYTHON = fs.existsSync(PYTHON);
const FIXTURE = JSON.parse(fs.readFileSync(path.join(ROOT, 'tests/fixtures/text/clip_tokens.json'), 'utf8')) as {
  eot: number;
  prompts: string[];
  raw_ids: number[][];
  emdm_ids: number[][];
};
const SOT = 49406;
const EOT = 49407;

describe('EMDM truncation (pure)', () => {
  test('short prompts are zero-padded to 77', () => {
    const ids = emdmClipIds([SOT, 320, 1125, EOT], EOT);
    expect(ids).toHaveLength(77);
    expect(ids.slice(0, 4)).toEqual([SOT, 320, 1125, EOT]);
    expect(new Set(ids.slice(4))).toEqual(new Set([0]));
  });
  test('long prompts keep 20 text tokens and end with [EOT]', () => {
    const raw = [SOT, ...Array.from({ length: 30 }, (_, i) => 1000 + i), EOT];
    const ids = emdmClipIds(raw, EOT);
    expect(ids.slice(0, 21)).toEqual(raw.slice(0, 21));
    expect(ids[21]).toBe(EOT);
    expect(ids.slice(22).every((x) => x === 0)).toBe(true);
  });
  test('bad ids are refused', () => {
    expect(() => emdmClipIds([SOT, 320], EOT)).toThrow(/last id must be the end token/);
    expect(() => truncateKeepingEnd([1, 2, 3], 1)).toThrow(/max must be >= 2/);
    expect(truncateKeepingEnd([101, 5, 6, 7, 102], 4)).toEqual([101, 5, 6, 102]);
  });
});

describe.skipIf(!HAVE_CLIP)(`real CLIP tokenizer (skipped: no ${CLIP_DIR}; put ../shared/data beside the checkout or set EMDM_SHARED_DATA)`, () => {
  test('token ids equal Python (fixture) and the known CLIP ids', async () => {
    const tf = await loadTransformers();
    const tok = await tf.AutoTokenizer.from_pretrained(CLIP_DIR, { local_files_only: true });
    expect(tok.encode('a photo of a cat')).toEqual([49406, 320, 1125, 539, 320, 2368, 49407]);
    FIXTURE.prompts.forEach((p, i) => {
      const raw = tok.encode(p);
      expect(raw, `prompt ${JSON.stringify(p)}`).toEqual(FIXTURE.raw_ids[i]);
      expect(emdmClipIds(raw, FIXTURE.eot)).toEqual(FIXTURE.emdm_ids[i]);
    });
  });
});

const CAN_EXPORT = HAVE_CLIP && HAVE_PYTHON;
describe.skipIf(!CAN_EXPORT)(
  `random CLIP text tower exported by Python (skipped: needs ${CLIP_DIR} and ${PYTHON}; run \`make test\` set-up)`,
  () => {
    let tmp = '';
    let enc: TextEncoder;
    let ref: { prompts: string[]; ids: number[][]; embeddings: number[][] };
    beforeAll(async () => {
      tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-clip-'));
      const prompts = path.join(tmp, 'prompts.json');
      fs.writeFileSync(prompts, JSON.stringify(FIXTURE.prompts));
      execFileSync(PYTHON, ['-m', 'emdm.text.export_clip', '--source', CLIP_DIR, '--random-init', '--seed', '0',
        '--models-dir', path.join(tmp, 'models'), '--reference', prompts], { cwd: ROOT, stdio: 'pipe', timeout: 300_000 });
      const base = path.join(tmp, 'models') + '/';
      ref = JSON.parse(fs.readFileSync(path.join(tmp, 'models/text/clip-vit-b32/reference.json'), 'utf8'));
      enc = await createTextEncoder(await loadManifest(base), base, 'clip-vit-b32');
    }, 360_000);
    afterAll(() => {
      if (tmp) fs.rmSync(tmp, { recursive: true, force: true });
    });

    test('Python used the same EMDM ids', () => {
      expect(ref.ids).toEqual(FIXTURE.emdm_ids);
    });

    test('transformers.js equals PyTorch within 1e-4 on every prompt (incl. truncated, empty, emoji, HTML)', async () => {
      expect(enc.dim).toBe(512);
      for (let i = 0; i < ref.prompts.length; i++) {
        const v = await enc.encode(ref.prompts[i]);
        expect(v).toHaveLength(512);
        let maxDiff = 0;
        v.forEach((x, j) => (maxDiff = Math.max(maxDiff, Math.abs(x - ref.embeddings[i][j]))));
        expect(maxDiff, `prompt ${JSON.stringify(ref.prompts[i])}`).toBeLessThan(1e-4);
      }
    });

    test('words past the 20-token context change nothing; a 10,000-character prompt still works', async () => {
      const long = FIXTURE.prompts[2];
      expect(Array.from(await enc.encode(long + ' and then sleeps'))).toEqual(Array.from(await enc.encode(long)));
      const huge = await enc.encode('a person walks '.repeat(700));
      expect(huge.every(Number.isFinite)).toBe(true);
      // the manifest's maxTokens (22: [SOT] + 20 + [EOT]) is what tokenize reports; EMDM's ids without padding
      const t = await enc.tokenize!(long);
      expect(t).toMatchObject({ maxTokens: 22, truncated: true, tokens: FIXTURE.raw_ids[2].length });
      expect(t.ids).toEqual(FIXTURE.emdm_ids[2].slice(0, 22));
    });
  },
);
