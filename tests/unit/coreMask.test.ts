// Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"): the keep mask against Python's (the
// tiny-mask parity fixture of `python -m emdm.motion.mask_fixture`), the sampler's masked runs against
// Python's sample_features(known, keep) with the same noise, and generate()'s `known` option.
import crypto from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, beforeAll, describe, expect, it } from 'vitest';
import { openModel } from '../../src/openModel';
import type { Manifest } from '../../src/manifest';
import { getSession } from '../../src/runtime/ort';
import { stepFunction } from '../../src/runtime/stepModel';
import { FEATURE_GROUPS, KeepSpecError, groupChannels, keepMask, parseKeep } from '../../src/sampler/mask';
import { sample, type StepFn } from '../../src/sampler/sampler';
import { computeSchedule } from '../../src/sampler/schedule';
import { SeededRandom } from '../../src/sampler/rng';
import { buildTinyManifest } from '../fixtures/parity/tinyManifest';
import { PARITY_DIR, type FixtureCase, fixtureNoise, loadCase, manifestSkeleton, maxAbsDiff } from './coreFixtures';

const fx = loadCase('tiny-mask');
const meta = fx.meta as unknown as {
  frames: number; condDim: number; guidance: number; specs: string[];
  groups: Record<string, number[]>; runs: Record<'ddgan' | 'ddim', { prefix: string; steps: number }>;
};
const L = meta.frames;
const D = 263;

async function tinyStep(): Promise<StepFn> {
  const bytes = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const session = await getSession('tests/fixtures/parity/tiny-step.onnx', bytes, 'wasm', { threads: 1 });
  return stepFunction(session, { featureDim: D, zDim: 64, condDim: meta.condDim }, 'tiny-step.onnx');
}

/** The fixture's arrays of one run (keys with the run's prefix). */
const runCase = (prefix: string): FixtureCase => ({ ...fx, get: (k) => fx.get(prefix + k) });

describe('keep mask', () => {
  it("computes each group's channels as Python does (tiny-mask fixture); the groups split the 263 channels", () => {
    expect([...FEATURE_GROUPS]).toEqual(Object.keys(meta.groups));
    for (const g of FEATURE_GROUPS) expect(groupChannels(g)).toEqual(meta.groups[g]);
    const all = FEATURE_GROUPS.flatMap((g) => groupChannels(g)).sort((a, b) => a - b);
    expect(all).toEqual(Array.from({ length: D }, (_, i) => i));
  });

  it("builds the fixture's mask from the same specs", () => {
    const m = keepMask(L, meta.specs.map(parseKeep));
    expect(maxAbsDiff(m, fx.get('keep'))).toBe(0);
    expect(meta.specs).toEqual(['frames:0-5', 'group:legs']);
    // rows 0..5 whole, then the legs only
    expect(m.subarray(0, 6 * D).every((v) => v === 1)).toBe(true);
    const row7 = m.subarray(7 * D, 8 * D);
    expect([...row7].reduce((a, b) => a + b, 0)).toBe(groupChannels('legs').length);
  });

  it('parses specs: ranges A-B, A, A- and intersections with /', () => {
    expect(parseKeep('frames:0-2,8-/group:root,upper')).toEqual({ frames: [[0, 2], [8, null]], groups: ['root', 'upper'] });
    expect(parseKeep('group:legs/frames:4')).toEqual({ groups: ['legs'], frames: [[4, 4]] });
    const m = keepMask(10, [parseKeep('frames:8-')]);
    expect(m.subarray(0, 8 * D).some((v) => v !== 0)).toBe(false);
    expect(m.subarray(8 * D).every((v) => v === 1)).toBe(true);
  });

  it.each([
    ['', /empty/], ['legs', /must be frames:RANGES or group:NAMES/], ['group:arms', /unknown group "arms"; groups: root, legs, upper/],
    ['frames:5-2', /ends before it starts/], ['frames:a-3', /must be A-B/], ['frames:1,,3', /empty entry/], ['frames:1/frames:2', /given twice/],
  ])('refuses the spec %j with a one-line message', (spec, msg) => {
    expect(() => parseKeep(spec)).toThrow(KeepSpecError);
    expect(() => parseKeep(spec)).toThrow(msg);
  });

  it('refuses a range past the motion', () => {
    expect(() => keepMask(10, [{ frames: [[5, 10]] }])).toThrow(/frame range 5-10 goes past the motion's last frame 9/);
    expect(() => keepMask(10, [{ frames: [[12, null]] }])).toThrow(/12- goes past/);
  });
});

describe('sampler with a known motion and a keep mask (tiny step model)', () => {
  const known = fx.get('known');
  const keep = fx.get('keep');

  it.each([['ddgan'], ['ddim']] as const)('%s: equals Python sample_features(known, keep) within 1e-4, and the known motion exactly where kept', async (name) => {
    const run = meta.runs[name];
    const step = await tinyStep();
    const noise = fixtureNoise(runCase(run.prefix));
    const r = await sample({
      method: name, schedule: computeSchedule(run.steps), step, noise, frames: L, featureDim: D, zDim: 64,
      cond: fx.get('cond'), guidance: meta.guidance, known, keep,
    });
    const err = maxAbsDiff(r.x, fx.get(run.prefix + 'final_x'));
    console.log(`tiny-mask ${name}: max |TS − Python| = ${err.toExponential(6)}`);
    expect(err).toBeLessThan(1e-4);
    for (let i = 0; i < keep.length; i++) if (keep[i]) expect(r.x[i]).toBe(known[i]);
    expect(r.modelCalls).toBe(run.steps); // both guidance halves in one call per step
  });

  it('the model input carries the known motion noised to its level (both guidance halves)', async () => {
    const step = await tinyStep();
    const schedule = computeSchedule(5);
    const xT = new SeededRandom(9).normals(L * D);
    const seen: Float32Array[] = [];
    const recording: StepFn = (i) => {
      expect(i.batch).toBe(2);
      expect(maxAbsDiff(i.x.subarray(0, L * D), i.x.subarray(L * D))).toBe(0);
      seen.push(Float32Array.from(i.x.subarray(0, L * D)));
      return step(i);
    };
    await sample({ method: 'ddim', schedule, step: recording, noise: new SeededRandom(9), frames: L, featureDim: D, zDim: 64, cond: fx.get('cond'), guidance: 2.5, known, keep });
    // DDIM keeps the noise of the kept part: (x_in − aCum[k+1]·known) / sCum[k+1] = x_T's noise at every step
    seen.forEach((x, i) => {
      const k = schedule.steps - 1 - i;
      let m = 0;
      for (let j = 0; j < x.length; j++) {
        if (keep[j]) m = Math.max(m, Math.abs((x[j] - schedule.aCum[k + 1] * known[j]) / schedule.sCum[k + 1] - xT[j]));
      }
      expect(m).toBeLessThan(2e-3);
    });
  });

  it('the kept part steers the free part (same noise, with and without keep)', async () => {
    const step = await tinyStep();
    const base = { method: 'ddgan' as const, schedule: computeSchedule(4), step, frames: L, featureDim: D, zDim: 64, cond: fx.get('cond'), guidance: 2.5 };
    const a = await sample({ ...base, noise: fixtureNoise(runCase('')) });
    const b = await sample({ ...base, noise: fixtureNoise(runCase('')), known, keep });
    let free = 0;
    let n = 0;
    for (let i = 0; i < keep.length; i++) if (!keep[i]) (free += Math.abs(b.x[i] - a.x[i])), n++;
    expect(free / n).toBeGreaterThan(1e-3);
  });

  it('keepFromTime: the kept part imposed only at steps with t ≤ it and at the last, its whole-kept leading frames sitting out the others; 1 = every step, bit for bit', async () => {
    const step = await tinyStep();
    const schedule = computeSchedule(4); // t = 1, 0.75, 0.5, 0.25 (about)
    const base = { method: 'ddgan' as const, schedule, step, frames: L, featureDim: D, zDim: 64, cond: fx.get('cond'), guidance: 2.5, known, keep };
    const run = async (keepFromTime?: number) => {
      const x0s: Float32Array[] = [];
      const r = await sample({ ...base, noise: fixtureNoise(runCase('')), onX0: (x0) => x0s.push(x0), ...(keepFromTime === undefined ? {} : { keepFromTime }) });
      return { x: r.x, x0s };
    };
    const every = await run();
    expect(maxAbsDiff((await run(1)).x, every.x)).toBe(0);
    const late = await run(0.6);
    const keptEqual = (x: Float32Array) => keep.every((k, i) => !k || x[i] === known[i]);
    expect(late.x0s.map(keptEqual)).toEqual([false, false, true, true]); // t = 1 and 0.75 are the model's own
    expect(every.x0s.map(keptEqual)).toEqual([true, true, true, true]);
    expect(keptEqual(late.x)).toBe(true); // the result keeps them exactly
    expect(maxAbsDiff(late.x, every.x)).toBeGreaterThan(1e-3); // and the free part differs
    expect(keptEqual((await run(0)).x)).toBe(true); // 0: only the last step
    // the whole-kept leading frames (0…5) sit out the free steps: the model sees frames 6… alone, as with 0, and they
    // join at t = 0.5 as the known motion noised to its level from their x_T draw (Python's test, the same numbers)
    const seen = async (keepFromTime: number) => {
      const xs: Float32Array[] = [];
      const rec: StepFn = async (i) => (xs.push(i.x.slice(0, i.frames * D)), step(i));
      await sample({ ...base, step: rec, noise: fixtureNoise(runCase('')), keepFromTime });
      return xs;
    };
    const [lateIn, freeIn] = [await seen(0.6), await seen(0)];
    expect(lateIn.map((x) => x.length / D)).toEqual([10, 10, 16, 16]);
    expect(freeIn.map((x) => x.length / D)).toEqual([10, 10, 10, 16]);
    for (const k of [0, 1]) expect(maxAbsDiff(lateIn[k], freeIn[k])).toBe(0);
    expect(maxAbsDiff(lateIn[2].subarray(6 * D), freeIn[2])).toBe(0);
    const xT = runCase('').get('x_T');
    const joined = known.subarray(0, 6 * D).map((v, i) => Math.fround(Math.fround(Math.fround(schedule.aCum[2]) * v) + Math.fround(Math.fround(schedule.sCum[2]) * xT[i])));
    expect(maxAbsDiff(lateIn[2].subarray(0, 6 * D), joined)).toBe(0);
    const none: StepFn = async () => new Float32Array(L * D);
    await expect(sample({ ...base, step: none, noise: new SeededRandom(1), keepFromTime: Number.NaN })).rejects.toThrow(/keepFromTime must be a finite time ≥ 0/);
  });

  it('refuses half a constraint, a wrong size, a soft mask and NaN where kept', async () => {
    const step: StepFn = async () => new Float32Array(L * D);
    const base = { schedule: computeSchedule(2), step, noise: new SeededRandom(1), frames: L, featureDim: D, zDim: 64, cond: new Float32Array(8), guidance: 1 };
    await expect(sample({ ...base, known })).rejects.toThrow(/needs both known .* and keep/);
    await expect(sample({ ...base, known, keep: keep.subarray(D) })).rejects.toThrow(/keep \(frames 16 × 263\) has 3945 values, expected 4208/);
    await expect(sample({ ...base, known, keep: new Float32Array(L * D).fill(0.5) })).rejects.toThrow(/keep\[0\] is 0.5; the mask holds only 0 and 1/);
    const bad = Float32Array.from(known);
    bad[3 * D + 7] = NaN;
    await expect(sample({ ...base, known: bad, keep })).rejects.toThrow(/known is NaN at frame 3, channel 7/);
  });
});

describe('generate() with known features', () => {
  let dir = '';
  let manifest: Manifest;
  beforeAll(() => {
    dir = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-mask-'));
    const file = (name: string, src: string) => {
      const bytes = fs.readFileSync(path.join(PARITY_DIR, src));
      fs.writeFileSync(path.join(dir, name), bytes);
      return { path: name, bytes: bytes.length, sha256: crypto.createHash('sha256').update(bytes).digest('hex') };
    };
    manifest = buildTinyManifest(manifestSkeleton() as unknown as Manifest['skeleton'], file('tiny.onnx', 'tiny-step.onnx'), file('tiny.meanstd.f32', 'tiny.meanstd.f32'));
  });
  afterAll(() => fs.rmSync(dir, { recursive: true, force: true }));

  it('keeps the given de-normalised features where keep = 1; kept frames decode to the same joints, also after a free stretch', async () => {
    const gen = await openModel({ manifest, baseUrl: dir + '/', model: 'tiny', backend: 'wasm', threads: 1 });
    try {
      const first = await gen.generate({ condition: { type: 'action', label: 1 }, frames: L, steps: 4, guidance: 2.5, seed: 3 });
      const keep = keepMask(L, [parseKeep('frames:0-5,12-15'), parseKeep('group:legs')]);
      const again = await gen.generate({ condition: { type: 'action', label: 5 }, frames: L, steps: 4, guidance: 2.5, seed: 4, known: { features: first.motion.features, keep } });
      let worst = 0;
      let free = 0;
      for (let i = 0; i < keep.length; i++) {
        const d = Math.abs(again.motion.features[i] - first.motion.features[i]);
        if (keep[i]) worst = Math.max(worst, d / Math.max(1, Math.abs(first.motion.features[i])));
        else free = Math.max(free, d);
      }
      expect(worst).toBeLessThan(1e-6);
      expect(free).toBeGreaterThan(1e-2);
      const J3 = 66;
      expect(maxAbsDiff(again.motion.joints.subarray(0, 6 * J3), first.motion.joints.subarray(0, 6 * J3))).toBeLessThan(1e-5);
      expect(maxAbsDiff(again.motion.joints.subarray(12 * J3), first.motion.joints.subarray(12 * J3))).toBeLessThan(1e-3); // ≤ 1 mm
      expect(maxAbsDiff(again.motion.joints.subarray(6 * J3, 12 * J3), first.motion.joints.subarray(6 * J3, 12 * J3))).toBeGreaterThan(1e-2);
    } finally {
      await gen.dispose();
    }
  });
});
