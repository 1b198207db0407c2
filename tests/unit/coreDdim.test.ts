// DDIM sampling (models trained with `--objective diffusion`): the update rule on known numbers, the
// marginals against emdm.sampler.schedule, and whole runs of the tiny step model against
// emdm.sampler.sample_features (method "ddim") (fixture tests/fixtures/parity/tiny-ddim.*).
import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { getSession } from '../../src/runtime/ort';
import { stepFunction } from '../../src/runtime/stepModel';
import { ddimUpdate } from '../../src/sampler/ddim';
import { sample, type StepFn } from '../../src/sampler/sampler';
import { computeSchedule, ddimScheduleFor, scheduleFor, type DdimSchedule } from '../../src/sampler/schedule';
import { PARITY_DIR, fixtureNoise, loadCase, maxAbsDiff } from './coreFixtures';

const fx = loadCase('tiny-ddim');
const D = 263;
const Z = 64;
const C = fx.meta.condDim as number;
const L = fx.meta.frames;
const T = fx.meta.steps as number;

async function tinyStep(): Promise<StepFn> {
  const bytes = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const session = await getSession('tests/fixtures/parity/tiny-step.onnx', bytes, 'wasm', { threads: 1 });
  return stepFunction(session, { featureDim: D, zDim: Z, condDim: C }, 'tiny-step.onnx');
}

/** A schedule with round numbers: aCum = [1, .6, .8], sCum = [0, .8, .6] (2 steps). */
const ROUND: DdimSchedule = { steps: 2, time: Float64Array.of(0.5, 1), aCum: Float64Array.of(1, 0.6, 0.8), sCum: Float64Array.of(0, 0.8, 0.6) };

describe('ddimUpdate', () => {
  it('computes ε̂ = (x − a_{k+1}·x0)/s_{k+1}, x = a_k·x0 + s_k·ε̂ on known numbers', () => {
    // x = 1, x0 = 0.5: ε̂ = (1 − 0.8·0.5)/0.6 = 1, x = 0.6·0.5 + 0.8·1 = 1.1
    // x = −2, x0 = 1:  ε̂ = (−2 − 0.8)/0.6 = −14/3, x = 0.6 − 0.8·14/3 = −3.1333…
    const x = Float32Array.of(1, -2);
    ddimUpdate(x, Float32Array.of(0.5, 1), 1, ROUND);
    expect(x[0]).toBeCloseTo(1.1, 6);
    expect(x[1]).toBeCloseTo(0.6 - (0.8 * 14) / 3, 5);
  });

  it('returns the prediction itself at k = 0', () => {
    const x = Float32Array.of(3, 4, 5);
    ddimUpdate(x, Float32Array.of(0.25, -1, 7), 0, ROUND);
    expect(Array.from(x)).toEqual([0.25, -1, 7]);
  });

  it('keeps x on the marginal of the predicted x0: x_{k+1} = a·x0 + s·ε gives x_k = a_k·x0 + s_k·ε (real T = 10 grid)', () => {
    const s = computeSchedule(10);
    const x0 = Float32Array.of(0.3, -1.2, 2);
    const eps = [0.7, 0.1, -1.5];
    for (let k = 1; k < 10; k++) {
      const x = Float32Array.from(x0, (v, i) => s.aCum[k + 1] * v + s.sCum[k + 1] * eps[i]);
      ddimUpdate(x, x0, k, s);
      x0.forEach((v, i) => expect(Math.abs(x[i] - (s.aCum[k] * v + s.sCum[k] * eps[i])), `k=${k} i=${i}`).toBeLessThan(1e-5));
    }
  });

  it('rejects a step index outside the schedule and a mismatched x0', () => {
    expect(() => ddimUpdate(new Float32Array(2), new Float32Array(2), 2, ROUND)).toThrow(/step index 2 outside 0…1/);
    expect(() => ddimUpdate(new Float32Array(2), new Float32Array(3), 1, ROUND)).toThrow(/x0 has 3 values, x has 2/);
  });
});

describe('DDIM schedule', () => {
  it('aCum / sCum equal emdm.sampler.schedule for every step count of the diffusion baseline', () => {
    const marginals = fx.meta.marginals as Record<string, { a_cum: number[]; s_cum: number[] }>;
    expect(Object.keys(marginals).map(Number).sort((a, b) => a - b)).toEqual([1, 2, 4, 5, 8, 10, 20, 50, 100]);
    for (const [n, py] of Object.entries(marginals)) {
      const s = computeSchedule(Number(n));
      expect(s.aCum.length, `T=${n}`).toBe(Number(n) + 1);
      py.a_cum.forEach((v, i) => expect(Math.abs(s.aCum[i] - v), `T=${n} aCum[${i}]`).toBeLessThan(1e-12));
      py.s_cum.forEach((v, i) => expect(Math.abs(s.sCum[i] - v), `T=${n} sCum[${i}]`).toBeLessThan(1e-9));
    }
  });

  it('shares the DDGAN time grid; aCum falls from ~1 (data) to ~0.0067 (t = 1), sCum rises', () => {
    for (const n of [1, 10, 100]) {
      const s = ddimScheduleFor({ supportedSteps: [n] }, n);
      const g = scheduleFor({ supportedSteps: [n] }, n);
      expect(Array.from(s.time)).toEqual(Array.from(g.time));
      expect(s.aCum[0]).toBeCloseTo(1, 7);
      expect(s.sCum[0]).toBeCloseTo(1e-4, 9);
      expect(s.aCum[n]).toBeCloseTo(Math.exp(-0.25 * 19.9 - 0.05) / Math.exp(-0.25 * 1e-6 * 19.9 - 0.5 * 1e-3 * 0.1), 6);
      for (let i = 1; i <= n; i++) {
        expect(s.aCum[i]).toBeLessThan(s.aCum[i - 1]);
        expect(s.sCum[i]).toBeGreaterThan(s.sCum[i - 1]);
      }
    }
  });

  it('ddimScheduleFor refuses undeclared step counts and a manifest time grid it was not computed for', () => {
    const s5 = computeSchedule(5);
    const entry = { supportedSteps: [5, 50], schedules: { '5': { time: [...s5.time], coef1: [...s5.coef1], coef2: [...s5.coef2], sigma: [...s5.sigma] } } };
    expect(ddimScheduleFor(entry, 5, 'd').aCum.length).toBe(6);
    expect(ddimScheduleFor(entry, 50, 'd').steps).toBe(50); // no manifest entry: computed
    expect(() => ddimScheduleFor(entry, 20, 'd')).toThrow(/models\.d: 20 steps not supported \(supportedSteps = \[5, 50\]\)/);
    const bad = structuredClone(entry);
    bad.schedules['5'].time[2] = 0.5;
    expect(() => ddimScheduleFor(bad, 5, 'd')).toThrow(/models\.d\.schedules\["5"\]\.time\[2\] = 0\.5 is not the VP grid/);
    // scheduleFor picks the check from the model's objective; a DDGAN model keeps its manifest posterior
    expect(() => scheduleFor({ ...bad, objective: 'diffusion' }, 5, 'd')).toThrow(/time\[2\] = 0\.5 is not the VP grid/);
    expect(scheduleFor(bad, 5, 'd').time[2]).toBe(0.5);
  });
});

describe('DDIM runs of the tiny step model equal emdm.sampler.sample_features (method "ddim")', () => {
  it('guided: features within 1e-4, z drawn every step but given to the model as zeros, no ε drawn', async () => {
    const step = await tinyStep();
    const zSeen: number[] = [];
    const spy: StepFn = (i) => (zSeen.push(Math.max(...i.z.map(Math.abs))), step(i));
    const noise = fixtureNoise(fx);
    const schedule = ddimScheduleFor({ supportedSteps: [T] }, T, 'tiny-ddim');
    const progress: number[] = [];
    const r = await sample({ method: 'ddim', schedule, step: spy, noise, frames: L, featureDim: D, zDim: Z, cond: fx.get('cond'), guidance: 2.5, onStep: (d) => progress.push(d) });
    expect(maxAbsDiff(r.x, fx.get('final_x'))).toBeLessThan(1e-4);
    expect(noise.calls).toEqual(['x_T', 'z_4', 'z_3', 'z_2', 'z_1', 'z_0']);
    expect(zSeen).toEqual([0, 0, 0, 0, 0]);
    expect(r.sampler).toBe('ddim');
    expect(r.modelCalls).toBe(T);
    expect(progress).toEqual([1, 2, 3, 4, 5]);
  });

  it('unconditional (zero condition): a single pass per step, equal to the Python run', async () => {
    const step = await tinyStep();
    const schedule = ddimScheduleFor({ supportedSteps: [T] }, T, 'tiny-ddim');
    const r = await sample({ method: 'ddim', schedule, step, noise: fixtureNoise(fx), frames: L, featureDim: D, zDim: Z, cond: new Float32Array(C), guidance: 2.5 });
    expect(maxAbsDiff(r.x, fx.get('final_x_uncond'))).toBeLessThan(1e-4);
  });

  it('the DDGAN update on the same model and noise gives another motion (the sampler choice matters)', async () => {
    const step = await tinyStep();
    const zeros = { normals: (n: number) => new Float32Array(n) }; // ε = 0 for DDGAN, x_T from the fixture
    const xT = fx.get('x_T');
    const noise = { normals: (n: number, what: string) => (what === 'xT' ? xT : zeros.normals(n)) };
    const r = await sample({ method: 'ddgan', schedule: computeSchedule(T), step, noise, frames: L, featureDim: D, zDim: Z, cond: fx.get('cond'), guidance: 2.5 });
    expect(r.sampler).toBe('ddgan');
    expect(maxAbsDiff(r.x, fx.get('final_x'))).toBeGreaterThan(1e-2);
  });

  it('refuses a schedule without the coefficients its method reads (marginals for DDIM, posterior for DDGAN)', async () => {
    const step = await tinyStep();
    const o = { step, noise: fixtureNoise(fx), frames: L, featureDim: D, zDim: Z, cond: fx.get('cond'), guidance: 2.5 };
    const wrongMarginals = { ...computeSchedule(T), aCum: computeSchedule(T + 1).aCum };
    await expect(sample({ ...o, method: 'ddim', schedule: wrongMarginals })).rejects.toThrow(/method 'ddim' needs schedule\.aCum of 6 values for 5 steps, got 7/);
    const noPosterior = { ...computeSchedule(T), sigma: new Float64Array(0) };
    await expect(sample({ ...o, method: 'ddgan', schedule: noPosterior })).rejects.toThrow(/method 'ddgan' needs schedule\.sigma of 5 values for 5 steps, got 0/);
  });
});
