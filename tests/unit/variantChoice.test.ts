// Which model file runs (issue 13 item 4): the manifest's chooseVariant is the one place that decides, for the
// page (web/ui/engine.ts, URL `variant`) and createGenerator; the manifest's defaultVariant is checked on load.
import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, test } from 'vitest';
import { chooseVariant, ModelFileError, stepFileOf, validateManifest, type Manifest } from '../../src/manifest';
import { pageThreads, pageVariant } from '../../web/ui/engine';

const MODELS = path.resolve(__dirname, '../../public/models');
const shipped = JSON.parse(fs.readFileSync(path.join(MODELS, 'manifest.json'), 'utf8')) as Manifest;

function withModel(entry: Record<string, unknown>): unknown {
  const m = structuredClone(shipped) as unknown as { models: Record<string, Record<string, unknown>> };
  m.models['emdm-t2m-web'] = { ...m.models['emdm-t2m-web'], ...entry };
  return m;
}

describe('chooseVariant', () => {
  test("the shipped EMDM models run int8 by default, 'fp32' their onnx file, the diffusion baseline fp32", () => {
    const m = validateManifest(shipped);
    expect(chooseVariant(m, 'emdm-t2m-web')).toBe('int8');
    expect(chooseVariant(m, 'emdm-a2m-web')).toBe('int8');
    expect(stepFileOf(m, 'emdm-t2m-web')).toBe('emdm-t2m-web.int8.onnx');
    expect(chooseVariant(m, 'emdm-t2m-web', 'fp32')).toBeUndefined();
    expect(stepFileOf(m, 'emdm-t2m-web', 'fp32')).toBe('emdm-t2m-web.onnx');
    expect(chooseVariant(m, 'emdm-t2m-web', 'fp16')).toBe('fp16');
    expect(chooseVariant(m, 'diffusion-t2m-web')).toBeUndefined(); // its int8 quality was not measured
    // the default file is a quarter of the fp32 download
    expect(m.files[stepFileOf(m, 'emdm-t2m-web')].bytes).toBeLessThan(0.3 * m.files['emdm-t2m-web.onnx'].bytes);
  });

  test('a variant the model lacks, or an unknown model, is refused naming what there is', () => {
    const m = validateManifest(shipped);
    expect(() => chooseVariant(m, 'emdm-t2m-web', 'fp8')).toThrow("model 'emdm-t2m-web' has no 'fp8' file (its variants: int8, fp16); use 'fp32' or one of those");
    expect(() => chooseVariant(m, 'nope')).toThrow(/model 'nope' is not in the manifest \(models: emdm-t2m-web, emdm-a2m-web, diffusion-t2m-web\)/);
  });

  test('validateManifest refuses a defaultVariant that names no variant of the entry', () => {
    expect(() => validateManifest(withModel({ defaultVariant: 'fp8' }))).toThrow(ModelFileError);
    expect(() => validateManifest(withModel({ defaultVariant: 'fp8' }))).toThrow("field 'models.emdm-t2m-web.defaultVariant' is \"fp8\"; it must name one of the model's variants (int8, fp16), or be absent to run the fp32 file");
    expect(() => validateManifest(withModel({ defaultVariant: 'int8', variants: undefined }))).toThrow(/must name one of the model's variants \(none\)/);
    const none = validateManifest(withModel({ defaultVariant: undefined }));
    expect(chooseVariant(none, 'emdm-t2m-web')).toBeUndefined(); // absent: fp32
  });
});

describe('the page URL flag variant', () => {
  test("absent: each model's default; fp32 or a variant every model has: that; anything else: a notice", () => {
    expect(pageVariant(shipped, '?mode=text')).toEqual({ variant: undefined, notice: '' });
    expect(pageVariant(shipped, '?variant=fp32')).toEqual({ variant: 'fp32', notice: '' });
    expect(pageVariant(shipped, '?variant=int8')).toEqual({ variant: 'int8', notice: '' });
    expect(pageVariant(shipped, '?variant=fp8')).toEqual({ variant: undefined, notice: "URL variant='fp8' is not a model file every model has (fp32, int8, fp16); each model runs its default file." });
  });
});

describe('the page URL flag threads', () => {
  test('absent: the runtime chooses; a whole number 1…16: that many WASM threads; anything else: a notice', () => {
    expect(pageThreads('?mode=text')).toEqual({ threads: undefined, notice: '' });
    expect(pageThreads('?threads=2')).toEqual({ threads: 2, notice: '' });
    expect(pageThreads('?threads=16')).toEqual({ threads: 16, notice: '' });
    for (const bad of ['0', '1.5', '17', 'many']) {
      expect(pageThreads(`?threads=${bad}`)).toEqual({ threads: undefined, notice: `URL threads='${bad}' is not a whole number 1–16; the runtime chooses the WASM thread count.` });
    }
  });
});
