/**
 * A live stream on a simulated clock (Python twin `emdm.motion.live.simulate`; the `tiny-live` parity fixture runs
 * both): frame by frame, each window taking `cost` frames of playback to generate. What the tests and the seam
 * benchmark run; src/live/stream.ts runs the same LiveCore against a real clock.
 *
 * At each frame p = 0 … frames − 1, in order: (1) the window under way, once p ≥ its start + its cost, is generated
 * (only then: a dropped one never is) and accepted at p; (2) a prompt at p replaces it (its cost counted from p);
 * (3) with none under way, `request(p)` may start one; (4) frame p is played (`frameAt`). The first window is
 * generated and accepted before frame 0. Window r costs cost[r mod cost.length] frames.
 */
import type { EditCondition, EditMotion, EditRequest } from '../edit';
import type { LiveCore, LiveWindowRequest } from './core';

export interface SimulatedPrompt {
  frame: number;
  cond: EditCondition | string;
}

export interface SimulatedLive {
  /** frames × 22 × 3 joints as played, world coordinates (stage + origin) */
  joints: Float32Array;
  /** frames × 2: the pelvis x/z as played, stage coordinates (the root kept near the stage) */
  stage: Float32Array;
  /** every window generated: its request and the frame it was accepted at */
  windows: { req: LiveWindowRequest; at: number; from: number | null; dropped: boolean }[];
}

export async function simulateLive(core: LiveCore, gen: (r: EditRequest) => Promise<EditMotion>, frames: number, prompts: readonly SimulatedPrompt[], cost: readonly number[]): Promise<SimulatedLive> {
  const windows: SimulatedLive['windows'] = [];
  let running: { req: LiveWindowRequest; ready: number } | null = null;
  const join = async (req: LiveWindowRequest, p: number) => {
    const m = await gen({ ...(req.action !== undefined ? { action: req.action } : { prompt: req.prompt }), frames: req.frames, seed: req.seed, ...(req.known ? { known: req.known } : {}) });
    const r = core.accept(req, m.features, p);
    windows.push({ req, at: p, from: r?.from ?? null, dropped: r?.dropped ?? true });
  };
  const start = (req: LiveWindowRequest, p: number) => ({ req, ready: p + cost[(req.id - 1) % cost.length] });
  await join(core.request(0)!, 0);
  const joints = new Float32Array(frames * 66);
  const stage = new Float32Array(frames * 2);
  for (let p = 0; p < frames; p++) {
    if (running && p >= running.ready) {
      const { req } = running;
      running = null;
      if (core.pending?.id === req.id) await join(req, p);
    }
    for (const e of prompts) if (e.frame === p) running = start(core.prompt(e.cond, p), p);
    if (!running) {
      const req = core.request(p);
      if (req) running = start(req, p);
    }
    const j = core.frameAt(p);
    stage.set([j[0], j[2]], p * 2);
    for (let i = 0; i < 66; i += 3) {
      j[i] += core.origin[0];
      j[i + 2] += core.origin[1];
    }
    joints.set(j, p * 66);
  }
  return { joints, stage, windows };
}
