// A long live session (issue 33 "Long runs"): thousands of windows and prompts on a fake clock keep every list and
// buffer the stream holds bounded (stats lists capped at MAX_LOG, the buffer at record + lead + window), the pelvis at
// the height the windows give it (no drift) and the root near the stage. The memory figure itself is the benchmark's
// (node --expose-gc scripts/bench/live-bench.mjs --soak-minutes 10).
import { describe, expect, it } from 'vitest';
import { type EditRequest, OVERLAP_FRAMES } from '../../src/edit';
import { COAST_FRAMES, LIVE_MAX_LEAD_FRAMES, RECENTRE_M } from '../../src/live/core';
import type { FramePose } from '../../src/live/poses';
import { MAX_LOG, startLive } from '../../src/live/stream';
import { walk } from './liveWalk';

const fakeSolve = (joints: Float32Array, frames: number): FramePose => {
  const rootPos = new Float32Array(frames * 3);
  for (let f = 0; f < frames; f++) rootPos.set(joints.subarray(f * 66, f * 66 + 3), f * 3);
  return { rootPos, quats: new Float32Array(frames * 88).fill(0.5) };
};
const flush = async () => {
  for (let i = 0; i < 8; i++) await Promise.resolve();
};

describe('a long live session', () => {
  it('1,380 prompts over 15 simulated minutes: stats lists capped, buffer bounded, pelvis height and stage kept', async () => {
    let t = 0;
    const window = 10;
    const recordSeconds = 10;
    const s = await startLive(async (r: EditRequest) => walk(r), { fps: 20, maxFrames: 196 }, { action: 'a', seed: 1, window, recordSeconds, clock: () => t }, {
      solve: (j) => fakeSolve(j, 1), solveFrames: async (j, n) => fakeSolve(j, n),
    });
    const frames = 15 * 60 * 20;
    let most = 0;
    let low = Infinity;
    let high = -Infinity;
    let stage = 0;
    for (let p = 0; p < frames; p++) {
      t = p / 20;
      if (p % 13 === 11) s.prompt({ action: 'abcdefgh'[(p / 13) % 8 | 0] });
      await flush();
      const f = s.frameAt(t + 0.01);
      low = Math.min(low, f.joints[1]);
      high = Math.max(high, f.joints[1]);
      stage = Math.max(stage, Math.hypot(f.joints[0], f.joints[2]));
      most = Math.max(most, s.stats().bufferedFrames);
      expect(f.pose!.rootPos[1]).toBeCloseTo(f.joints[1], 5);
    }
    const st = s.stats();
    expect(st.windows).toBeGreaterThan(1300);
    for (const k of ['latencies', 'windowMs', 'blends'] as const) expect(st[k].length, k).toBe(MAX_LOG);
    expect(most).toBeLessThanOrEqual(recordSeconds * 20 + LIVE_MAX_LEAD_FRAMES + OVERLAP_FRAMES + window + COAST_FRAMES);
    expect(st.lead).toBe(30); // windows on time: the lead stays where it started
    // the walking generator's pelvis: 0.9 ± 0.02 m, shown as it was generated over 15 minutes
    expect(low).toBeGreaterThan(0.87);
    expect(high).toBeLessThan(0.93);
    // 1.3 m/s for 15 minutes, kept within RECENTRE_M (+ a frame's step, 0.065 m) of the stage's centre in x and z
    expect(stage).toBeLessThan(Math.SQRT2 * (RECENTRE_M + 0.07));
    await s.close();
  });
});
