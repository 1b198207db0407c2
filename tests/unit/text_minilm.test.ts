// The shipped MiniLM through transformers.js (Node) agrees with Python on the same ONNX file,
// and hostile prompts give a vector or a clear error.
import { beforeAll, describe, expect, test, vi } from 'vitest';
import fs from 'node:fs';
import path from 'node:path';
import { openModel } from '../../src/openModel';
import { loadManifest } from '../../src/manifest';
import { cosine, createTextEncoder, type TextEncoder, TextEncoderError } from '../../src/text';
import { loadTransformers } from '../../src/text/transformersEnv';

const MODELS = path.resolve(__dirname, '../../public/models') + '/';
const FIXTURE = JSON.parse(fs.readFileSync(path.resolve(__dirname, '../fixtures/text/minilm_vectors.json'), 'utf8')) as {
  prompts: string[];
  vectors: number[][];
  dim: number;
  /** Python's ids (cut to maxTokens) and whole-prompt token counts (emdm.text.fixtures) */
  maxTokens: number;
  ids: number[][];
  tokens: number[];
};
let enc: TextEncoder;

beforeAll(async () => {
  enc = await createTextEncoder(await loadManifest(MODELS), MODELS);
});

describe('all-MiniLM-L6-v2 (transformers.js, Node)', () => {
  test('is the shipped 384-d encoder', () => {
    expect(enc.id).toBe('all-MiniLM-L6-v2');
    expect(enc.dim).toBe(384);
  });

  test.each(FIXTURE.prompts.map((p, i) => [i, p.length > 60 ? `${p.slice(0, 40)}… (${p.length} chars)` : JSON.stringify(p)]))(
    'prompt %i %s: cosine to Python >= 0.999, unit length',
    async (i) => {
      const v = await enc.encode(FIXTURE.prompts[i as number]);
      expect(v).toBeInstanceOf(Float32Array);
      expect(v.length).toBe(FIXTURE.dim);
      expect(v.every(Number.isFinite)).toBe(true);
      expect(Math.hypot(...v)).toBeCloseTo(1, 5);
      expect(cosine(v, FIXTURE.vectors[i as number])).toBeGreaterThanOrEqual(0.999);
    },
  );

  test('similar captions are closer than unrelated ones', async () => {
    const [a, b, c] = await Promise.all(
      ['a person walks forward slowly', 'someone is walking ahead at a slow pace', 'the stock market fell sharply today'].map((t) => enc.encode(t)),
    );
    expect(cosine(a, b)).toBeGreaterThan(cosine(a, c) + 0.3);
  });

  test('every transformers.js tensor of a run is disposed (the 3 inputs and the outputs)', async () => {
    const tf = await loadTransformers();
    const disposed: unknown[] = [];
    const spy = vi.spyOn(tf.Tensor.prototype, 'dispose').mockImplementation(function (this: unknown) {
      disposed.push(this);
    });
    try {
      await enc.encode('a person walks forward');
    } finally {
      spy.mockRestore();
    }
    const dims = disposed.map((t) => (t as { dims: number[] }).dims.join('x'));
    expect(dims.filter((d) => /^1x\d+$/.test(d))).toHaveLength(3); // input_ids, attention_mask, token_type_ids
    expect(dims.some((d) => /^1x\d+x384$/.test(d))).toBe(true); // last_hidden_state
  });

  test('every prompt is cut to the same token ids as Python (manifest maxTokens, [SEP] kept)', async () => {
    const manifest = await loadManifest(MODELS);
    expect(FIXTURE.maxTokens).toBe(manifest.textEncoders['all-MiniLM-L6-v2'].maxTokens);
    for (let i = 0; i < FIXTURE.prompts.length; i++) {
      const t = await enc.tokenize!(FIXTURE.prompts[i]);
      expect(t.ids, `prompt ${i}`).toEqual(FIXTURE.ids[i]);
      expect(t.tokens, `prompt ${i}`).toBe(FIXTURE.tokens[i]);
      expect(t.truncated).toBe(FIXTURE.tokens[i] > FIXTURE.maxTokens);
      expect(t.maxTokens).toBe(FIXTURE.maxTokens);
    }
    expect(FIXTURE.tokens.some((n) => n > FIXTURE.maxTokens)).toBe(true); // the fixture exercises the cut
  });

  test('non-string input gives a clear error; the only length limit is in tokens', async () => {
    await expect(enc.encode(undefined as unknown as string)).rejects.toThrow(TextEncoderError);
    await expect(enc.encode(42 as unknown as string)).rejects.toThrow(/expects a string, got number/);
    const huge = 'a person walks forward. '.repeat(5000); // 120,000 characters
    expect(Array.from(await enc.encode(huge))).toEqual(Array.from(await enc.encode(huge + ' then jumps')));
    expect((await enc.encode('a person walks')).length).toBe(384);
  });

  test('generate() says when a prompt was cut (result.prompt)', async () => {
    const manifest = await loadManifest(MODELS);
    const name = Object.keys(manifest.models).find((k) => {
      const c = manifest.models[k].condition;
      return c.type === 'text' && c.encoder === enc.id && manifest.models[k].objective !== 'diffusion';
    });
    expect(name).toBeDefined();
    const gen = await openModel({ manifest, baseUrl: MODELS, model: name!, backend: 'wasm', threads: 1, textEncoder: enc });
    const o = { frames: 4, steps: manifest.models[name!].supportedSteps[0], guidance: 1, seed: 1 };
    const long = FIXTURE.prompts.length - 1; // 129 tokens
    const cut = await gen.generate({ ...o, condition: { type: 'text', text: FIXTURE.prompts[long] } });
    expect(cut.prompt).toEqual({ tokens: 129, maxTokens: 128, truncated: true });
    const fits = await gen.generate({ ...o, condition: { type: 'text', text: 'a person walks' } });
    expect(fits.prompt).toEqual({ tokens: 5, maxTokens: 128, truncated: false });
    expect((await gen.generate({ ...o, condition: { type: 'none' } })).prompt).toBeUndefined();
    await gen.dispose();
  });

  test('a generator encodes a prompt once: the same prompt again (a timeline window, a regenerated segment) reuses its embedding', async () => {
    const manifest = await loadManifest(MODELS);
    const name = Object.keys(manifest.models).find((k) => manifest.models[k].condition.type === 'text' && manifest.models[k].condition.encoder === enc.id)!;
    const texts: string[] = [];
    const counting = { ...enc, encode: (t: string) => (texts.push(t), enc.encode(t)) } as typeof enc;
    const gen = await openModel({ manifest, baseUrl: MODELS, model: name, backend: 'wasm', threads: 1, textEncoder: counting });
    const o = { frames: 4, steps: manifest.models[name].supportedSteps[0], guidance: 1, seed: 1 };
    const a = await gen.generate({ ...o, condition: { type: 'text', text: 'a person waves' } });
    await gen.generate({ ...o, condition: { type: 'text', text: 'a person kicks' } });
    const b = await gen.generate({ ...o, condition: { type: 'text', text: 'a person waves' } });
    expect(texts).toEqual(['a person waves', 'a person kicks']);
    expect(Array.from(b.motion.features)).toEqual(Array.from(a.motion.features));
    await gen.dispose();
  });
});

describe('loading', () => {
  test('asking twice for the same encoder shares one loaded model', async () => {
    const m = await loadManifest(MODELS);
    const again = await createTextEncoder(m, MODELS);
    expect(again).toBe(enc);
  });
  test('an unknown id names the known ones', async () => {
    await expect(createTextEncoder(await loadManifest(MODELS), MODELS, 'nope')).rejects.toThrow(/no textEncoders entry 'nope' \(known: .*all-MiniLM-L6-v2/);
  });
});
