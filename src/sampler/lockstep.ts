/**
 * Several sampling runs, one model call per step: a timeline's windows sampled together up to the step where each
 * needs the motion it continues (src/edit.ts). Every run gets its own StepFn; a call waits until every run still in
 * the group has asked, then all their rows go to the model as one batch (frames padded to the longest with mask 0,
 * which the model's attention ignores) and each run gets its own rows back. A run that ends leaves the group; a run
 * that fails makes every later call of the group fail with its error, so no run waits for it.
 *
 * One batched call costs less than its parts where the runtime has threads to spare (ORT-web WASM, 2 threads: a
 * 6 × 100-frame call about 90 ms against 3 × 41 ms for three 2 × 100 calls) or a GPU; on one WASM thread it costs
 * the same as the calls one by one. On fp32/fp16 files each run's rows come out as they would alone; a file that
 * quantises activations per call (int8) shares one scale across the batch, so a run's rounding would depend on what
 * it ran with: Generator.begin runs alone there (`batchesExactly`).
 */
import type { StepFn, StepInputs } from './sampler';

interface Asked {
  inputs: StepInputs;
  resolve: (x0: Float32Array) => void;
  reject: (e: unknown) => void;
}

export interface Lockstep {
  /** run i's step function */
  steps: StepFn[];
  /** run i is done (or failed): the others no longer wait for it */
  leave(i: number, error?: unknown): void;
}

export function lockstep(step: StepFn, runs: number): Lockstep {
  if (!Number.isInteger(runs) || runs < 1) throw new RangeError(`lockstep: runs must be a positive integer, got ${runs}`);
  const live = new Set(Array.from({ length: runs }, (_, i) => i));
  const asked = new Map<number, Asked>();
  let failure: { error: unknown } | null = null;

  const flush = (): void => {
    if (asked.size === 0 || asked.size < live.size) return;
    const batch = [...asked.entries()].sort((a, b) => a[0] - b[0]).map(([, a]) => a);
    asked.clear();
    call(step, batch.map((a) => a.inputs)).then(
      (outs) => batch.forEach((a, j) => a.resolve(outs[j])),
      (e) => {
        failure ??= { error: e };
        batch.forEach((a) => a.reject(e));
      },
    );
  };

  const steps = Array.from({ length: runs }, (_, i): StepFn => (inputs) => {
    if (failure) return Promise.reject(failure.error);
    if (!live.has(i)) return Promise.reject(new Error(`lockstep: run ${i} has left the group`));
    if (asked.has(i)) return Promise.reject(new Error(`lockstep: run ${i} asked again before its call was answered`));
    return new Promise<Float32Array>((resolve, reject) => {
      asked.set(i, { inputs, resolve, reject });
      flush();
    });
  });

  return {
    steps,
    leave(i, error) {
      if (!live.delete(i)) return;
      if (error !== undefined && !failure) {
        failure = { error };
        for (const a of asked.values()) a.reject(error);
        asked.clear();
        return;
      }
      flush();
    },
  };
}

/** Run `jobs` together, each with its lockstep StepFn; resolves with their results in order or rejects with the first failure. */
export async function together<T>(step: StepFn, jobs: ReadonlyArray<(step: StepFn) => Promise<T>>): Promise<T[]> {
  const g = lockstep(step, jobs.length);
  return Promise.all(jobs.map((job, i) => job(g.steps[i]).then(
    (r) => (g.leave(i), r),
    (e) => {
      g.leave(i, e);
      throw e;
    },
  )));
}

/** One model call for several runs' inputs; each run's rows of x0 back, its frames only. */
async function call(step: StepFn, parts: StepInputs[]): Promise<Float32Array[]> {
  if (parts.length === 1) return [await step({ ...parts[0] })];
  const dims = parts.map((p) => ({ D: p.x.length / (p.batch * p.frames), Z: p.z.length / p.batch, C: p.cond.length / p.batch }));
  const { D, Z, C } = dims[0];
  if (dims.some((d) => d.D !== D || d.Z !== Z || d.C !== C)) throw new Error(`lockstep: the runs' inputs differ in feature, z or condition size: ${JSON.stringify(dims)}`);
  const L = Math.max(...parts.map((p) => p.frames));
  const B = parts.reduce((a, p) => a + p.batch, 0);
  const x = new Float32Array(B * L * D);
  const z = new Float32Array(B * Z);
  const cond = new Float32Array(B * C);
  const t = new Float32Array(B);
  const mask = new Float32Array(B * L); // 0 on the padding frames
  let r = 0;
  for (const p of parts) {
    for (let b = 0; b < p.batch; b++, r++) {
      x.set(p.x.subarray(b * p.frames * D, (b + 1) * p.frames * D), r * L * D);
      z.set(p.z.subarray(b * Z, (b + 1) * Z), r * Z);
      cond.set(p.cond.subarray(b * C, (b + 1) * C), r * C);
      t[r] = p.t[b];
      mask.set(p.mask.subarray(b * p.frames, (b + 1) * p.frames), r * L);
    }
  }
  const out = await step({ x, z, cond, t, mask, batch: B, frames: L });
  if (out.length !== B * L * D) throw new Error(`lockstep: the model returned ${out.length} values for ${B} rows of ${L} frames × ${D}`);
  r = 0;
  return parts.map((p) => {
    const o = new Float32Array(p.batch * p.frames * D);
    for (let b = 0; b < p.batch; b++, r++) o.set(out.subarray(r * L * D, r * L * D + p.frames * D), b * p.frames * D);
    return o;
  });
}
