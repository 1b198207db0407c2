// The live stream's poses (src/live/poses.ts): bone rotations solved once per window (where the generator solves, its
// worker in a page), read and interpolated by frameAt; a frame is solved on its own only when its window's solve has
// not come back; a solve that comes back after a later window replaced its frames is not used for them.
import { describe, expect, it } from 'vitest';
import type { EditMotion, EditRequest } from '../../src/edit';
import type { FramePose } from '../../src/live/poses';
import { LIVE_LEAD_FRAMES, LIVE_WINDOW_FRAMES } from '../../src/live/core';
import { startLive } from '../../src/live/stream';
import { framePair, framesOnOneStage } from '../../web/ui/live';
import { walk } from './liveWalk';

const limits = { fps: 20, maxFrames: 196 };
/** A stand-in IK: the pelvis as the root, every rotation the identity but joint 0's w carrying the pelvis height. */
const fakeSolve = (joints: Float32Array, frames: number): FramePose => {
  const rootPos = new Float32Array(frames * 3);
  const quats = new Float32Array(frames * 88);
  for (let f = 0; f < frames; f++) {
    rootPos.set(joints.subarray(f * 66, f * 66 + 3), f * 3);
    for (let j = 0; j < 22; j++) quats[f * 88 + j * 4 + 3] = 1;
  }
  return { rootPos, quats };
};
const tick = () => new Promise((r) => setTimeout(r, 0));

describe('live poses: once per window, read by frameAt', () => {
  it('frameAt solves no frame itself when the windows\' solves are there; each window is solved once, for the frames it changed', async () => {
    let t = 0;
    let perFrame = 0;
    const windows: number[] = [];
    const s = await startLive(async (r: EditRequest) => walk(r), limits, { action: 'a', seed: 1, clock: () => t }, {
      solve: (j) => (perFrame++, fakeSolve(j, 1)),
      solveFrames: async (j, n) => (windows.push(n), fakeSolve(j, n)),
    });
    for (let p = 0; p < 600; p++) {
      t = p / 20;
      if (p % 150 === 75) s.prompt({ action: 'c' });
      const f = s.frameAt(t);
      expect(Array.from(f.pose!.rootPos)).toEqual(Array.from(f.joints.subarray(0, 3)));
      await tick();
    }
    expect(perFrame).toBe(0);
    expect(s.stats().poseFallbacks).toBe(0);
    expect(s.stats().windows).toBeGreaterThan(12);
    expect(windows.length).toBe(s.stats().windows); // the first included
    // a window's new frames and the display pad
    expect(Math.max(...windows.slice(1))).toBeLessThanOrEqual(LIVE_WINDOW_FRAMES + 3);
    await s.close();
  });

  it('between two frames, joints and pose are interpolated (the pose\'s root is the joints\' pelvis)', async () => {
    let t = 0;
    const s = await startLive(async (r: EditRequest) => walk(r), limits, { action: 'a', clock: () => t }, { solve: (j) => fakeSolve(j, 1), solveFrames: async (j, n) => fakeSolve(j, n) });
    const a = s.frameAt(0.5).joints;
    const b = s.frameAt(0.55).joints;
    t = 0.5;
    const m = s.frameAt(0.5125);
    expect(m.frame).toBe(10);
    for (let i = 0; i < 66; i++) expect(m.joints[i]).toBeCloseTo(a[i] + 0.25 * (b[i] - a[i]), 6);
    expect(Array.from(m.pose!.rootPos)).toEqual(Array.from(m.joints.subarray(0, 3)));
    await s.close();
  });

  it('the page\'s two frames around now (web/ui/live.ts framePair) share one stage, also where reading the second moved it back', async () => {
    let t = 0;
    const s = await startLive(async (r: EditRequest) => walk(r), limits, { action: 'a', clock: () => t }, { solve: (j) => fakeSolve(j, 1), solveFrames: async (j, n) => fakeSolve(j, n) });
    let moves = 0;
    let origin = [0, 0];
    for (let p = 0; p < 400; p++) {
      t = p / 20;
      const { track, shown } = framePair(s, p);
      const o = s.frameAt(t).origin;
      if (o[0] !== origin[0] || o[1] !== origin[1]) moves++;
      origin = o;
      // a walk's one frame step (0.065 m): never the whole metres the stage moved by
      const step = Math.hypot(track.rootPos[3] - track.rootPos[0], track.rootPos[5] - track.rootPos[2]);
      expect(step, `frame ${p}: pelvis step between the two frames (m)`).toBeLessThan(0.1);
      expect(Array.from(track.rootPos.subarray(0, 3)), `frame ${p}: the shown frame's pelvis is the track's first root`).toEqual(Array.from(shown.joints.subarray(0, 3)));
      await tick();
    }
    expect(moves, 'the stage moved back under the walker (1.3 m/s for 20 s)').toBeGreaterThan(3);
    // the visitor's character's piece: every frame from now to what is made, read ahead (the stage moves meanwhile)
    const to = Math.floor(s.stats().bufferedTo * 20);
    const piece = framesOnOneStage(s, 400, to);
    expect(to - 400).toBeGreaterThanOrEqual(LIVE_LEAD_FRAMES); // at least the lead is made ahead
    for (let k = 1; k < piece.length; k++) {
      const [a, b] = [piece[k - 1].joints, piece[k].joints];
      expect(Math.hypot(b[0] - a[0], b[2] - a[2]), `piece frame ${k}: pelvis step (m)`).toBeLessThan(0.1);
    }
    await s.close();
  });

  it('a window\'s solve that comes back after a later window replaced its frames is not used for them', async () => {
    let t = 0;
    const solves: { j: Float32Array; n: number; done: () => void; p: Promise<FramePose> }[] = [];
    const gens: { r: EditRequest; done: () => void }[] = [];
    const gen = (r: EditRequest) => new Promise<EditMotion>((res) => gens.push({ r, done: () => res(walk(r)) }));
    const solveFrames = (j: Float32Array, n: number) => {
      let done!: () => void;
      const p = new Promise<FramePose>((res) => (done = () => res(fakeSolve(j, n))));
      solves.push({ j, n, done, p });
      return p;
    };
    let perFrame = 0;
    // windows of 40 new frames (the frame numbers below are scripted for them)
    const hooks = { solve: (j: Float32Array) => (perFrame++, fakeSolve(j, 1)), solveFrames };
    const started = startLive(gen, limits, { action: 'a', window: 40, clock: () => t }, hooks);
    gens[0].done();
    await tick();
    solves[0].done();
    const s = await started;
    t = 1.6;
    s.frameAt(t); // frame 32: the lead runs low, window 2 is asked for (cut 60)
    gens[1].done();
    await tick(); // window 2 joins: its solve (frames 57 …) stays pending
    s.prompt({ action: 'd' }); // cut 40: replaces frames 37 … of the display
    gens[2].done();
    await tick();
    solves[2].done(); // the prompt's window solved first, then the stale one
    await tick();
    solves[1].done();
    await tick();
    perFrame = 0;
    for (let p = 33; p < 80; p++) { // the prompt's window ends at 80 (cut 40 + 40 new frames)
      const f = s.frameAt(p / 20);
      expect(Array.from(f.pose!.rootPos), `frame ${p}`).toEqual(Array.from(f.joints.subarray(0, 3)));
    }
    expect(perFrame).toBe(0);
    await s.close();
  });
});
