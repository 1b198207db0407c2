// A run stopped (stopAt) and resumed gives the whole run bit for bit; several runs in lockstep (one model call per
// step, src/sampler/lockstep.ts) give each run's own result; a timeline window's early steps need no known motion.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { getSession } from '../../src/runtime/ort';
import { stepFunction } from '../../src/runtime/stepModel';
import { lockstep, together } from '../../src/sampler/lockstep';
import { keepMask } from '../../src/sampler/mask';
import { SeededRandom } from '../../src/sampler/rng';
import { sample, type SampleOptions, type StepFn, type StepInputs } from '../../src/sampler/sampler';
import { computeSchedule } from '../../src/sampler/schedule';
import { type EditBegin, type EditGenerate, generateTimeline } from '../../src/edit';
import { openModel, quantisesPerCall } from '../../src/openModel';
import { loadManifest } from '../../src/manifest';
import { MODELS_DIR, PARITY_DIR, loadCase, maxAbsDiff, tinyModels } from './coreFixtures';

const D = 263;
const fx = loadCase('tiny-mask');
const condDim = (fx.meta as unknown as { condDim: number }).condDim;

async function tinyStep(): Promise<StepFn> {
  const bytes = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const session = await getSession('tests/fixtures/parity/tiny-step.onnx', bytes, 'wasm', { threads: 1 });
  return stepFunction(session, { featureDim: D, zDim: 64, condDim }, 'tiny-step.onnx');
}

function window(frames: number, lead: number, seed: number): { known: Float32Array; keep: Float32Array; cond: Float32Array } {
  const r = new SeededRandom(seed);
  return { known: r.normals(frames * D), keep: keepMask(frames, [{ frames: [[0, lead - 1]] }]), cond: r.normals(condDim) };
}

describe('stopAt and resume', () => {
  it('a window stopped where its context joins and resumed with it equals one whole run, bit for bit (ddgan and ddim, restored RNG state)', async () => {
    const step = await tinyStep();
    const schedule = computeSchedule(10);
    const { known, keep, cond } = window(30, 8, 1);
    for (const method of ['ddgan', 'ddim'] as const) {
      const base: Omit<SampleOptions, 'noise'> = { method, schedule, step, frames: 30, featureDim: D, zDim: 64, cond, guidance: 2.5, guidanceMinTime: 0.55, x0Smoothing: 1, keep, keepFromTime: 0.55 };
      const whole = await sample({ ...base, known, noise: new SeededRandom(7) });
      expect(whole.next).toBeUndefined();
      const rng = new SeededRandom(7);
      const first = await sample({ ...base, noise: rng, stopAt: 0.55 }); // no known: nothing is imposed before t ≤ 0.55
      expect(first.next).toBe(4);
      expect(first.modelCalls).toBe(5);
      const rest = await sample({ ...base, known, noise: SeededRandom.fromState(rng.state()), resume: { x: first.x, next: first.next! } });
      expect(rest.modelCalls).toBe(5);
      expect(maxAbsDiff(rest.x, whole.x)).toBe(0);
    }
  });

  it('with one step (the last, which imposes the kept part) the first part runs no step and the resumed one runs it', async () => {
    const step = await tinyStep();
    const { known, keep, cond } = window(12, 4, 3);
    const base: Omit<SampleOptions, 'noise'> = { method: 'ddgan', schedule: computeSchedule(1), step, frames: 12, featureDim: D, zDim: 64, cond, guidance: 2.5, keep, keepFromTime: 0.55 };
    const whole = await sample({ ...base, known, noise: new SeededRandom(4) });
    const rng = new SeededRandom(4);
    const first = await sample({ ...base, noise: rng, stopAt: 0.55 });
    expect([first.next, first.modelCalls]).toEqual([0, 0]);
    const rest = await sample({ ...base, known, noise: SeededRandom.fromState(rng.state()), resume: { x: first.x, next: 0 } });
    expect(maxAbsDiff(rest.x, whole.x)).toBe(0);
  });

  it('says what is wrong: known missing where it is imposed, a bad resume step or state, a bad stopAt', async () => {
    const step = await tinyStep();
    const { known, keep, cond } = window(12, 4, 2);
    const base: SampleOptions = { method: 'ddgan', schedule: computeSchedule(4), step, noise: new SeededRandom(1), frames: 12, featureDim: D, zDim: 64, cond, guidance: 1, keep, keepFromTime: 0.6 };
    await expect(sample({ ...base, stopAt: 0.3 })).rejects.toThrow(/imposed at step 1 \(t = 0\.5.*known is needed/);
    await expect(sample({ ...base })).rejects.toThrow(/known is needed/);
    await expect(sample({ ...base, known, resume: { x: new Float32Array(12 * D), next: 4 } })).rejects.toThrow(/resume\.next must be a step index in 0…3, got 4/);
    await expect(sample({ ...base, known, resume: { x: new Float32Array(5), next: 1 } })).rejects.toThrow(/resume\.x has 5 values, expected 3156/);
    await expect(sample({ ...base, known, stopAt: Number.NaN })).rejects.toThrow(/stopAt must be a finite time ≥ 0/);
    expect(() => SeededRandom.fromState({ seed: 1, words: [1, 2, 3], spare: null })).toThrow(/four 32-bit integers/);
  });
});

describe('lockstep', () => {
  it("three windows' early steps in one call per step, frames padded: each gets its own rows (within 1e-5 of running alone)", async () => {
    const step = await tinyStep();
    const calls: number[][] = [];
    const counting: StepFn = (i: StepInputs) => (calls.push([i.batch, i.frames]), step(i));
    const schedule = computeSchedule(10);
    const runs = [[30, 0], [26, 8], [21, 8]].map(([frames, lead], j) => ({ frames, lead, ...window(frames, Math.max(lead, 1), 10 + j) }));
    const opts = (r: (typeof runs)[number], st: StepFn, seed: number): SampleOptions => ({
      method: 'ddgan', schedule, step: st, noise: new SeededRandom(seed), frames: r.frames, featureDim: D, zDim: 64, cond: r.cond, guidance: 2.5,
      guidanceMinTime: 0.55, x0Smoothing: 1, stopAt: 0.55, ...(r.lead ? { keep: r.keep, keepFromTime: 0.55 } : {}),
    });
    const alone = [];
    for (const [j, r] of runs.entries()) alone.push(await sample(opts(r, step, 100 + j)));
    calls.length = 0;
    const joint = await together(counting, runs.map((r, j) => (st: StepFn) => sample(opts(r, st, 100 + j))));
    // 5 guided steps, each one call of 3 × 2 rows, padded to the longest free part (30 frames; the others 18 and 13)
    expect(calls).toEqual(Array.from({ length: 5 }, () => [6, 30]));
    for (const [j, r] of joint.entries()) {
      expect(r.next).toBe(4);
      expect(maxAbsDiff(r.x, alone[j].x)).toBeLessThan(1e-5);
    }
  });

  it('a run that ends leaves the group; a run that fails fails the others instead of leaving them waiting', async () => {
    const step: StepFn = async (i) => new Float32Array(i.x.length);
    const g = lockstep(step, 2);
    const inputs = (frames: number): StepInputs => ({ x: new Float32Array(frames * D), z: new Float32Array(64), cond: new Float32Array(4), t: new Float32Array(1), mask: new Float32Array(frames).fill(1), batch: 1, frames });
    const waiting = g.steps[0](inputs(3));
    g.leave(1);
    expect((await waiting).length).toBe(3 * D);
    const h = lockstep(step, 3);
    const a = h.steps[0](inputs(2));
    h.leave(2, new Error('window 3 broke'));
    await expect(a).rejects.toThrow('window 3 broke');
    await expect(h.steps[1](inputs(2))).rejects.toThrow('window 3 broke');
  });
});

describe('begin on a model that quantises its activations per call (the shipped int8 files)', () => {
  it('runs the requests alone, so a timeline begun together is the timeline in turn, bit for bit; fp32/fp16 files batch', async () => {
    const manifest = await loadManifest(MODELS_DIR);
    const entry = manifest.models['emdm-t2m-web'];
    for (const [v, file] of Object.entries({ fp32: entry.onnx, ...entry.variants })) {
      expect(quantisesPerCall(fs.readFileSync(path.join(MODELS_DIR, file))), v).toBe(v === 'int8');
    }
    expect(quantisesPerCall(fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx')))).toBe(false);
    const g = await openModel({ manifest, baseUrl: MODELS_DIR, model: 'emdm-t2m-web', variant: 'int8', backend: 'wasm', threads: 1 });
    expect(g.batchesExactly).toBe(false);
    const calls: number[] = [];
    const vec = (seed: number) => new SeededRandom(seed).normals(384).map((v) => v * 0.05);
    const o = { steps: 4, guidance: 2.5 };
    const gen: EditGenerate = async (r) => (await g.generate({ ...o, condition: { type: 'vector', vector: vec(r.seed) }, frames: r.frames, seed: r.seed, known: r.known, resume: r.resume })).motion;
    const begin: EditBegin = (rs) => (calls.push(rs.length), g.begin(rs.map((r) => ({ ...o, condition: { type: 'vector', vector: vec(r.seed) }, frames: r.frames, seed: r.seed, stopAt: r.stopAt, ...(r.keep ? { known: { keep: r.keep, fromTime: r.keepFromTime } } : {}) }))));
    const segs = [1, 2, 3].map((seed) => ({ prompt: 'x', seconds: 1.5, seed }));
    const limits = { fps: 20, maxFrames: 196 };
    const together = await generateTimeline(segs, gen, limits, { begin });
    const inTurn = await generateTimeline(segs, gen, limits);
    expect(calls).toEqual([3]);
    expect(maxAbsDiff(together.features, inTurn.features)).toBe(0);
    // a finished window counts its begun steps too: the page's "Model calls" of a timeline begun together
    const one = { ...o, condition: { type: 'vector' as const, vector: vec(1) }, frames: 30, seed: 1 };
    const [state] = await g.begin([{ ...one, stopAt: 0.55 }]);
    expect(state.modelCalls).toBeGreaterThan(0);
    const [plain, resumed] = [await g.generate(one), await g.generate({ ...one, resume: state })];
    expect([resumed.modelCalls, resumed.guidedSteps]).toEqual([plain.modelCalls, plain.guidedSteps]);
    expect(plain.modelCalls).toBe(4);
    await g.dispose();
  });
});

describe('begin and cancelling', () => {
  it('a begin cancelled at a step rejects with an AbortError for every request (batched or one by one)', async () => {
    const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-begin-'));
    try {
      const dir = tinyModels(tmp).dir;
      const g = await openModel({ manifest: await loadManifest(dir), baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
      expect(g.batchesExactly).toBe(true);
      const ctrl = new AbortController();
      const o = { condition: { type: 'action' as const, label: 1 }, steps: 4, guidance: 2.5, signal: ctrl.signal, stopAt: 0.3 };
      const asked = g.begin([{ ...o, frames: 20, seed: 1, onStep: (d: number) => d === 1 && ctrl.abort() }, { ...o, frames: 30, seed: 2 }]);
      await expect(asked).rejects.toMatchObject({ name: 'AbortError' });
      const states = await g.begin([{ ...o, signal: undefined, frames: 20, seed: 1 }]);
      expect([states[0].next, states[0].frames, states[0].steps]).toEqual([0, 20, 4]); // t = 0.25 is the first step ≤ 0.3
      await g.dispose();
    } finally {
      fs.rmSync(tmp, { recursive: true, force: true });
    }
  });
});
