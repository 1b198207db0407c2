// src/edit.ts against Python's emdm.motion.edit (the tiny-edit parity fixture of `python -m emdm.motion.edit_fixture`):
// the same timeline, regeneration, in-between, body-part edit and loop on the tiny step model, through the
// library's own generate() (openModel) with the fixture's noise, within 1e-4.
import crypto from 'node:crypto';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, beforeAll, describe, expect, it } from 'vitest';
import {
  type EditBegin, type EditBeginRequest, type EditGenerate, type EditRequest, type TimelineSegment, LOOP_END_FRAMES, OVERLAP_FRAMES, SEAM_BLEND_EXTRA, SEAM_BLEND_TAU, SEAM_BLEND_VELOCITY, SEAM_EASE_ACCEL,
  SEAM_EASE_ACCEL_MIN, SEAM_EASE_FRAMES, TIMELINE_KEEP_FROM, bodyPartEdit, easeSeams, generateTimeline, inBetween, makeLoop, seamAccel,
} from '../../src/edit';
import { type Generator, openModel } from '../../src/openModel';
import { type Manifest, loadManifest } from '../../src/manifest';
import { recoverJoints } from '../../src/motion/recover';
import { buildTinyManifest } from '../fixtures/parity/tinyManifest';
import { MODELS_DIR, PARITY_DIR, fixtureNoise, loadCase, maxAbsDiff, maxJointDist } from './coreFixtures';

const fx = loadCase('tiny-edit');
type Seg = { label: string; cond: number; seconds: number; seed: number };
const meta = fx.meta as unknown as {
  labels: string[]; steps: number; guidance: number; fps: number; maxFrames: number; overlap: number; loopEnds: number;
  ops: {
    timeline: { segments: Seg[]; frames: number[]; starts: number[]; total: number };
    regenerate: { segment: number; with: Seg; total: number };
    inbetween: { seed: number; label: string; keepUntil: number; keepFrom: number };
    body: { seed: number; label: string; keep: 'lower' | 'upper' };
    loop: { seed: number; label: string; ends: number; clipFrames: number };
    loopLong: { seed: number; label: string; maxFrames: number; clipFrames: number };
    ease: { calmFrames: number; frames: number; sway: number; dropAt: number; drop: number; keptFrames: number; accel: number; blendFrames: number; out: string };
  };
  runs: { op: string; frames: number; label: string; seed: number; noise: string }[];
};
const D = 263;
const limits = { fps: meta.fps, maxFrames: meta.maxFrames };
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-edit-parity-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

/** The tiny action model with the fixture's mean/std (tiny.meanstd.f32), served from a temp folder. */
function tinyFolder(): string {
  const sha = (b: Buffer) => crypto.createHash('sha256').update(b).digest('hex');
  const onnx = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const ms = fs.readFileSync(path.join(PARITY_DIR, 'tiny.meanstd.f32'));
  const real = JSON.parse(fs.readFileSync(path.join(MODELS_DIR, 'manifest.json'), 'utf8'));
  const manifest: Manifest = buildTinyManifest(real.skeleton, { path: 'tiny.onnx', bytes: onnx.length, sha256: sha(onnx) },
    { path: 'tiny.meanstd.f32', bytes: ms.length, sha256: sha(ms) });
  fs.writeFileSync(path.join(tmp, 'tiny.onnx'), onnx);
  fs.writeFileSync(path.join(tmp, 'tiny.meanstd.f32'), ms);
  fs.writeFileSync(path.join(tmp, 'manifest.json'), JSON.stringify(manifest));
  return tmp + '/';
}

let model: Generator;
const calls: EditRequest[] = [];
/** generate() with the noise of the fixture's run of the same frames and seed (the calls are checked in order below). */
const gen: EditGenerate = async (r) => {
  calls.push(r);
  const run = meta.runs.find((x) => x.frames === r.frames && x.seed === r.seed);
  if (!run) throw new Error(`no fixture run of ${r.frames} frames, seed ${r.seed}`);
  const noise = fixtureNoise({ ...fx, get: (k) => fx.get(run.noise + k) });
  const label = meta.labels.indexOf(String(r.action));
  const res = await model.generate({ condition: { type: 'action', label }, frames: r.frames, steps: meta.steps, guidance: meta.guidance, seed: r.seed, noise, known: r.known });
  return { frames: r.frames, fps: res.motion.fps, features: res.motion.features, joints: res.motion.joints };
};

const segsOf = (s: Seg[]): TimelineSegment[] => s.map((x) => ({ action: x.label, seconds: x.seconds, seed: x.seed }));
const rows = (a: Float32Array, from: number, to: number, width: number) => a.subarray(from * width, to * width);

beforeAll(async () => {
  const dir = tinyFolder();
  model = await openModel({ manifest: await loadManifest(dir), baseUrl: dir, model: 'tiny', backend: 'wasm', threads: 1 });
});
afterAll(() => model?.dispose());

describe('src/edit.ts = emdm.motion.edit (tiny-edit fixture)', () => {
  it('uses the same constants: overlap, loop ends, seam fade and cross-fade, the timeline windows\' keepFromTime', () => {
    expect(fx.meta).toMatchObject({
      overlap: OVERLAP_FRAMES, loopEnds: LOOP_END_FRAMES, seamEase: SEAM_EASE_FRAMES, seamAccel: SEAM_EASE_ACCEL,
      seamBlendExtra: SEAM_BLEND_EXTRA, seamBlendTau: SEAM_BLEND_TAU, seamBlendVelocity: SEAM_BLEND_VELOCITY, seamAccelMin: SEAM_EASE_ACCEL_MIN, timelineKeepFrom: TIMELINE_KEEP_FROM,
    });
  });

  const tlSegs = segsOf(meta.ops.timeline.segments);
  const base = () => ({ frames: meta.ops.timeline.total, fps: meta.fps, features: fx.get('timeline_features'), joints: fx.get('timeline_joints') });

  it('timeline and regenerating segment 2: same windows, features and stitched joints within 1e-4', async () => {
    calls.length = 0;
    const t = await generateTimeline(tlSegs, gen, limits);
    expect(calls.map((c) => c.known?.fromTime)).toEqual(calls.map((c, i) => (i === 0 ? undefined : TIMELINE_KEEP_FROM)));
    expect(t.segments.map((s) => s.frames)).toEqual(meta.ops.timeline.frames);
    expect(t.starts).toEqual(meta.ops.timeline.starts);
    expect(t.frames).toBe(meta.ops.timeline.total);
    const runs = meta.runs.filter((r) => r.op === 'timeline').map((r) => [r.frames, r.label, r.seed]);
    expect(calls.map((c) => [c.frames, c.action, c.seed])).toEqual(runs);
    expect(maxAbsDiff(t.features, fx.get('timeline_features'))).toBeLessThan(1e-4);
    // joints reach 11.7 m in this random model: feature differences of 3.5e-6 integrate along the root path to
    // 1.4e-4 (1.2e-5 of the scale), so joints are compared relative to their scale
    const jointTol = (a: Float32Array) => 1e-4 * Math.max(1, ...Array.from(a, Math.abs));
    expect(maxJointDist(t.joints, fx.get('timeline_joints'))).toBeLessThan(jointTol(fx.get('timeline_joints')));

    calls.length = 0;
    const segs = tlSegs.slice();
    const w = meta.ops.regenerate.with;
    segs[meta.ops.regenerate.segment - 1] = { action: w.label, seconds: w.seconds, seed: w.seed };
    const r = await generateTimeline(segs, gen, limits, { previous: t });
    expect(calls.map((c) => [c.frames, c.action, c.seed])).toEqual(meta.runs.filter((x) => x.op === 'regenerate').map((x) => [x.frames, x.label, x.seed]));
    expect(r.frames).toBe(meta.ops.regenerate.total);
    expect(maxAbsDiff(r.features, fx.get('regen_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(r.joints, fx.get('regen_joints'))).toBeLessThan(jointTol(fx.get('regen_joints')));
    // segment 1 untouched, bit for bit
    const n0 = meta.ops.timeline.frames[0];
    expect(maxAbsDiff(rows(r.joints, 0, n0, 66), rows(t.joints, 0, n0, 66))).toBe(0);
  });

  it('timeline with its windows begun together (begin: one model call per step until each context joins): the same within 1e-4', async () => {
    const noiseOf = (frames: number, seed: number) => {
      const run = meta.runs.find((x) => x.frames === frames && x.seed === seed);
      if (!run) throw new Error(`no fixture run of ${frames} frames, seed ${seed}`);
      return fixtureNoise({ ...fx, get: (k) => fx.get(run.noise + k) });
    };
    const begun: EditBeginRequest[][] = [];
    const begin: EditBegin = (reqs) => {
      begun.push(reqs);
      return model.begin(reqs.map((r) => ({
        condition: { type: 'action', label: meta.labels.indexOf(String(r.action)) }, frames: r.frames, steps: meta.steps, guidance: meta.guidance,
        seed: r.seed, noise: noiseOf(r.frames, r.seed), stopAt: r.stopAt, ...(r.keep ? { known: { keep: r.keep, fromTime: r.keepFromTime } } : {}),
      })));
    };
    const resumed: boolean[] = [];
    const viaResume: EditGenerate = async (r) => {
      resumed.push(r.resume !== undefined);
      const label = meta.labels.indexOf(String(r.action));
      const res = await model.generate({ condition: { type: 'action', label }, frames: r.frames, steps: meta.steps, guidance: meta.guidance, seed: r.seed, noise: noiseOf(r.frames, r.seed), known: r.known, resume: r.resume });
      return { frames: r.frames, fps: res.motion.fps, features: res.motion.features, joints: res.motion.joints };
    };
    const t = await generateTimeline(tlSegs, viaResume, limits, { begin });
    expect(begun.map((b) => b.map((r) => [r.frames, r.seed, r.stopAt, r.keep ? r.keep.reduce((a, v) => a + v, 0) / D : 0])))
      .toEqual([meta.runs.filter((r) => r.op === 'timeline').map((r, i) => [r.frames, r.seed, TIMELINE_KEEP_FROM, i === 0 ? 0 : OVERLAP_FRAMES])]);
    expect(resumed).toEqual([true, true, true]);
    expect(maxAbsDiff(t.features, fx.get('timeline_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(t.joints, fx.get('timeline_joints'))).toBeLessThan(1e-4 * Math.max(1, ...Array.from(fx.get('timeline_joints'), Math.abs)));
  });

  it('in-between (first and last second kept): within 1e-4; kept frames decode within 1 mm of the known motion', async () => {
    const o = meta.ops.inbetween;
    const m = base();
    const r = await inBetween(m, { action: o.label }, o.seed, gen, limits, { a: o.keepUntil, b: o.keepFrom });
    expect(maxAbsDiff(r.features, fx.get('inbetween_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(r.joints, fx.get('inbetween_joints'))).toBeLessThan(1e-4);
    const known = recoverJoints(m.features, m.frames);
    for (const [a, b] of [[0, o.keepUntil + 1], [o.keepFrom, m.frames]]) {
      expect(maxJointDist(rows(r.joints, a, b, 66), rows(known, a, b, 66))).toBeLessThan(1e-3);
    }
  });

  it('body-part edit (keep the lower body): within 1e-4', async () => {
    const o = meta.ops.body;
    const r = await bodyPartEdit(base(), o.keep, { action: o.label }, o.seed, gen, limits);
    expect(maxAbsDiff(r.features, fx.get('body_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(r.joints, fx.get('body_joints'))).toBeLessThan(1e-4);
  });

  it('loop and loop in place: the clip within 1e-4', async () => {
    const o = meta.ops.loop;
    const r = await makeLoop(base(), { action: o.label }, o.seed, gen, limits);
    expect(r.clip.frames).toBe(o.clipFrames);
    expect(maxAbsDiff(r.clip.features, fx.get('loop_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(r.clip.joints, fx.get('loop_joints'))).toBeLessThan(1e-4);
    const p = await makeLoop(base(), { action: o.label }, o.seed, gen, limits, { inPlace: true });
    expect(maxJointDist(p.clip.joints, fx.get('loop_in_place_joints'))).toBeLessThan(1e-4);
  });

  it('loop of a motion longer than the model window (only its last window sampled): within 1e-4', async () => {
    const o = meta.ops.loopLong;
    calls.length = 0;
    const r = await makeLoop(base(), { action: o.label }, o.seed, gen, { ...limits, maxFrames: o.maxFrames });
    expect(calls.map((c) => [c.frames, c.action, c.seed])).toEqual(meta.runs.filter((x) => x.op === 'loop_long').map((x) => [x.frames, x.label, x.seed]));
    expect(r.clip.frames).toBe(o.clipFrames);
    expect(maxAbsDiff(r.clip.features, fx.get('loop_long_features'))).toBeLessThan(1e-4);
    expect(maxJointDist(r.clip.joints, fx.get('loop_long_joints'))).toBeLessThan(1e-4 * Math.max(1, ...Array.from(fx.get('loop_long_joints'), Math.abs)));
    const n = meta.ops.timeline.total - o.maxFrames;
    expect(maxAbsDiff(rows(r.full.features, 0, n, D), rows(base().features, 0, n, D))).toBe(0); // before the window: as it was
  });

  it('a seam eased at a calm window\'s accel (seamAccel): the same accel, a cross-fade grown past the fade\'s, the same frames within 1e-4', () => {
    // the fixture's ease_case, from the timeline's frame 0: a calm window and one whose model frames drop 0.9 m two frames past the seam
    const e = meta.ops.ease;
    const f0 = fx.get('timeline_features').subarray(0, D);
    const build = (frames: number, drop: boolean) => {
      const f = new Float32Array(frames * D);
      for (let t = 0; t < frames; t++) {
        for (let c = 0; c < D; c++) {
          let v = c < 3 ? 0 : f0[c];
          if (c === 4) v += e.sway * Math.sin(t / 2);
          if (c === 3 && drop && t >= e.dropAt) v -= e.drop;
          f[t * D + c] = v;
        }
      }
      return f;
    };
    const accel = seamAccel(build(e.calmFrames, false), e.calmFrames);
    expect(Math.abs(accel - e.accel)).toBeLessThan(1e-4);
    expect(accel).toBeGreaterThan(SEAM_EASE_ACCEL_MIN);
    expect(accel).toBeLessThan(SEAM_EASE_ACCEL);
    const input = build(e.frames, true);
    const keep = new Float32Array(e.frames * D).fill(1, 0, e.keptFrames * D);
    const out = easeSeams(input, e.frames, keep, SEAM_EASE_FRAMES, D, accel);
    expect(maxAbsDiff(out.subarray(e.keptFrames * D, (e.keptFrames + e.blendFrames) * D), fx.get(e.out))).toBeLessThan(1e-4);
    let last = -1;
    for (let t = 0; t < e.frames; t++) if (out.subarray(t * D, (t + 1) * D).some((v, c) => v !== input[t * D + c])) last = t;
    expect(last + 1 - e.keptFrames).toBe(e.blendFrames);
    expect(e.blendFrames).toBeGreaterThan(SEAM_EASE_FRAMES + SEAM_BLEND_EXTRA);
  });
});
