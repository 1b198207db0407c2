// The live stream (src/live): a prompt drops the window in preparation, frameAt never waits nor repeats a frame for
// lack of motion, memory stays bounded over a long run, the root is kept near the stage and the floor where it was;
// bad input gets one clear EditError. Behaviour runs on a cheap walking generator (the windows' bookkeeping is what is
// tested; tests/unit/liveParity.test.ts checks it against Python on the tiny step model), the API on the tiny model.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { createGenerator } from '../../src/createGenerator';
import { type EditMotion, type EditRequest, EditError, TIMELINE_KEEP_FROM } from '../../src/edit';
import {
  LIVE_PROMPT_KEEP_FROM, LIVE_PROMPT_LEAD_FRAMES, LIVE_WINDOW_FRAMES, LiveCore, RECENTRE_M,
} from '../../src/live/core';
import { simulateLive } from '../../src/live/simulate';
import { startLive } from '../../src/live/stream';
import { recoverJoints } from '../../src/motion/recover';
import { tinyModels } from './coreFixtures';
import { walk } from './liveWalk';

const D = 263;
const limits = { fps: 20, maxFrames: 196 };
describe('live stream behaviour (a walking generator, a simulated or a hand-driven clock)', () => {
  it('a prompt drops the window in preparation (aborted, its result ignored) and joins its own where it was cut', async () => {
    let t = 0;
    const calls: { r: EditRequest; signal: AbortSignal; done: () => void }[] = [];
    const gen = (r: EditRequest & { signal: AbortSignal }) => new Promise<EditMotion>((res) => calls.push({ r, signal: r.signal, done: () => res(walk(r)) }));
    // windows of 40 new frames (the frame numbers below are scripted for them)
    const started = startLive(gen, limits, { action: 'a', seed: 3, window: 40, clock: () => t });
    calls[0].done();
    const s = await started;
    expect(calls).toHaveLength(1); // 60 frames buffered: no window needed yet
    t = 1.6; // frame 32: fewer than 30 frames left ahead
    s.frameAt(t);
    expect(calls).toHaveLength(2);
    const before = s.frameAt(44 / 20).joints;
    s.prompt({ action: 'c' });
    expect(calls[1].signal.aborted).toBe(true);
    expect(calls[2].r).toMatchObject({ action: 'c', seed: 5, frames: 60 });
    // the prompt's window leaves more of its steps to the new prompt than a window continuing the same one
    expect([calls[1].r.known?.fromTime, calls[2].r.known?.fromTime]).toEqual([TIMELINE_KEEP_FROM, LIVE_PROMPT_KEEP_FROM]);
    expect(LIVE_PROMPT_KEEP_FROM).toBeLessThan(TIMELINE_KEEP_FROM);
    calls[1].done(); // the dropped window arrives after all: ignored
    await new Promise((r) => setTimeout(r, 0));
    calls[2].done();
    await new Promise((r) => setTimeout(r, 0));
    expect(s.stats()).toMatchObject({ windows: 2, dropped: 1, underruns: 0, blends: [32 + LIVE_PROMPT_LEAD_FRAMES] });
    expect(s.stats().latencies[0]).toBeCloseTo((32 + LIVE_PROMPT_LEAD_FRAMES) / 20 - 1.6, 6); // on time: its first frame is the cut's
    expect(Array.from(s.frameAt(44 / 20).joints)).not.toEqual(Array.from(before)); // frames after the cut: the new prompt's
    await s.close();
  });

  it('frameAt never waits and never repeats a frame while generation has stalled (an underrun, counted)', async () => {
    let t = 0;
    let first = true;
    const gen = (r: EditRequest) => (first ? ((first = false), Promise.resolve(walk(r))) : new Promise<EditMotion>(() => undefined));
    const s = await startLive(gen, limits, { action: 'b', clock: () => t });
    let prev: Float32Array | null = null;
    for (let p = 0; p < 400; p++) {
      t = p / 20;
      const f = s.frameAt(t);
      expect(f.frame).toBe(p);
      if (prev) expect(Array.from(f.joints), `frame ${p} repeats frame ${p - 1}`).not.toEqual(Array.from(prev));
      prev = f.joints;
    }
    expect(s.stats().underruns).toBeGreaterThan(0);
    expect(s.stats().coastedFrames).toBeGreaterThan(300);
    await s.close();
  });

  it('stats().bufferedTo says how far motion is made: frameAt before it reads it, at it plays back (the page feeds a character up to it)', async () => {
    let first = true;
    const gen = (r: EditRequest) => (first ? ((first = false), Promise.resolve(walk(r))) : new Promise<EditMotion>(() => undefined));
    const s = await startLive(gen, limits, { action: 'b', clock: () => 0 });
    const made = 20 + LIVE_WINDOW_FRAMES; // the first window: 20 kept + the window's new frames
    expect(s.stats().bufferedTo).toBe(made / 20);
    s.frameAt((made - 1) / 20);
    expect(s.stats()).toMatchObject({ underruns: 0, bufferedTo: made / 20 });
    s.frameAt(made / 20);
    expect(s.stats()).toMatchObject({ underruns: 1, bufferedTo: (made + 10) / 20 }); // 10 frames played back
    await s.close();
  });

  it('memory stays bounded over 20 simulated minutes; the root stays near the stage; the floor stays where it was', async () => {
    const core = new LiveCore(limits, { action: 'a' }, 1, { recordSeconds: 10 });
    const prompts = Array.from({ length: 200 }, (_, i) => ({ frame: 100 + i * 117, cond: { action: 'abcdefgh'[i % 8] } }));
    const frames = 20 * 60 * 20;
    const held: number[] = [];
    const gen = async (r: EditRequest) => {
      held.push(core.frames);
      return walk(r);
    };
    const sim = await simulateLive(core, gen, frames, prompts, [6, 14, 35]);
    expect(Math.max(...held)).toBeLessThanOrEqual(10 * 20 + 20 + LIVE_WINDOW_FRAMES + 30 + 35 + 20);
    expect(core.features.length).toBe(core.frames * D);
    expect(core.base).toBeGreaterThan(frames - 400);
    // walking 1.3 m/s for 20 min: ~1.5 km in the world, within a few metres of the stage's centre on it
    expect(Math.hypot(...core.origin)).toBeGreaterThan(1000);
    // the stage is moved back under the root shown once it is over RECENTRE_M out: at most a frame's step (0.065 m) more
    const most = Math.max(...Array.from(sim.stage, Math.abs));
    expect(most).toBeLessThan(RECENTRE_M + 0.07);
    // heights as the features have them (never shifted): the pelvis is root height [3] on every frame played
    const rec = recoverJoints(core.features, core.frames);
    for (let p = 0; p < core.frames; p++) expect(core.joints[p * 66 + 1]).toBeCloseTo(rec[p * 66 + 1], 5);
    const y = Array.from({ length: frames }, (_, p) => sim.joints[p * 66 + 1]);
    expect(Math.min(...y)).toBeGreaterThan(0.85);
    expect(Math.max(...y)).toBeLessThan(0.95);
  });
});

describe('generator.live (the tiny action model, in-process)', () => {
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-live-'));
  afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

  it('streams frames with a pose; bad input gets one clear EditError (unknown action, empty prompt, closed stream)', async () => {
    const g = await createGenerator({ baseUrl: tinyModels(tmp).dir, threads: 1, worker: false });
    await expect(g.live({ action: 'zz' })).rejects.toThrow(/^live: .*action 'zz' is not a label of tiny \(a, b, c, d, e, f, g, h\)/);
    await expect(g.live({ prompt: '  ' })).rejects.toThrow(EditError);
    let t = 0;
    const s = await g.live({ action: 'b', seed: 2, steps: 2, clock: () => t });
    const f = s.frameAt(0.5);
    expect(f.joints).toHaveLength(66);
    expect(f.pose!.quats).toHaveLength(22 * 4);
    // the rest offsets its rotations were solved for, where the page puts the character's bones (placeBones)
    expect(f.pose!.offsets).toHaveLength(66);
    expect(f.pose!.offsets!.every(Number.isFinite)).toBe(true);
    expect(() => s.prompt('')).toThrow(/live: the edit: the prompt is empty|prompt is empty/);
    expect(() => s.prompt({ action: 'zz' })).toThrow(/^live: .*action 'zz' is not a label/);
    expect(() => s.frameAt(-1)).toThrow(/frameAt takes seconds ≥ 0/);
    t = 1;
    expect(s.record().frames).toBe(21);
    await s.close();
    expect(() => s.frameAt(1)).toThrow(/live: the stream is closed; frameAt\(\) needs an open one/);
    expect(() => s.prompt('a person waves')).toThrow(/closed/);
    await g.dispose();
  });
});
