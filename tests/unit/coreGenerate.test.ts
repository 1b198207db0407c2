// openModel end to end in Node (ORT-web WASM): on a temporary models folder holding the
// tiny step model, and on the shipped models (parity with the Python fixtures) when present.
import crypto from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { openModel } from '../../src/openModel';
import { NonFiniteMotionError } from '../../src/index';
import { assertFinite } from '../../src/errors';
import { ModelFileError, loadManifest, validateManifest } from '../../src/manifest';
import { getSession } from '../../src/runtime/ort';
import { stepFunction } from '../../src/runtime/stepModel';
import { MODELS_DIR, fixtureExists, fixtureNoise, loadCase, maxAbsDiff, maxJointDist, tinyModels } from './coreFixtures';

const sha = (b: Buffer) => crypto.createHash('sha256').update(b).digest('hex');
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-gen-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));


describe('openModel on the tiny model', () => {
  it('generates a motion with timings; same seed is bit-identical; progress per step', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const downloads: number[] = [];
    const gen = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1, onDownload: (l) => downloads.push(l) });
    expect(gen.backend).toBe('wasm');
    expect(downloads.at(-1)).toBe(manifest.files['tiny.onnx'].bytes + manifest.files['tiny.meanstd.f32'].bytes);
    const steps: number[] = [];
    const o = { condition: { type: 'action' as const, label: 2 }, frames: 30, steps: 4, guidance: 2.5, seed: 123, onStep: (d: number) => steps.push(d) };
    const a = await gen.generate(o);
    const b = await gen.generate({ ...o, onStep: undefined });
    expect(steps).toEqual([1, 2, 3, 4]);
    expect(a.motion.frames).toBe(30);
    expect(a.motion.fps).toBe(20);
    expect(a.motion.joints.length).toBe(30 * 22 * 3);
    expect(a.motion.features.length).toBe(30 * 263);
    expect(a.modelCalls).toBe(4);
    expect(a.timings.stepMs).toHaveLength(4);
    expect(a.timings.totalMs).toBeGreaterThan(0);
    expect(Buffer.from(a.motion.joints.buffer).equals(Buffer.from(b.motion.joints.buffer))).toBe(true);
    const c = await gen.generate({ ...o, seed: 124 });
    expect(maxAbsDiff(a.motion.features, c.motion.features)).toBeGreaterThan(1e-3);
    await gen.dispose();
  });

  it('guides only above the manifest entry\'s guidanceMinTime; a request overrides it; absent = every step', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const interval = structuredClone(manifest);
    interval.models.tiny.guidanceMinTime = 0.6;
    const plain = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const gen = await openModel({ manifest: interval, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const o = { condition: { type: 'action' as const, label: 2 }, frames: 30, steps: 4, guidance: 2.5, seed: 5 };
    const full = await plain.generate(o);
    const byEntry = await gen.generate(o);
    const byRequest = await plain.generate({ ...o, guidanceMinTime: 0.6 });
    expect([full.guidedSteps, byEntry.guidedSteps, byRequest.guidedSteps]).toEqual([4, 2, 2]); // t = 1, 0.75 > 0.6
    expect(Buffer.from(byEntry.motion.features.buffer).equals(Buffer.from(byRequest.motion.features.buffer))).toBe(true);
    expect(maxAbsDiff(full.motion.features, byEntry.motion.features)).toBeGreaterThan(1e-6);
    const overridden = await gen.generate({ ...o, guidanceMinTime: 0 });
    expect(Buffer.from(overridden.motion.features.buffer).equals(Buffer.from(full.motion.features.buffer))).toBe(true);
    await expect(gen.generate({ ...o, guidanceMinTime: -1 })).rejects.toThrow(/guidanceMinTime must be a finite time ≥ 0/);
    const bad = structuredClone(manifest) as unknown as { models: Record<string, Record<string, unknown>> };
    bad.models.tiny.guidanceMinTime = 'high';
    expect(() => validateManifest(bad)).toThrow(/models\.tiny\.guidanceMinTime' is "high"; it must be a time ≥ 0/);
    await plain.dispose();
    await gen.dispose();
  });

  it('smooths x̂0 by the manifest entry\'s x0Smoothing; a request overrides it; absent = off', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const smoothed = structuredClone(manifest);
    smoothed.models.tiny.x0Smoothing = 1;
    const plain = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const gen = await openModel({ manifest: smoothed, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const o = { condition: { type: 'action' as const, label: 2 }, frames: 30, steps: 4, guidance: 2.5, seed: 5 };
    const off = await plain.generate(o);
    const byEntry = await gen.generate(o);
    const byRequest = await plain.generate({ ...o, x0Smoothing: 1 });
    expect(Buffer.from(byEntry.motion.features.buffer).equals(Buffer.from(byRequest.motion.features.buffer))).toBe(true);
    expect(maxAbsDiff(off.motion.features, byEntry.motion.features)).toBeGreaterThan(1e-4);
    const overridden = await gen.generate({ ...o, x0Smoothing: 0 });
    expect(Buffer.from(overridden.motion.features.buffer).equals(Buffer.from(off.motion.features.buffer))).toBe(true);
    await expect(gen.generate({ ...o, x0Smoothing: -1 })).rejects.toThrow(/x0Smoothing must be a finite σ ≥ 0 in frames/);
    for (const v of ['high', -1]) {
      const bad = structuredClone(manifest) as unknown as { models: Record<string, Record<string, unknown>> };
      bad.models.tiny.x0Smoothing = v;
      expect(() => validateManifest(bad)).toThrow(new RegExp(`models\\.tiny\\.x0Smoothing' is ${JSON.stringify(v)}; it must be a σ ≥ 0 in frames`));
    }
    await plain.dispose();
    await gen.dispose();
  });

  it('rejects bad requests with clear errors', async () => {
    const { dir, manifest } = tinyModels(tmp);
    const gen = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const o = { condition: { type: 'none' as const }, frames: 30, steps: 4, guidance: 1, seed: 1 };
    await expect(gen.generate({ ...o, steps: 3 })).rejects.toThrow(/3 steps not supported \(supportedSteps = \[2, 4\]\)/);
    await expect(gen.generate({ ...o, frames: 197 })).rejects.toThrow(/frames must be an integer in 1…196/);
    await expect(gen.generate({ ...o, condition: { type: 'action', label: 8 } })).rejects.toThrow(/action label 8 out of range 0…7/);
    await expect(gen.generate({ ...o, condition: { type: 'text', text: 'walk' } })).rejects.toThrow(/is a action model; it takes no text prompt/);
    await expect(gen.generate({ ...o, seed: -3 })).rejects.toThrow(/seed must be an integer/);
    const ctrl = new AbortController();
    ctrl.abort();
    await expect(gen.generate({ ...o, signal: ctrl.signal })).rejects.toThrow(/cancelled after 0 of 4 steps/);
    await gen.dispose();
  });

  it('refuses a corrupt or missing model file, naming it', async () => {
    const { dir, manifest } = tinyModels(tmp);
    fs.writeFileSync(path.join(dir, 'tiny.onnx'), Buffer.from('not a model'));
    await expect(openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 })).rejects.toThrow(ModelFileError);
    await expect(openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 })).rejects.toThrow(/tiny\.onnx: size 11 bytes differs/);
    fs.rmSync(path.join(dir, 'tiny.onnx'));
    await expect(openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 })).rejects.toThrow(/tiny\.onnx: not found/);
    await expect(openModel({ manifest, baseUrl: dir, model: 'nope', backend: 'wasm', threads: 1 })).rejects.toThrow(/models\.nope' not found \(models: tiny, tiny-ddim\)/);
  });

  it('refuses NaN from the model with NonFiniteMotionError (exported by the library); the generator keeps working', async () => {
    // x0 = x_t * NaN (onnx.helper, opset 18): a valid step model whose every output is NaN
    const nanModel = Buffer.from(
      'CAgSCGVtZG0tZTJlOsUBChMKA3hfdAoDbmFuEgJ4MCIDTXVsEghuYW5fc3RlcCoNEAEiBAAAwH9CA25hblocCgN4X3QSFQoTCAESDwoDEgFCCgMSAUwKAwiHAloUCgF6Eg8KDQgBEgkKAxIBQgoCCEBaGAoEY29uZBIQCg4IARIKCgMSAUIKAxIBQ1oQCgF0EgsKCQgBEgUKAxIBQloYCgRtYXNrEhAKDggBEgoKAxIBQgoDEgFMYhsKAngwEhUKEwgBEg8KAxIBQgoDEgFMCgMIhwJCBAoAEBI=',
      'base64',
    );
    const { dir, manifest } = tinyModels(tmp);
    const m = structuredClone(manifest);
    fs.writeFileSync(path.join(dir, 'nan.onnx'), nanModel);
    m.files['nan.onnx'] = { bytes: nanModel.length, sha256: sha(nanModel) };
    m.models.tiny.variants = { nan: 'nan.onnx' };
    const o = { condition: { type: 'action' as const, label: 1 }, frames: 10, steps: 2, guidance: 2.5, seed: 3 };
    const bad = await openModel({ manifest: m, baseUrl: dir, model: 'tiny', variant: 'nan', backend: 'wasm', threads: 1 });
    const err = await bad.generate(o).catch((e: unknown) => e);
    expect(err).toBeInstanceOf(NonFiniteMotionError);
    expect(err).toMatchObject({ name: 'NonFiniteMotionError', index: 0, count: 10 * 263 });
    expect((err as Error).message).toMatch(/^model tiny \(nan\.onnx\) output features: non-finite numbers \(value 0 of 2630 is NaN\)/);
    await bad.dispose();
    const good = await openModel({ manifest: m, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    expect((await good.generate(o)).motion.joints.every(Number.isFinite)).toBe(true);
    await good.dispose();
    expect(() => assertFinite(Float32Array.of(0, 1, Infinity), 'x')).toThrow(/^x: non-finite numbers \(value 2 of 3 is Infinity\)/);
  });

  it('refuses a model whose shapes do not match the manifest (incompatible)', async () => {
    const { dir, manifest } = tinyModels(tmp);
    const bad = structuredClone(manifest);
    bad.models.tiny.condition = { type: 'action', labels: ['a', 'b'], dim: 2 };
    await expect(openModel({ manifest: bad, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 })).rejects.toMatchObject({
      name: 'ModelFileError', reason: 'incompatible', path: 'tiny.onnx',
    });
  });
});

describe('openModel on a diffusion-objective model (DDIM)', () => {
  it('samples with DDIM and says so; a fixture run equals emdm.sampler.sample_features (method "ddim")', async () => {
    const { dir } = tinyModels(tmp);
    const manifest = await loadManifest(dir);
    const ddim = await openModel({ manifest, baseUrl: dir, model: 'tiny-ddim', backend: 'wasm', threads: 1 });
    const ddgan = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    expect(ddim.sampler).toBe('ddim');
    expect(ddgan.sampler).toBe('ddgan');
    const fx = loadCase('tiny-ddim');
    const L = fx.meta.frames;
    const r = await ddim.generate({ condition: { type: 'vector', vector: fx.get('cond') }, frames: L, steps: fx.meta.steps as number, guidance: 2.5, seed: 0, noise: fixtureNoise(fx) });
    expect(r.sampler).toBe('ddim');
    expect(r.steps).toBe(5);
    expect(r.modelCalls).toBe(5);
    expect(r.timings.stepMs).toHaveLength(5);
    // tiny.meanstd.f32: mean 0 except mean[3] = 0.9, std 1 → features = x + mean
    const want = fx.get('final_x');
    for (let f = 0; f < L; f++) want[f * 263 + 3] += 0.9;
    expect(maxAbsDiff(r.motion.features, want)).toBeLessThan(1e-4);
    // the same request on the DDGAN declaration of the same file is another motion
    const o = { condition: { type: 'action' as const, label: 1 }, frames: 24, steps: 2, guidance: 2.5, seed: 9 };
    const a = await ddim.generate(o);
    const b = await ddgan.generate(o);
    expect(b.sampler).toBe('ddgan');
    expect(maxAbsDiff(a.motion.features, b.motion.features)).toBeGreaterThan(1e-3);
    // deterministic: same seed, same motion
    const a2 = await ddim.generate(o);
    expect(Buffer.from(a.motion.joints.buffer).equals(Buffer.from(a2.motion.joints.buffer))).toBe(true);
    await expect(ddim.generate({ ...o, steps: 4 })).rejects.toThrow(/tiny-ddim: 4 steps not supported \(supportedSteps = \[1, 2, 5, 10\]\)/);
    await ddim.dispose();
    await ddgan.dispose();
  });

  it('refuses an unknown objective, naming the field', async () => {
    const { dir, manifest } = tinyModels(tmp);
    const bad = structuredClone(manifest);
    (bad.models.tiny as { objective: string }).objective = 'flow';
    await expect(openModel({ manifest: bad, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 })).rejects.toThrow(
      /models\.tiny\.objective' is "flow"; expected "ddgan" .* or "diffusion" \(sampled with DDIM\)/,
    );
  });
});

describe('parity with Python on the shipped models', () => {
  const manifestPath = path.join(MODELS_DIR, 'manifest.json');
  const models = fs.existsSync(manifestPath) ? Object.keys(JSON.parse(fs.readFileSync(manifestPath, 'utf8')).models ?? {}) : [];
  if (!models.length) it.skip('no shipped models in public/models/manifest.json yet', () => {});
  for (const name of models) {
    it(`${name}: one step and a whole run equal Python within 1e-4 (features) and 1 mm (joints)`, async () => {
      // a shipped model without an up-to-date fixture is a failure, not a skip: regenerate them
      expect(fixtureExists(`model-${name}`), `tests/fixtures/parity/model-${name}.json absent: run \`.venv/bin/python -m emdm.fixtures\``).toBe(true);
      const fx = loadCase(`model-${name}`);
      const manifest = await loadManifest(MODELS_DIR + '/');
      const entry = manifest.models[name];
      expect(fx.meta.sha256, `fixture model-${name} was made from another ${entry.onnx}: re-run \`.venv/bin/python -m emdm.fixtures\``).toBe(manifest.files[entry.onnx].sha256);
      // the run below takes the entry's guidanceMinTime (guidance in a limited interval) as the fixture did
      expect(fx.meta.guidanceMinTime ?? 0, `fixture model-${name} was sampled with another guidanceMinTime: re-run \`.venv/bin/python -m emdm.fixtures --only models\``).toBe(entry.guidanceMinTime ?? 0);
      // …and its x0Smoothing (x̂0 smoothed along time)
      expect(fx.meta.x0Smoothing ?? 0, `fixture model-${name} was sampled with another x0Smoothing: re-run \`.venv/bin/python -m emdm.fixtures --only models\``).toBe(entry.x0Smoothing ?? 0);
      // …and its speedCap (the root held to the first step's speed)
      expect(fx.meta.speedCap ?? 0, `fixture model-${name} was sampled with another speedCap: re-run \`.venv/bin/python -m emdm.fixtures --only models\``).toBe(entry.speedCap ?? 0);
      const L = fx.meta.frames;
      // one step (x_t, z, c, t → x0̂)
      const bytes = fs.readFileSync(path.join(MODELS_DIR, entry.onnx));
      const session = await getSession(`${entry.onnx}#${fx.meta.sha256}`, bytes, 'wasm', { threads: 1 });
      const step = stepFunction(session, { featureDim: entry.featureDim, zDim: entry.zDim, condDim: entry.condition.dim }, entry.onnx);
      const x0 = await step({
        x: fx.get('step_x_t'), z: fx.get('step_z'), cond: fx.get('step_cond'), t: fx.get('step_t'), mask: new Float32Array(L).fill(1), batch: 1, frames: L,
      });
      expect(maxAbsDiff(x0, fx.get('step_x0'))).toBeLessThan(1e-4);
      await session.release();
      const gen = await openModel({ manifest, baseUrl: MODELS_DIR + '/', model: name, backend: 'wasm', threads: 1 });
      // whole run with the fixture's noise and condition vector
      const r = await gen.generate({
        condition: { type: 'vector', vector: fx.get('cond') }, frames: L, steps: fx.meta.steps as number, guidance: fx.meta.guidance as number,
        seed: 0, noise: fixtureNoise(fx),
      });
      expect(r.sampler).toBe(entry.objective === 'diffusion' ? 'ddim' : 'ddgan');
      if (fx.meta.sampler !== undefined) expect(r.sampler, `fixture model-${name} was sampled with ${fx.meta.sampler}`).toBe(fx.meta.sampler);
      expect(maxAbsDiff(r.motion.features, fx.get('features'))).toBeLessThan(1e-4);
      expect(maxJointDist(r.motion.joints, fx.get('joints'))).toBeLessThan(1e-3);
      await gen.dispose();
    });
  }
});
