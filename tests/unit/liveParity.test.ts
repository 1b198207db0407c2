// src/live (LiveCore on simulateLive's clock) against Python's emdm.motion.live (the tiny-live parity fixture of
// `python -m emdm.motion.live_fixture`): the same windows (labels, seeds, cuts, the one dropped by a second prompt,
// the late joins) and the same frames as played, on the tiny step model with the fixture's noise.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, beforeAll, describe, expect, it } from 'vitest';
import type { EditGenerate } from '../../src/edit';
import {
  COAST_FRAMES, LEAD_SAFETY, LEAD_STEP_DOWN, LIVE_DISPLAY_FADE, LIVE_DISPLAY_PAD, LIVE_LEAD_FRAMES, LIVE_MAX_LEAD_FRAMES, LIVE_PROMPT_KEEP_FROM, LIVE_PROMPT_LEAD_FRAMES, LiveCore, RECENTRE_M,
} from '../../src/live/core';
import { simulateLive } from '../../src/live/simulate';
import { type Generator, openModel } from '../../src/openModel';
import { PARITY_DIR, fixtureNoise, loadCase, maxAbsDiff, maxJointDist, tinyModels } from './coreFixtures';

const fx = loadCase('tiny-live');
type Win = { id: number; label: string; seed: number; frames: number; c: number; cut: number; at: number; from: number | null; dropped: boolean; noise: string };
const meta = fx.meta as unknown as {
  labels: string[]; steps: number; first: { label: string; seed: number }; frames: number; prompts: { frame: number; label: string }[]; cost: number[];
  window: number; lead: number; promptLead: number; coast: number; recentre: number; base: number; origin: [number, number]; underruns: number; windows: Win[];
  maxLead: number; leadSafety: number; leadStepDown: number; displayPad: number; displayFade: number; promptKeepFrom: number; leadNow: number;
};
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-live-parity-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));
let model: Generator;
beforeAll(async () => {
  const { dir, manifest } = tinyModels(tmp, fs.readFileSync(path.join(PARITY_DIR, 'tiny.meanstd.f32')));
  model = await openModel({ manifest, baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
});
afterAll(() => model?.dispose());

const gen: EditGenerate = async (r) => {
  const w = meta.windows.find((x) => x.frames === r.frames && x.seed === r.seed);
  if (!w) throw new Error(`no fixture window of ${r.frames} frames, seed ${r.seed}`);
  const noise = fixtureNoise({ ...fx, get: (k) => fx.get(w.noise + k) });
  const res = await model.generate({ condition: { type: 'action', label: meta.labels.indexOf(String(r.action)) }, frames: r.frames, steps: meta.steps, guidance: 2.5, seed: r.seed, noise, known: r.known });
  return { frames: r.frames, fps: res.motion.fps, features: res.motion.features, joints: res.motion.joints };
};

describe('src/live = emdm.motion.live (tiny-live fixture)', () => {
  it('uses the same constants (the fixture\'s windows are shorter than the default)', () => {
    expect([meta.lead, meta.promptLead, meta.coast, meta.recentre]).toEqual([LIVE_LEAD_FRAMES, LIVE_PROMPT_LEAD_FRAMES, COAST_FRAMES, RECENTRE_M]);
    expect([meta.maxLead, meta.leadSafety, meta.leadStepDown, meta.displayPad, meta.displayFade]).toEqual([LIVE_MAX_LEAD_FRAMES, LEAD_SAFETY, LEAD_STEP_DOWN, LIVE_DISPLAY_PAD, LIVE_DISPLAY_FADE]);
    expect(meta.promptKeepFrom).toBe(LIVE_PROMPT_KEEP_FROM);
  });

  it('the same windows and the same frames as played, for the same prompts, seeds and prompt times', async () => {
    const core = new LiveCore({ fps: 20, maxFrames: 196 }, { action: meta.first.label }, meta.first.seed, { window: meta.window });
    const sim = await simulateLive(core, gen, meta.frames, meta.prompts.map((p) => ({ frame: p.frame, cond: { action: p.label } })), meta.cost);
    expect(sim.windows.map((w) => [w.req.id, w.req.action, w.req.seed, w.req.frames, w.req.c, w.req.cut, w.at, w.from, w.dropped]))
      .toEqual(meta.windows.map((w) => [w.id, w.label, w.seed, w.frames, w.c, w.cut, w.at, w.from, w.dropped]));
    expect(sim.windows.some((w) => w.from! > w.req.cut)).toBe(true); // a late join is among them
    expect(meta.underruns).toBeGreaterThan(0); // and an underrun (a window that took longer than the lead)
    const ids = meta.windows.map((w) => w.id);
    expect(ids.length).toBeLessThan(ids.at(-1)!); // windows dropped in preparation by a prompt: never generated
    expect([core.base, core.underruns, ...core.origin]).toEqual([meta.base, meta.underruns, ...meta.origin]);
    expect(core.lead).toBe(meta.leadNow); // raised by the 45-frame window, lowered by the next
    expect(meta.leadNow).toBeGreaterThan(meta.lead);
    expect(maxAbsDiff(core.features, fx.get('buffer_features'))).toBeLessThan(1e-4);
    // the tiny model's root jumps metres a frame (hundreds of metres in all) and its joints sit up to 11 m from the
    // pelvis: float32 rounding in each window's alignment (heading) grows along that path, so the pelvis is compared
    // relative to the path so far, the body relative to its size (measured here: 3.4e-4 of it at most, growing over the windows)
    const played = fx.get('played_joints');
    let path = 1;
    for (let p = 0; p < meta.frames; p++) {
      if (p > 0) path += Math.hypot(played[p * 66] - played[(p - 1) * 66], played[p * 66 + 2] - played[(p - 1) * 66 + 2]);
      const a = sim.joints.subarray(p * 66, (p + 1) * 66);
      const b = played.subarray(p * 66, (p + 1) * 66);
      expect(maxJointDist(a.subarray(0, 3), b.subarray(0, 3)), `pelvis of frame ${p}`).toBeLessThan(1e-4 * path);
      const rel = (j: Float32Array) => j.map((v, i) => v - j[i % 3]);
      const rb = rel(b);
      expect(maxJointDist(rel(a), rb), `body of frame ${p}`).toBeLessThan(5e-4 * Math.max(1, ...Array.from(rb, Math.abs)));
    }
  });
});
