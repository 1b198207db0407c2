// One SamplingSettings object from createGenerator's request to the sampler: every field a request gives reaches
// the loop as it was given (here `method`, which no other path sets), in-process and through resolveRequest's wire
// options, and the fields it leaves out take the model's manifest values. The TypeScript type names the fields of
// Python's `emdm.sampler` SamplingSettings dataclass (both read from their source files), and a request's
// de-normalised `known` becomes the settings' normalised known / keep / keepFromTime.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import ts from 'typescript';
import { afterAll, describe, expect, it } from 'vitest';
import { createGenerator } from '../../src/createGenerator';
import { openModel } from '../../src/openModel';
import { loadManifest } from '../../src/manifest';
import { type MotionRequest, resolveRequest } from '../../src/requests';
import { inpaintingSettings, methodOf } from '../../src/sampler/settings';
import { tinyModels } from './coreFixtures';

const ROOT = path.resolve(__dirname, '../..');
/** Python's model shapes and root normalisation, which TypeScript's sampler takes as SampleOptions' fields (from the manifest and meanstd, not a request). */
const SHAPES = ['featureDim', 'zDim', 'rootNorm'];

/** The fields of a Python dataclass, in order, read from its source: the annotated names of the class body before its first method. */
function dataclassFields(source: string, cls: string, where: string): string[] {
  const at = source.search(new RegExp(`^@dataclass\\b.*\\n^class ${cls}\\b[^\\n]*:\\n`, 'm'));
  if (at < 0) throw new Error(`${where}: no @dataclass class ${cls}`);
  const rest = source.slice(at).split('\n').slice(2).join('\n');
  const body = rest.slice(0, rest.search(/^\S/m) >= 0 ? rest.search(/^\S/m) : undefined).replace(/("""|''')[\s\S]*?\1/g, '');
  const fields: string[] = [];
  for (const line of body.split('\n')) {
    if (/^ {4}(def |@)/.test(line)) break;
    const m = /^ {4}([A-Za-z_]\w*)\s*:(?!=)/.exec(line);
    if (m && !/:\s*ClassVar\b/.test(line)) fields.push(m[1]);
  }
  if (!fields.length) throw new Error(`${where}: class ${cls} declares no fields`);
  return fields;
}

/** The property names of a TypeScript interface, read from its source with the compiler's parser. */
function interfaceFields(file: string, name: string): string[] {
  const sf = ts.createSourceFile(file, fs.readFileSync(path.join(ROOT, file), 'utf8'), ts.ScriptTarget.ES2022, true);
  const decl = sf.statements.find((s): s is ts.InterfaceDeclaration => ts.isInterfaceDeclaration(s) && s.name.text === name);
  if (!decl) throw new Error(`${file}: no interface ${name}`);
  return decl.members.filter(ts.isPropertySignature).map((m) => m.name.getText(sf));
}

const camel = (snake: string) => snake.replace(/_([a-z0-9])/g, (_, c: string) => c.toUpperCase());

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-settings-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));
const same = (a: Float32Array, b: Float32Array) => Buffer.from(a.buffer, a.byteOffset, a.byteLength).equals(Buffer.from(b.buffer, b.byteOffset, b.byteLength));

describe('SamplingSettings', () => {
  it('resolveRequest carries the request\'s settings and fills steps and guidance from the manifest', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const given = resolveRequest(manifest, { model: 'tiny', action: 1, method: 'ddim', steps: 2, guidance: 1.5, guidanceMinTime: 0.3, x0Smoothing: 1, seed: 3 }).options;
    expect(given).toMatchObject({ method: 'ddim', steps: 2, guidance: 1.5, guidanceMinTime: 0.3, x0Smoothing: 1 });
    const plain = resolveRequest(manifest, { model: 'tiny', action: 1, seed: 3 }).options;
    expect(plain).toMatchObject({ steps: manifest.models.tiny.defaultSteps, guidance: manifest.models.tiny.guidance });
    expect('method' in plain || 'guidanceMinTime' in plain || 'x0Smoothing' in plain).toBe(false);
  });

  it('a method given to createGenerator\'s generate is the one the sampler runs', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const g = await createGenerator({ manifest, baseUrl: dir, backend: 'wasm', worker: false, threads: 1 });
    const req = { model: 'tiny', action: 1, frames: 24, steps: 2, guidance: 2.5, seed: 9 };
    const byDefault = await g.generate(req);
    const byDdim = await g.generate({ ...req, method: 'ddim' });
    // the same file declared as a diffusion model samples with DDIM by default: the same motion, bit for bit
    const ddimModel = await openModel({ manifest, baseUrl: dir, model: 'tiny-ddim', backend: 'wasm', threads: 1 });
    const reference = await ddimModel.generate({ condition: { type: 'action', label: 1 }, frames: 24, steps: 2, guidance: 2.5, seed: 9 });
    expect(reference.sampler).toBe('ddim');
    expect(same(byDdim.features, reference.motion.features)).toBe(true);
    expect(same(byDefault.features, byDdim.features)).toBe(false);
    await Promise.all([g.dispose(), ddimModel.dispose()]);
  });

  it('names the same fields as Python\'s emdm.sampler SamplingSettings (the model\'s shapes: SampleOptions\')', () => {
    const python = dataclassFields(fs.readFileSync(path.join(ROOT, 'scripts/emdm/sampler/settings.py'), 'utf8'), 'SamplingSettings', 'scripts/emdm/sampler/settings.py').map(camel);
    const typescript = interfaceFields('src/sampler/settings.ts', 'SamplingSettings');
    expect(python).toEqual(expect.arrayContaining(SHAPES));
    expect([...typescript].sort()).toEqual(python.filter((f) => !SHAPES.includes(f)).sort());
    expect(interfaceFields('src/sampler/sampler.ts', 'SampleOptions')).toEqual(expect.arrayContaining(SHAPES));
  });

  it('reads a dataclass\'s fields, not its docstring, methods or class variables, and says when there are none', () => {
    const src = 'import x\n\n@dataclass(frozen=True)\nclass S:\n    """Doc.\n    method: not a field\n    """\n    method: str = "a"\n    k: ClassVar[int] = 1\n'
      + '    keep_from_time: float = 1.0\n\n    def check(self) -> None:\n        x: int = 1\n\n\nclass T:\n    y: int = 0\n';
    expect(dataclassFields(src, 'S', 's.py').map(camel)).toEqual(['method', 'keepFromTime']);
    expect(() => dataclassFields(src, 'T', 's.py')).toThrow(/s\.py: no @dataclass class T/);
    expect(() => dataclassFields('@dataclass\nclass U:\n    pass\n', 'U', 'u.py')).toThrow(/u\.py: class U declares no fields/);
  });

  it('a request\'s known motion becomes the settings\' normalised known, keep and keepFromTime', () => {
    const mean = Float32Array.of(1, -2);
    const std = Float32Array.of(2, 0.5);
    const keep = Float32Array.of(1, 0, 1, 1);
    const got = inpaintingSettings({ features: Float32Array.of(3, 0, -1, -2.5), keep, fromTime: 0.55 }, mean, std);
    expect(Array.from(got.known!)).toEqual([1, 4, -1, -1]);
    expect(got.keep).toBe(keep);
    expect(got.keepFromTime).toBe(0.55);
    expect(inpaintingSettings({ keep }, mean, std)).toEqual({ keep, keepFromTime: undefined }); // a begin that stops before it is imposed
    expect(inpaintingSettings(undefined, mean, std)).toEqual({});
    // the two `known`s never meet in one type: `npx tsc --noEmit` fails if a request ever took the sampler's array
    // @ts-expect-error a request's known is a de-normalised KnownMotion, not SamplingSettings' normalised features
    const wrong: MotionRequest = { known: got.known };
    expect(wrong.known).toBe(got.known);
  });

  it('a model\'s objective names its update rule as Python\'s method_of does (absent: ddgan)', () => {
    expect([methodOf('ddgan'), methodOf('diffusion'), methodOf(undefined)]).toEqual(['ddgan', 'ddim', 'ddgan']);
  });
});
