// The library's entry createGenerator (src/createGenerator.ts) in Node (in-process, WASM) on the tiny
// step model, and the backend choice / fallbacks it runs through (src/loadModel.ts).
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { loadModel, runWithFallback } from '../../src/loadModel';
import { createGenerator } from '../../src/createGenerator';
import { resolveRequest } from '../../src/requests';
import { type GenerateOptions, type GenerateResult, type Generator, openModel } from '../../src/openModel';
import { ModelFileError, loadManifest } from '../../src/manifest';
import { AbortError } from '../../src/sampler/sampler';
import { poseTrack } from '../../src/three';
import { EditError, type EditGenerate, generateTimeline, withNewSeed } from '../../src/edit';
import { decodeJoints } from '../../src/motion/decode';
import { maxAbsDiff, tinyModels } from './coreFixtures';

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-create-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));


describe('createGenerator', () => {
  it('fills a request from the manifest: model by task, steps, guidance, length, action by name', async () => {
    const manifest = await loadManifest(tinyModels(tmp).dir);
    const r = resolveRequest(manifest, { action: 'c', seed: 9 });
    expect(r).toEqual({ model: 'tiny', options: { condition: { type: 'action', label: 2 }, frames: 196, steps: 4, guidance: 2.5, seed: 9, smooth: undefined, footCleanup: undefined } });
    expect(resolveRequest(manifest, { action: 1, seconds: 1.5, model: 'tiny-ddim' }).options).toMatchObject({ frames: 30, steps: 5 });
    expect(resolveRequest(manifest, { action: 1, seconds: 60 }).options.frames).toBe(196);
    expect(() => resolveRequest(manifest, { action: 'zz' })).toThrow(/action 'zz' is not a label of tiny \(a, b, c, d, e, f, g, h\)/);
    for (const bad of [-1, 8, 1.5, Number.NaN]) {
      expect(() => resolveRequest(manifest, { action: bad, seed: 1 })).toThrow(new RegExp(`action '${bad}' is not a label of tiny .*its index, 0 to 7`));
    }
    const withText = { ...manifest, models: { ...manifest.models, t: { ...manifest.models.tiny, task: 'text' as const, condition: { type: 'text' as const, encoder: 'x', dim: 4 } } } };
    expect(() => resolveRequest(withText, { action: 'a', model: 't' })).toThrow(/t takes a prompt, not an action \(action: "a"\)/);
    expect(() => resolveRequest(manifest, { prompt: 'a person walks' })).toThrow(/no text model \(models: tiny, tiny-ddim\)/);
    expect(() => resolveRequest(manifest, { action: 1, seconds: 0 })).toThrow(/seconds must be > 0/);
    expect(() => resolveRequest(manifest, { action: 1, model: 'big' })).toThrow(/model 'big' is not in the manifest/);
  });

  it('in-process (Node): the same motion as openModel, with its pose (IK) for the character', async () => {
    const dir = tinyModels(tmp).dir;
    const manifest = await loadManifest(dir);
    const fallbacks: string[] = [];
    const g = await createGenerator({ baseUrl: dir, threads: 1, onFallback: (_m, r) => fallbacks.push(r) });
    expect(g.inWorker).toBe(false); // Node has no Worker: in-process by default
    const steps: number[] = [];
    const m = await g.generate({ action: 2, seconds: 1.5, seed: 7, onStep: (d) => steps.push(d) });
    expect(steps).toEqual([1, 2, 3, 4]);
    expect([m.model, m.backend, m.frames, m.fps, m.seed, m.steps, m.guidance]).toEqual(['tiny', 'wasm', 30, 20, 7, 4, 2.5]);
    expect(fallbacks).toEqual(['WebGPU is not available in this browser']); // 'auto' in Node: WASM, said once
    const ref = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
    const want = await ref.generate({ condition: { type: 'action', label: 2 }, frames: 30, steps: 4, guidance: 2.5, seed: 7 });
    expect(Buffer.from(m.joints.buffer).equals(Buffer.from(want.motion.joints.buffer))).toBe(true);
    expect(m.pose.rootPos.length).toBe(30 * 3);
    expect(m.pose.quats.length).toBe(30 * 22 * 4);
    const track = poseTrack(m, manifest.skeleton);
    expect(track.rootPos).toBe(m.pose.rootPos);
    // without a pose, the track is solved from the joints: the same numbers
    const solved = poseTrack({ frames: m.frames, fps: m.fps, joints: m.joints, features: m.features }, manifest.skeleton);
    expect(Array.from(solved.quats)).toEqual(Array.from(m.pose.quats));
    await ref.dispose();
    await g.dispose();
  });

  it("Node stays in-process once ONNX Runtime has set a global Worker (worker_threads'); bad threads and an aborted signal are said plainly", async () => {
    const dir = tinyModels(tmp).dir;
    const had = Object.getOwnPropertyDescriptor(globalThis, 'Worker');
    (globalThis as { Worker?: unknown }).Worker = class {};          // what ORT's wasm module does in Node
    try {
      const g = await createGenerator({ baseUrl: dir, threads: 1 });
      expect(g.inWorker).toBe(false);                               // was a browser worker, which then crashed
      const m = await g.generate({ action: 1, seconds: 1, seed: 1 });
      expect(m.frames).toBe(20);
      const stop = new AbortController();
      stop.abort();
      const aborted = g.generate({ action: 1, seconds: 1, seed: 1, signal: stop.signal });
      await expect(aborted).rejects.toBeInstanceOf(AbortError);    // the library's, as a cancel mid-run gives
      await g.dispose();
    } finally {
      if (had) Object.defineProperty(globalThis, 'Worker', had);
      else delete (globalThis as { Worker?: unknown }).Worker;
    }
    for (const threads of [0, -1, 1.5, Number.NaN]) {
      await expect(createGenerator({ baseUrl: dir, threads })).rejects.toThrow(/createGenerator: threads must be a whole number ≥ 1 \(WASM threads\), got/);
    }
  });

  it('a timeline through the library with its windows begun together: the motion of the windows run in turn', async () => {
    const g = await createGenerator({ baseUrl: tinyModels(tmp).dir, threads: 1, worker: false });
    const gen: EditGenerate = (r) => g.generate(r);
    const segs = [{ action: 'b', seconds: 3, seed: 1 }, { action: 'e', seconds: 2, seed: 2 }, { action: 'g', seconds: 12, seed: 3 }];
    const limits = { fps: 20, maxFrames: 196 };
    const inTurn = await generateTimeline(segs, gen, limits);
    const begun: number[] = [];
    const together = await generateTimeline(segs, gen, limits, { begin: (rs) => (begun.push(rs.length), g.begin(rs)) });
    expect(begun).toEqual([4]); // the 12 s segment is two windows
    expect(together.frames).toBe(340);
    expect(maxAbsDiff(together.features, inTurn.features)).toBeLessThan(1e-4);
    await expect(g.begin([{ action: 'b', frames: 10, seed: 1, stopAt: Number.NaN }])).rejects.toThrow(/stopAt must be a finite time ≥ 0/);
    await g.dispose();
  });

  it('generator.timeline: the whole timeline where the models are, the motion generateTimeline makes, shown and posed', async () => {
    const g = await createGenerator({ baseUrl: tinyModels(tmp).dir, threads: 1, worker: false });
    const segs = [{ action: 'b', seconds: 3, seed: 1 }, { action: 'e', seconds: 2, seed: 2 }, { action: 'g', seconds: 12, seed: 3 }];
    const want = await generateTimeline(segs, (r) => g.generate(r), { fps: 20, maxFrames: 196 }, { begin: (rs) => g.begin(rs) });
    const windows: number[][] = [];
    const together = new Set<number>();
    const t = await g.timeline(segs, { onWindow: (s, d, n) => windows.push([s, d, n]), onStep: (_d, _n, w) => together.add(w) });
    const same = (a: Float32Array, b: Float32Array) => Buffer.from(a.buffer, a.byteOffset, a.byteLength).equals(Buffer.from(b.buffer, b.byteOffset, b.byteLength));
    expect(same(t.features, want.features) && same(t.timeline.joints, want.joints)).toBe(true);
    expect([t.frames, t.fps, t.starts]).toEqual([340, 20, [0, 60, 100]]);
    // the joints shown: decoded as generate() decodes one motion (smoothed, feet on the floor), with their pose
    expect(same(t.joints, decodeJoints(want.features, 340, g.skeleton, { smooth: true, footCleanup: true }))).toBe(true);
    expect([t.pose.rootPos.length, t.pose.quats.length]).toEqual([340 * 3, 340 * 22 * 4]);
    expect(t.windows.map((w) => [w.model, w.frames])).toEqual([['tiny', 60], ['tiny', 60], ['tiny', 140], ['tiny', 140]]);
    expect(windows).toEqual([[0, 0, 4], [0, 0, 4], [1, 1, 4], [2, 2, 4], [2, 3, 4], [2, 4, 4]]);
    expect([...together].sort()).toEqual([0, 4]); // the 4 windows' early steps together, then each finished alone
    // regenerating from segment 2: segment 1 is reused as it was, the later ones continue from it
    const again = await g.timeline(withNewSeed(segs, 1), { previous: t });
    expect(again.windows.length).toBe(3);
    expect(same(again.features.subarray(0, 60 * 263), t.features.subarray(0, 60 * 263))).toBe(true);
    expect(same(again.features, t.features)).toBe(false);
    // bad input: an EditError naming the segment, before anything is generated
    const bad = g.timeline([{ action: 'b', seconds: 3, seed: 1 }, { action: 'zz', seconds: 2, seed: 2 }]);
    await expect(bad).rejects.toThrow(EditError);
    await expect(bad).rejects.toMatchObject({ segment: 1, message: expect.stringMatching(/action 'zz' is not a label of tiny/) });
    await expect(g.timeline([{ action: 'b', seconds: 0, seed: 1 }])).rejects.toMatchObject({ segment: 0 });
    await g.dispose();
  });

  it('names the missing folder setting in Node', async () => {
    await expect(createGenerator()).rejects.toThrow(/no baseUrl given; pass the models folder/);
  });
});

/** A generator stand-in whose generate() runs `run`. */
function fake(backend: 'webgpu' | 'wasm', run: (o: GenerateOptions) => Promise<GenerateResult>): Generator {
  return { modelName: 'm', backend, threads: 1, entry: {} as Generator['entry'], sampler: 'ddgan', batchesExactly: true, generate: run, begin: async () => { throw new Error('fake generator: no begin'); }, dispose: async () => undefined };
}
const OK = { steps: 1 } as GenerateResult;
const O: GenerateOptions = { condition: { type: 'none' }, frames: 2, steps: 1, guidance: 1, seed: 1 };

describe('backends: one place for WebGPU → WASM', () => {
  it('loadModel: WASM when asked; WebGPU missing → WASM, said once', async () => {
    const dir = tinyModels(tmp).dir;
    const manifest = await loadManifest(dir);
    const said: string[] = [];
    const w = await loadModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 }, (r) => said.push(r));
    expect([w.backend, said]).toEqual(['wasm', []]);
    const a = await loadModel({ manifest, baseUrl: dir, model: 'tiny', threads: 1 }, (r) => said.push(r));
    expect([a.backend, said]).toEqual(['wasm', ['WebGPU is not available in this browser']]);
    await expect(loadModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'gpu' as never })).rejects.toThrow(/backend must be 'auto', 'webgpu' or 'wasm', got "gpu"/);
    await Promise.all([w.dispose(), a.dispose()]);
  });

  it('runWithFallback: a WebGPU failure runs again on WASM; cancels, bad files and WASM failures are not retried', async () => {
    const said: string[] = [];
    const wasm = fake('wasm', async () => OK);
    const broken = fake('webgpu', async () => {
      throw new Error('device lost');
    });
    const r = await runWithFallback(broken, O, async () => wasm, (s) => said.push(s));
    expect(r.gen).toBe(wasm);
    expect(r.result).toBe(OK);
    expect(said).toEqual(['WebGPU failed while generating (device lost)']);
    const never = async () => {
      throw new Error('must not reload');
    };
    await expect(runWithFallback(fake('webgpu', async () => { throw new AbortError('stop'); }), O, never)).rejects.toThrow('stop');
    await expect(runWithFallback(fake('webgpu', async () => { throw new ModelFileError('x.onnx', 'incompatible', 'bad'); }), O, never)).rejects.toThrow(ModelFileError);
    await expect(runWithFallback(fake('wasm', async () => { throw new Error('oom'); }), O, never)).rejects.toThrow('oom');
  });
});
