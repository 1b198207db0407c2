// The ORT runtime + sampler loop against the tiny step model of tests/fixtures/parity (exported
// by `python -m emdm.fixtures`), whose outputs were computed by Python onnxruntime.
import fs from 'node:fs';
import path from 'node:path';
import { describe, expect, it } from 'vitest';
import { getSession } from '../../src/runtime/ort';
import { IncompatibleModelError, stepFunction } from '../../src/runtime/stepModel';
import { sample, type StepFn } from '../../src/sampler/sampler';
import { computeSchedule, scheduleFromEntry } from '../../src/sampler/schedule';
import { SeededRandom } from '../../src/sampler/rng';
import { PARITY_DIR, fixtureNoise, loadCase, maxAbsDiff } from './coreFixtures';

const tiny = loadCase('tiny');
const D = 263;
const Z = 64;
const C = tiny.meta.condDim as number;
const L = tiny.meta.frames;

async function tinyStep(): Promise<StepFn> {
  const bytes = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const session = await getSession('tests/fixtures/parity/tiny-step.onnx', bytes, 'wasm', { threads: 1 });
  return stepFunction(session, { featureDim: D, zDim: Z, condDim: C }, 'tiny-step.onnx');
}

describe('runtime + sampler on the tiny step model', () => {
  it('one step equals Python onnxruntime within 1e-4 (batch 2)', async () => {
    const step = await tinyStep();
    const x0 = await step({
      x: tiny.get('step_x_t'), z: tiny.get('step_z'), cond: tiny.get('step_cond'), t: tiny.get('step_t'),
      mask: new Float32Array(2 * L).fill(1), batch: 2, frames: L,
    });
    expect(maxAbsDiff(x0, tiny.get('step_x0'))).toBeLessThan(1e-4);
  });

  it('a guided 4-step run with fixture noise equals the Python reference; draws in the documented order', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const noise = fixtureNoise(tiny);
    const progress: number[] = [];
    const r = await sample({ step, schedule, noise, frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, onStep: (d) => progress.push(d) });
    expect(maxAbsDiff(r.x, tiny.get('final_x'))).toBeLessThan(1e-4);
    expect(noise.calls).toEqual(['x_T', 'z_3', 'eps_3', 'z_2', 'eps_2', 'z_1', 'eps_1', 'z_0']);
    expect(r.modelCalls).toBe(4); // guidance batched: one call per step
    expect(progress).toEqual([1, 2, 3, 4]);
    expect(r.stepMs).toHaveLength(4);
  });

  it('guidance in a limited interval: the unconditional row only above guidanceMinTime, equal to the Python reference, same draws', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const gMin = tiny.meta.intervalGuidanceMinTime as number;
    const batches: number[] = [];
    const counting: StepFn = (i) => (batches.push(i.batch), step(i));
    const noise = fixtureNoise(tiny);
    const r = await sample({ step: counting, schedule, noise, frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, guidanceMinTime: gMin });
    // steps run from t = 1 down: guided (2 rows) where t > gMin, one conditional row below
    expect(batches).toEqual([...schedule.time].reverse().map((t) => (t > gMin ? 2 : 1)));
    expect(batches).toEqual([2, 2, 1, 1]);
    expect(r.guidedSteps).toBe(2);
    expect(noise.calls).toEqual(['x_T', 'z_3', 'eps_3', 'z_2', 'eps_2', 'z_1', 'eps_1', 'z_0']);
    expect(maxAbsDiff(r.x, tiny.get('final_x_interval'))).toBeLessThan(1e-4);
    // the skipped rows' guidance mattered: the motion is not the guided-everywhere one
    const full = tiny.get('final_x');
    expect(maxAbsDiff(r.x, full)).toBeGreaterThan(1e-6);
    // 0 guides every step: bit-identical to leaving it out
    const plain = await sample({ step, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5 });
    const zero = await sample({ step, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, guidanceMinTime: 0 });
    expect(Buffer.from(zero.x.buffer).equals(Buffer.from(plain.x.buffer))).toBe(true);
    expect(plain.guidedSteps).toBe(4);
    for (const bad of [-0.1, Number.NaN, Infinity]) {
      await expect(sample({ step, schedule, noise: new SeededRandom(1), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, guidanceMinTime: bad }))
        .rejects.toThrow(/guidanceMinTime must be a finite time ≥ 0/);
    }
  });

  it('x0Smoothing: x̂0 smoothed along time at every step but the last, equal to the Python reference, same draws', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const sigma = tiny.meta.smoothX0Smoothing as number;
    const noise = fixtureNoise(tiny);
    const r = await sample({ step, schedule, noise, frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, x0Smoothing: sigma });
    expect(noise.calls).toEqual(['x_T', 'z_3', 'eps_3', 'z_2', 'eps_2', 'z_1', 'eps_1', 'z_0']);
    expect(maxAbsDiff(r.x, tiny.get('final_x_smooth'))).toBeLessThan(1e-4);
    expect(maxAbsDiff(r.x, tiny.get('final_x'))).toBeGreaterThan(1e-3);
    // 0 is off: bit-identical to leaving it out
    const zero = await sample({ step, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, x0Smoothing: 0 });
    const plain = await sample({ step, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5 });
    expect(Buffer.from(zero.x.buffer).equals(Buffer.from(plain.x.buffer))).toBe(true);
    for (const bad of [-1, Number.NaN, Infinity, 1e9]) {
      await expect(sample({ step, schedule, noise: new SeededRandom(1), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, x0Smoothing: bad }))
        .rejects.toThrow(/x0Smoothing must be a finite σ ≥ 0 in frames \(0 = off\)/);
    }
    // a step count beyond the bound every manifest keeps (1…1000) is refused before any buffer is sized by it
    await expect(sample({ step, schedule: computeSchedule(1001), noise: new SeededRandom(1), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5 }))
      .rejects.toThrow(/schedule\.steps must be an integer in 1…1000, got 1001/);
  });

  it('speedCap: the root held to the first conditional x̂0\'s speed, equal to the Python reference; a begun run resumes with it', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const cap = { speedCap: tiny.meta.capSpeedCap as number, rootNorm: tiny.meta.capRootNorm as number[] };
    const base = { step, schedule, frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5 };
    const noise = fixtureNoise(tiny);
    const r = await sample({ ...base, noise, ...cap });
    expect(noise.calls).toEqual(['x_T', 'z_3', 'eps_3', 'z_2', 'eps_2', 'z_1', 'eps_1', 'z_0']);
    expect(maxAbsDiff(r.x, tiny.get('final_x_cap'))).toBeLessThan(1e-4);
    const plain = await sample({ ...base, noise: fixtureNoise(tiny) });
    expect(maxAbsDiff(r.x, plain.x)).toBeGreaterThan(1e-3);
    // only the root velocity channels 1-2 move
    for (let i = 0; i < r.x.length; i++) if (i % D !== 1 && i % D !== 2) expect(r.x[i]).toBe(plain.x[i]);
    // 0 is off, bit for bit
    const zero = await sample({ ...base, noise: fixtureNoise(tiny), speedCap: 0 });
    expect(Buffer.from(zero.x.buffer).equals(Buffer.from(plain.x.buffer))).toBe(true);
    // stopped part way, the reference travels with the state; the finished run is the whole one's
    const rng = new SeededRandom(5);
    const first = await sample({ ...base, noise: rng, ...cap, stopAt: 0.6 });
    expect(first.next).toBeDefined();
    expect(first.speedRef).toBeGreaterThan(0);
    const rest = await sample({ ...base, noise: rng, ...cap, resume: { x: first.x, next: first.next!, speedRef: first.speedRef } });
    const whole = await sample({ ...base, noise: new SeededRandom(5), ...cap });
    expect(Buffer.from(rest.x.buffer).equals(Buffer.from(whole.x.buffer))).toBe(true);
    await expect(sample({ ...base, noise: new SeededRandom(5), ...cap, resume: { x: first.x, next: first.next! } }))
      .rejects.toThrow(/resume\.speedRef is missing/);
    // a part that stopped before its first step (stopAt ≥ 1) has no reference yet: its resume runs that step
    const none = new SeededRandom(5);
    const early = await sample({ ...base, noise: none, ...cap, stopAt: 1 });
    expect(early.next).toBe(3);
    expect(early.speedRef).toBeUndefined();
    const late = await sample({ ...base, noise: none, ...cap, resume: { x: early.x, next: early.next! } });
    expect(Buffer.from(late.x.buffer).equals(Buffer.from(whole.x.buffer))).toBe(true);
    for (const bad of [-1, Number.NaN, Infinity]) {
      await expect(sample({ ...base, noise: new SeededRandom(1), speedCap: bad, rootNorm: cap.rootNorm })).rejects.toThrow(/speedCap must be a finite multiple ≥ 0/);
    }
    for (const bad of [undefined, [0, 0, 1], [0, 0, 0, 1], [0, Number.NaN, 1, 1]]) {
      await expect(sample({ ...base, noise: new SeededRandom(1), speedCap: 1, rootNorm: bad })).rejects.toThrow(/speedCap needs rootNorm/);
    }
  });

  for (const method of ['ddgan', 'ddim'] as const) {
    it(`x0Smoothing (${method}): the previews show x̂0 smoothed before the last step and the model's own at it; kept entries stay known`, async () => {
      // a step model whose x̂0 is a spike train along frames: smoothing is visible in every pose channel
      const spikes = new Float32Array(L * D);
      for (let f = 0; f < L; f += 2) spikes.fill(1, f * D, (f + 1) * D);
      const spiky: StepFn = async (i) => {
        const out = new Float32Array(i.batch * L * D);
        for (let b = 0; b < i.batch; b++) out.set(spikes, b * L * D);
        return out;
      };
      const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
      const keep = new Float32Array(L * D);
      const known = new Float32Array(L * D);
      keep.fill(1, 0, D); // frame 0 kept, all channels
      known.fill(0.25, 0, D);
      const previews: Float32Array[] = [];
      const r = await sample({
        method, step: spiky, schedule, noise: new SeededRandom(3), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5,
        x0Smoothing: 1, known, keep, onX0: (x0) => previews.push(Float32Array.from(x0)),
      });
      expect(previews).toHaveLength(4);
      const { smoothJoints, POSE_CHANNELS } = await import('../../src/motion/smooth');
      // the pose channels smoothed (every channel filtered alike, so the smoothed spike train of any channel will
      // do), the root, velocity and contact channels the model's own
      const smooth = smoothJoints(spikes, L, 1);
      const want = Float32Array.from(spikes);
      const [a, b] = POSE_CHANNELS;
      for (let f = 0; f < L; f++) want.set(smooth.subarray(f * D + a, f * D + b), f * D + a);
      want.set(known.subarray(0, D), 0);
      expect(maxAbsDiff(want, spikes)).toBeGreaterThan(0.1);
      const raw = Float32Array.from(spikes);
      raw.set(known.subarray(0, D), 0);
      for (const p of previews.slice(0, 3)) expect(maxAbsDiff(p, want)).toBeLessThan(1e-6);
      expect(maxAbsDiff(previews[3], raw)).toBe(0);
      expect(maxAbsDiff(r.x, raw)).toBe(0); // the result is the last x̂0: the model's own, kept part known
    });
  }

  it('a zero condition runs unguided (single pass) and equals the Python unconditional run', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    let maxBatch = 0;
    const counting: StepFn = (i) => ((maxBatch = Math.max(maxBatch, i.batch)), step(i));
    const r = await sample({ step: counting, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: new Float32Array(C), guidance: 2.5 });
    expect(maxBatch).toBe(1);
    expect(maxAbsDiff(r.x, tiny.get('final_x_uncond'))).toBeLessThan(1e-4);
  });

  it('same seed → bit-identical output; the guidance changes it', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const run = (seed: number, guidance: number) =>
      sample({ step, schedule, noise: new SeededRandom(seed), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance });
    const a = await run(5, 2.5);
    const b = await run(5, 2.5);
    const c = await run(5, 1);
    expect(Buffer.from(a.x.buffer).equals(Buffer.from(b.x.buffer))).toBe(true);
    expect(maxAbsDiff(a.x, c.x)).toBeGreaterThan(1e-3);
  });

  it('onX0 hands over each step\'s guided x̂0, draws nothing, and leaves the result bit-identical', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const outs: Float32Array[] = [];
    const recording: StepFn = async (i) => {
      const o = await step(i);
      outs.push(Float32Array.from(o));
      return o;
    };
    const plain = await sample({ step, schedule, noise: fixtureNoise(tiny), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5 });
    const noise = fixtureNoise(tiny);
    const seen: Array<[number, number, Float32Array]> = [];
    const order: string[] = [];
    const r = await sample({
      step: recording, schedule, noise, frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5,
      onX0: (x0, done, total) => (order.push(`x0 ${done}`), seen.push([done, total, x0])), onStep: (d) => order.push(`step ${d}`),
    });
    expect(Buffer.from(r.x.buffer).equals(Buffer.from(plain.x.buffer))).toBe(true);
    expect(noise.calls).toEqual(['x_T', 'z_3', 'eps_3', 'z_2', 'eps_2', 'z_1', 'eps_1', 'z_0']);
    expect(seen.map(([d, t]) => [d, t])).toEqual([[1, 4], [2, 4], [3, 4], [4, 4]]);
    expect(order).toEqual(['x0 1', 'step 1', 'x0 2', 'step 2', 'x0 3', 'step 3', 'x0 4', 'step 4']);
    const n = L * D;
    seen.forEach(([, , x0], k) => {
      expect(x0).toHaveLength(n);
      const o = outs[k];
      for (let i = 0; i < n; i += 97) expect(x0[i]).toBe(Math.fround(o[n + i] + Math.fround(2.5 * Math.fround(o[i] - o[n + i]))));
    });
  });

  it('cancels between steps with an AbortSignal', async () => {
    const step = await tinyStep();
    const schedule = scheduleFromEntry(tiny.meta.schedule!, 4, 'tiny.schedule');
    const ctrl = new AbortController();
    let calls = 0;
    const p = sample({
      step: (i) => (++calls === 2 && ctrl.abort(), step(i)),
      schedule, noise: new SeededRandom(1), frames: L, featureDim: D, zDim: Z, cond: tiny.get('cond'), guidance: 2.5, signal: ctrl.signal,
    });
    await expect(p).rejects.toThrow(/generation cancelled after 2 of 4 steps/);
    await expect(p).rejects.toHaveProperty('name', 'AbortError');
    expect(calls).toBe(2);
  });

  it('rejects a model whose inputs break the contract, naming them', async () => {
    const bytes = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
    const session = await getSession('tiny-step.onnx', bytes, 'wasm', { threads: 1 });
    const fake = { ...session, inputNames: ['x_t', 'z', 'cond', 'timestep'], outputNames: session.outputNames };
    expect(() => stepFunction(fake, { featureDim: D, zDim: Z, condDim: C }, 'bad.onnx')).toThrow(IncompatibleModelError);
    expect(() => stepFunction(fake, { featureDim: D, zDim: Z, condDim: C }, 'bad.onnx')).toThrow(/bad\.onnx: .*missing t, mask.*unexpected timestep/);
  });

  it('a corrupt model file fails with a clear error', async () => {
    await expect(getSession('corrupt.onnx', new Uint8Array([1, 2, 3, 4]), 'wasm', { threads: 1 })).rejects.toThrow(/cannot load ONNX model corrupt\.onnx on wasm/);
  });
});
