// The sampler registry: a third sampler is one new rule (src/sampler/update.ts's SamplerRule) and one
// registerSampler call, and runs through the real loop (src/sampler/sampler.ts) — its draws, its schedule check,
// guidance, inpainting and resume — without any change there. Also the built-in rules on known numbers.
import { describe, expect, it } from 'vitest';
import { ddganUpdate } from '../../src/sampler/ddgan';
import { registerSampler, samplerRule } from '../../src/sampler/registry';
import { type NoiseSource, type StepFn, sample } from '../../src/sampler/sampler';
import { computeSchedule } from '../../src/sampler/schedule';
import type { SamplerRule } from '../../src/sampler/update';

/** The trivial third sampler: jump straight to the prediction (x_k = x̂0), reading only the time grid. */
const jump: SamplerRule = {
  name: 'x0-jump',
  update: (x, x0) => x.set(x0),
  reads: { time: 'steps' },
  usesZ: true,
};
registerSampler(jump);

const D = 3;
const L = 4;
const Z = 2;

/** Noise that says what was drawn: value = a running count, so the draws are reproducible and recorded. */
function countingNoise(): NoiseSource & { calls: string[] } {
  let c = 0;
  const calls: string[] = [];
  return { calls, normals: (n, what, k) => (calls.push(`${what}_${k}`), Float32Array.from({ length: n }, () => ((c++ % 7) - 3) / 3)) };
}

/** A step model whose prediction is 0.5·x + t + z[0] (each row on its own), recording its inputs. */
function halfStep(seen: { batch: number; frames: number; t: number; z0: number }[]): StepFn {
  return async (i) => {
    seen.push({ batch: i.batch, frames: i.frames, t: i.t[0], z0: i.z[0] });
    const n = i.frames * D;
    return Float32Array.from(i.x, (v, j) => 0.5 * v + i.t[Math.floor(j / n)] + i.z[Math.floor(j / n) * Z]);
  };
}

describe('sampler registry', () => {
  it('runs a registered third sampler through the real loop: its update, the documented draws, one call per step', async () => {
    const seen: Parameters<typeof halfStep>[0] = [];
    const noise = countingNoise();
    const schedule = computeSchedule(3);
    const r = await sample({ method: 'x0-jump', schedule, step: halfStep(seen), noise, frames: L, featureDim: D, zDim: Z, cond: Float32Array.of(1), guidance: 1 });
    expect(r.sampler).toBe('x0-jump');
    expect(r.modelCalls).toBe(3);
    // x_T, then z at every step; the rule draws no ε
    expect(noise.calls).toEqual(['xT_3', 'z_2', 'z_1', 'z_0']);
    // x_k = x̂0 = 0.5·x_{k+1} + t_k + z_k[0], replayed by hand from the same draws
    const replay = countingNoise();
    let x = Float32Array.from(replay.normals(L * D, 'xT', 3));
    for (let k = 2; k >= 0; k--) {
      const z0 = replay.normals(Z, 'z', k)[0];
      x = Float32Array.from(x, (v) => 0.5 * v + Math.fround(schedule.time[k]) + z0); // the model gets t as float32
    }
    expect(Array.from(r.x)).toEqual(Array.from(x));
    expect(seen.map((s) => s.t)).toEqual([...schedule.time].reverse().map(Math.fround));
  });

  it('gives the third sampler the loop\'s inpainting, guidance rows and resume', async () => {
    const schedule = computeSchedule(4);
    const keep = new Float32Array(L * D);
    keep.fill(1, 0, D); // frame 0 kept on every channel
    const known = Float32Array.from({ length: L * D }, (_, i) => i / 10);
    const base = { method: 'x0-jump', schedule, featureDim: D, zDim: Z, frames: L, cond: Float32Array.of(1), guidance: 2.5, known, keep };
    const seen: Parameters<typeof halfStep>[0] = [];
    const whole = await sample({ ...base, step: halfStep(seen), noise: countingNoise() });
    expect(Array.from(whole.x.subarray(0, D))).toEqual(Array.from(known.subarray(0, D)));
    expect(seen.every((s) => s.batch === 2)).toBe(true); // guided: [c, 0] rows
    const noise = countingNoise();
    const first = await sample({ ...base, step: halfStep([]), noise, stopAt: 0.6 });
    expect(first.next).toBe(1);
    const rest = await sample({ ...base, step: halfStep([]), noise, resume: { x: first.x, next: first.next! } });
    expect(Array.from(rest.x)).toEqual(Array.from(whole.x));
  });

  it('checks the schedule arrays a rule reads before the first model call', async () => {
    const bare = { steps: 2, time: Float64Array.of(0.5, 1) } as unknown as ReturnType<typeof computeSchedule>;
    const step = halfStep([]);
    const opts = { schedule: bare, step, noise: countingNoise(), frames: L, featureDim: D, zDim: Z, cond: new Float32Array(1), guidance: 1 };
    await expect(sample({ ...opts, method: 'x0-jump' })).resolves.toMatchObject({ sampler: 'x0-jump', modelCalls: 2 });
    await expect(sample({ ...opts, method: 'ddgan' })).rejects.toThrow(/method 'ddgan' needs schedule\.coef1 of 2 values for 2 steps, got none/);
    await expect(sample({ ...opts, method: 'ddim' })).rejects.toThrow(/method 'ddim' needs schedule\.aCum of 3 values/);
  });

  it('names the registered samplers for an unknown method and refuses a second rule of one name', async () => {
    expect(samplerRule('ddgan').name).toBe('ddgan');
    const opts = { schedule: computeSchedule(2), step: halfStep([]), noise: countingNoise(), frames: L, featureDim: D, zDim: Z, cond: new Float32Array(1), guidance: 1 };
    await expect(sample({ ...opts, method: 'euler' })).rejects.toThrow("sampler: method 'euler' is not a registered sampler (registered: ddgan, ddim, x0-jump)");
    expect(() => registerSampler({ ...jump })).toThrow(/'x0-jump' is already registered/);
  });
});

describe('ddganUpdate', () => {
  it('x_k = coef1·x̂0 + coef2·x_{k+1} + sigma·ε, drawing ε only where sigma ≠ 0', () => {
    const s = { ...computeSchedule(2), coef1: Float64Array.of(1, 0.5), coef2: Float64Array.of(0, 0.25), sigma: Float64Array.of(0, 2) };
    let draws = 0;
    const noise = { eps: () => (draws++, Float32Array.of(1, -1)) };
    const x = Float32Array.of(4, 8);
    ddganUpdate(x, Float32Array.of(2, 2), 1, s, noise);
    expect(Array.from(x)).toEqual([0.5 * 2 + 0.25 * 4 + 2, 0.5 * 2 + 0.25 * 8 - 2]);
    ddganUpdate(x, Float32Array.of(3, -3), 0, s, noise);
    expect(Array.from(x)).toEqual([3, -3]);
    expect(draws).toBe(1);
  });
});
