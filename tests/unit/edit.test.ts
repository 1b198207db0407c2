// Timelines, in-betweening, body-part edits and loops (src/edit.ts): the frame bookkeeping against a
// generator that keeps what it is told to keep, and the real path (createGenerator in-process on the tiny
// step model) keeping the known motion where asked.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { createGenerator } from '../../src/createGenerator';
import {
  EditError, LOOP_END_FRAMES, OVERLAP_FRAMES, SEAM_BLEND_EXTRA, SEAM_EASE_ACCEL, SEAM_EASE_ACCEL_MIN, SEAM_EASE_FRAMES, bodyPartEdit, easeSeams, generateTimeline, inBetween, inBetweenRange,
  keptSegments, makeLoop, planTimeline, seamAccel, seamBlendFrames, seamEaseFrames, type EditGenerate, type EditMotion, type EditRequest, type TimelineSegment, withNewSeed,
} from '../../src/edit';
import { recoverJoints } from '../../src/motion/recover';
import { groupChannels } from '../../src/sampler/mask';
import { SeededRandom } from '../../src/sampler/rng';
import { tinyModels } from './coreFixtures';

const D = 263;
const C = OVERLAP_FRAMES;
const limits = { fps: 20, maxFrames: 196 };
const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-edit-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

/** A stand-in model: seeded small features (a plausible root height), the known entries where keep is 1. */
function fakeGenerator(): { gen: EditGenerate; calls: EditRequest[] } {
  const calls: EditRequest[] = [];
  const gen: EditGenerate = async (r) => {
    calls.push({ ...r, known: r.known && { features: Float32Array.from(r.known.features), keep: Float32Array.from(r.known.keep) } });
    const f = new SeededRandom(r.seed + 1000 * r.frames).normals(r.frames * D).map((v) => 0.05 * v);
    for (let t = 0; t < r.frames; t++) f[t * D + 3] = 0.9 + f[t * D + 3];
    if (r.known) for (let i = 0; i < f.length; i++) if (r.known.keep[i]) f[i] = r.known.features[i];
    return { frames: r.frames, fps: 20, features: f, joints: recoverJoints(f, r.frames) };
  };
  return { gen, calls };
}

const three10s: TimelineSegment[] = [
  { prompt: 'a person walks forward', seconds: 10, seed: 1 },
  { prompt: 'a person waves', seconds: 10, seed: 2 },
  { action: 'sit', seconds: 10, seed: 3 },
];

const maxDiff = (a: ArrayLike<number>, b: ArrayLike<number>) => {
  expect(a.length).toBe(b.length);
  let m = 0;
  for (let i = 0; i < a.length; i++) m = Math.max(m, Math.abs(a[i] - b[i]));
  return m;
};

describe('timeline plan', () => {
  it('splits segments past the window into near-equal windows; a fitting first segment is one generation', () => {
    const p = planTimeline(three10s, limits);
    expect(p.frames).toEqual([200, 200, 200]);
    expect(p.windows).toEqual([[100, 100], [100, 100], [100, 100]]);
    expect(p.total).toBe(600);
    const q = planTimeline([{ prompt: 'walk', seconds: 9.8, seed: 1 }, { prompt: 'wave', seconds: 8.8, seed: 1 }, { prompt: 'x', seconds: 8.85, seed: 1 }], limits);
    expect(q.windows).toEqual([[196], [176], [89, 88]]);
  });

  it.each([
    ['a 0 s segment', [three10s[0], { prompt: 'wave', seconds: 0, seed: 1 }], 1, /segment 2 is 0 s long; a segment needs at least one frame \(0\.05 s\)/],
    ['a segment with its seconds left blank', [three10s[0], { prompt: 'wave', seconds: Number.NaN, seed: 1 }], 1, /segment 2 has no length; a segment needs at least one frame/],
    ['a segment under one frame', [{ prompt: 'wave', seconds: 0.02, seed: 1 }], 0, /segment 1 is 0\.02 s long/],
    ['an empty prompt', [three10s[0], three10s[1], { prompt: '   ', seconds: 2, seed: 1 }], 2, /segment 3: the prompt is empty; type what the character should do in it, or remove the segment/],
    ['61 s in all', [...three10s, { prompt: 'walk', seconds: 31, seed: 4 }], null, /the timeline is 61 s in all; at most 60 s/],
    ['no segments', [], null, /no segments/],
    ['a 1e308 s segment (a link)', [three10s[0], { prompt: 'walk', seconds: 1e308, seed: 1 }], 1, /segment 2 is 1\.00e\+308 s long; a timeline is at most 60 s/],
    ['a 61 s segment', [{ prompt: 'walk', seconds: 61, seed: 1 }], 0, /segment 1 is 61 s long; a timeline is at most 60 s/],
  ])('refuses %s with a message naming the segment', (_what, segs, segment, msg) => {
    let err: unknown;
    try {
      planTimeline(segs as TimelineSegment[], limits);
    } catch (e) {
      err = e;
    }
    expect(err).toBeInstanceOf(EditError);
    expect((err as EditError).message).toMatch(msg);
    expect((err as EditError).segment).toBe(segment);
  });
});

describe('timeline generation (a generator that keeps the known entries)', () => {
  it('generates window by window, each continuing from the last second before it; one motion of all frames', async () => {
    const { gen, calls } = fakeGenerator();
    const seen: number[] = [];
    const t = await generateTimeline(three10s, gen, limits, { onWindow: (_s, done) => seen.push(done) });
    expect(t.frames).toBe(600);
    expect(t.starts).toEqual([0, 200, 400]);
    expect(t.features.length).toBe(600 * D);
    expect(t.joints.length).toBe(600 * 22 * 3);
    expect(calls.map((c) => [c.frames, c.seed, c.prompt ?? c.action])).toEqual([
      [100, 1, 'a person walks forward'], [120, 2, 'a person walks forward'], [120, 2, 'a person waves'], [120, 3, 'a person waves'], [120, 3, 'sit'], [120, 4, 'sit'],
    ]);
    expect(seen).toEqual([0, 1, 2, 3, 4, 5, 6]);
    expect(calls[0].known).toBeUndefined();
    // every later window: its first C frames are the previous window's last C, all channels kept, the last one's
    // root velocity [0:3] (its step into the window) the one before it
    const w = t.segments.flatMap((s) => s.windows);
    for (let j = 1; j < calls.length; j++) {
      const k = calls[j].known!;
      expect(k.keep.subarray(0, C * D).every((v) => v === 1)).toBe(true);
      expect(k.keep.subarray(C * D).every((v) => v === 0)).toBe(true);
      const prev = w[j - 1].features.subarray((w[j - 1].frames - C) * D);
      expect(maxDiff(k.features.subarray(0, (C - 1) * D), prev.subarray(0, (C - 1) * D))).toBe(0);
      expect(maxDiff(k.features.subarray((C - 1) * D + 3, C * D), prev.subarray((C - 1) * D + 3))).toBe(0);
      expect(maxDiff(k.features.subarray((C - 1) * D, (C - 1) * D + 3), prev.subarray((C - 2) * D, (C - 2) * D + 3))).toBe(0);
    }
    // features: the windows' new frames in order, the frame before a window's taking the step its context gave it;
    // the stitched joints are what those features decode to
    expect(maxDiff(t.features.subarray(0, 99 * D), w[0].features.subarray(0, 99 * D))).toBe(0);
    expect(maxDiff(t.features.subarray(99 * D + 3, 100 * D), w[0].features.subarray(99 * D + 3))).toBe(0);
    expect(maxDiff(t.features.subarray(99 * D, 99 * D + 3), calls[1].known!.features.subarray((C - 1) * D, (C - 1) * D + 3))).toBe(0);
    expect(maxDiff(t.features.subarray(100 * D, 199 * D), w[1].features.subarray(C * D, (C + 99) * D))).toBe(0);
    expect(maxDiff(t.features.subarray(199 * D + 3, 200 * D), w[1].features.subarray((C + 99) * D + 3))).toBe(0);
    expect(maxDiff(t.joints, recoverJoints(t.features, 600))).toBeLessThan(1e-4);
    // no jump at the seams: a seam step is no bigger than the steps inside a window
    const step = (f: number) => Math.hypot(t.joints[f * 66] - t.joints[(f - 1) * 66], t.joints[f * 66 + 2] - t.joints[(f - 1) * 66 + 2]);
    const inside = Math.max(...Array.from({ length: 98 }, (_, k) => step(k + 1)));
    for (const seam of [100, 200, 300, 400, 500]) expect(step(seam)).toBeLessThanOrEqual(inside * 1.5);
  });

  it('regenerating segment 2 keeps segment 1 as it was and redoes 2 and 3', async () => {
    const { gen, calls } = fakeGenerator();
    const t = await generateTimeline(three10s, gen, limits);
    calls.length = 0;
    const segs = withNewSeed(three10s, 1, 77);
    expect(keptSegments(t, segs)).toBe(1);
    const u = await generateTimeline(segs, gen, limits, { previous: t });
    expect(calls.map((c) => c.seed)).toEqual([77, 78, 3, 4]);
    expect(u.segments[0]).toBe(t.segments[0]);
    expect(maxDiff(u.joints.subarray(0, 200 * 66), t.joints.subarray(0, 200 * 66))).toBe(0);
    expect(maxDiff(u.joints.subarray(300 * 66), t.joints.subarray(300 * 66))).toBeGreaterThan(0);
    // unchanged list: nothing generated; a removed last segment: nothing generated either
    calls.length = 0;
    await generateTimeline(segs, gen, limits, { previous: u });
    const shorter = await generateTimeline(segs.slice(0, 2), gen, limits, { previous: u });
    expect(calls).toEqual([]);
    expect(shorter.frames).toBe(400);
  });

  it('a first segment shorter than the overlap: the next one continues from all of it', async () => {
    const { gen, calls } = fakeGenerator();
    const t = await generateTimeline([{ prompt: 'walk', seconds: 0.5, seed: 1 }, { prompt: 'wave', seconds: 2, seed: 2 }, { prompt: 'sit', seconds: 1, seed: 3 }], gen, limits);
    expect(calls.map((c) => c.frames)).toEqual([10, 50, 40]);
    expect(t.segments.map((s) => s.overlaps)).toEqual([[0], [10], [20]]);
    expect(t.frames).toBe(70);
    expect(maxDiff(t.joints, recoverJoints(t.features, 70))).toBeLessThan(1e-4);
  });

  it('bad input generates nothing', async () => {
    const { gen, calls } = fakeGenerator();
    await expect(generateTimeline([three10s[0], { prompt: '', seconds: 3, seed: 1 }], gen, limits)).rejects.toThrow(/segment 2: the prompt is empty/);
    expect(calls).toEqual([]);
  });

  it('stops between windows when cancelled', async () => {
    const { gen, calls } = fakeGenerator();
    const ctrl = new AbortController();
    const p = generateTimeline(three10s, async (r) => {
      const m = await gen(r);
      if (calls.length === 2) ctrl.abort();
      return m;
    }, limits, { signal: ctrl.signal });
    await expect(p).rejects.toMatchObject({ name: 'AbortError' });
    expect(calls.length).toBe(2);
  });
});

describe('editing one motion', () => {
  const motion = async (frames: number): Promise<EditMotion> => fakeGenerator().gen({ prompt: 'walk', frames, seed: 5 });

  it('in-between keeps the first and last second, all channels, pinned in place', async () => {
    const m = await motion(120);
    const { gen, calls } = fakeGenerator();
    const r = await inBetween(m, { prompt: 'jump' }, 9, gen, limits);
    const k = calls[0].known!;
    const rows = Array.from({ length: 120 }, (_, t) => k.keep[t * D] === 1 && k.keep.subarray(t * D, (t + 1) * D).every((v) => v === 1));
    expect(rows.map((v, t) => (v ? t : -1)).filter((t) => t >= 0)).toEqual([...Array.from({ length: 20 }, (_, t) => t), ...Array.from({ length: 20 }, (_, t) => 100 + t)]);
    expect(maxDiff(k.features, m.features)).toBe(0);
    expect(r.frames).toBe(120);
    await expect(inBetween(m, { prompt: 'x' }, 1, gen, limits, { a: 50, b: 51 })).rejects.toThrow(/at least one frame between/);
    await expect(inBetween(await motion(30), { prompt: 'x' }, 1, gen, limits)).rejects.toThrow(/\(at least one frame between\); got a = 19, b = 10/);
  });

  it('in-between ends given in seconds (as the page fields give them) are the frames inBetween keeps, or a refusal in seconds', async () => {
    const m = await motion(100); // 5 s at 20 fps
    expect(inBetweenRange(m, 1, 1, limits)).toEqual({ a: 19, b: 80 }); // inBetween's own default for a whole second
    expect(inBetweenRange(m, 0.05, 4.9, limits)).toEqual({ a: 0, b: 2 }); // one frame kept, one generated, 98 kept
    expect(() => inBetweenRange(m, 3, 2, limits)).toThrow(
      /^in-betweening: keeping the first 3 s and the last 2 s of this 5 s motion leaves no middle to regenerate; keep at least 0\.05 s at each end and at most 4\.95 s in all$/,
    );
    expect(() => inBetweenRange(m, 0.01, 1, limits)).toThrow(/keeping the first 0\.01 s .* leaves no middle/); // rounds to no frame kept
    expect(() => inBetweenRange(m, 0, 1, limits)).toThrow(/keep more than 0 s at each end \(got first 0 s, last 1 s\)/);
    expect(() => inBetweenRange(m, Number.NaN, 1, limits)).toThrow(EditError);
    const { gen } = fakeGenerator();
    const long = await generateTimeline(three10s.slice(0, 2), gen, limits);
    expect(() => inBetweenRange(long, 1, 1, limits)).toThrow(/at most 196 frames \(9\.8 s\), the model's window; this one is 400 frames/);
    // what it returns, inBetween takes as is
    const { gen: g2, calls } = fakeGenerator();
    await inBetween(m, { prompt: 'jump' }, 2, g2, limits, inBetweenRange(m, 0.5, 1.5, limits));
    const kept = Array.from({ length: 100 }, (_, t) => calls[0].known!.keep[t * D] === 1);
    expect(kept.map((v, t) => (v ? t : -1)).filter((t) => t >= 0)).toEqual([...Array.from({ length: 10 }, (_, t) => t), ...Array.from({ length: 30 }, (_, t) => 70 + t)]);
  });

  it('refuses a motion longer than the model window', async () => {
    const { gen } = fakeGenerator();
    const t = await generateTimeline(three10s.slice(0, 2), gen, limits);
    await expect(inBetween(t, { prompt: 'x' }, 1, gen, limits)).rejects.toThrow(/at most 196 frames \(9\.8 s\), the model's window; this one is 400 frames/);
    await expect(bodyPartEdit(t, 'lower', { prompt: 'wave' }, 1, gen, limits)).rejects.toThrow(EditError);
  });

  it('body-part edit keeps root + legs (or the upper body) on every frame', async () => {
    const m = await motion(60);
    const { gen, calls } = fakeGenerator();
    await bodyPartEdit(m, 'lower', { prompt: 'wave both hands' }, 3, gen, limits);
    await bodyPartEdit(m, 'upper', { prompt: 'run' }, 3, gen, limits);
    const kept = (keep: Float32Array, t: number) => [...keep.subarray(t * D, (t + 1) * D)].flatMap((v, c) => (v ? [c] : []));
    const lower = [...groupChannels('root'), ...groupChannels('legs')].sort((a, b) => a - b);
    for (const t of [0, 30, 59]) {
      expect(kept(calls[0].known!.keep, t)).toEqual(lower);
      expect(kept(calls[1].known!.keep, t)).toEqual(groupChannels('upper'));
    }
    await expect(bodyPartEdit(m, 'lower', { prompt: '' }, 3, gen, limits)).rejects.toThrow(/the edit: the prompt is empty/);
  });

  it('loop: both ends inpainted to the first pose; the clip stops before the repeat; in place stays put', async () => {
    const m = await motion(80);
    const { gen, calls } = fakeGenerator();
    const K = LOOP_END_FRAMES;
    const { clip, full } = await makeLoop(m, { prompt: 'walk' }, 4, gen, limits);
    const k = calls[0].known!;
    expect(maxDiff(k.features.subarray((80 - K) * D), m.features.subarray(0, K * D))).toBe(0);
    expect(k.keep.subarray(K * D, (80 - K) * D).every((v) => v === 0)).toBe(true);
    expect(clip.frames).toBe(70);
    expect(maxDiff(full.features.subarray((80 - K) * D, (81 - K) * D), full.features.subarray(0, D))).toBe(0);
    const inPlace = await makeLoop(m, { prompt: 'walk' }, 4, gen, limits, { inPlace: true });
    const j = inPlace.clip.joints;
    for (let t = 0; t < inPlace.clip.frames; t++) {
      expect(Math.abs(j[t * 66])).toBeLessThan(1e-6);
      expect(Math.abs(j[t * 66 + 2])).toBeLessThan(1e-6);
    }
  });
});

describe('the real path: createGenerator (in-process, tiny step model) with known/keep', () => {
  it('continues, in-betweens and loops keeping the known entries', async () => {
    const g = await createGenerator({ baseUrl: tinyModels(tmp).dir, threads: 1, backend: 'wasm' });
    const gen: EditGenerate = (r) => g.generate({ ...r, steps: 2 });
    const lim = { fps: 20, maxFrames: 60 };
    const t = await generateTimeline([{ action: 'a', seconds: 1.5, seed: 1 }, { action: 'c', seconds: 1, seed: 2 }], gen, lim);
    expect(t.frames).toBe(50);
    const [w0, w1] = t.segments.map((s) => s.windows[0]);
    expect(w1.frames).toBe(40);
    // w1's context: w0's last C frames, the last one's step into w1 (root velocity [0:3]) the one before it
    expect(maxDiff(w1.features.subarray(0, (C - 1) * D), w0.features.subarray(10 * D, 29 * D))).toBeLessThan(1e-4);
    expect(maxDiff(w1.features.subarray((C - 1) * D + 3, C * D), w0.features.subarray(29 * D + 3))).toBeLessThan(1e-4);
    expect(maxDiff(w1.features.subarray((C - 1) * D, (C - 1) * D + 3), w0.features.subarray(28 * D, 28 * D + 3))).toBeLessThan(1e-4);
    expect(maxDiff(t.joints, recoverJoints(t.features, 50))).toBeLessThan(1e-3);
    const ib = await inBetween(t, { action: 'e' }, 3, gen, lim);
    // kept frames decode where they were (first and last second), ≤ 1 mm
    for (const f of [0, 19, 30, 49]) expect(maxDiff(ib.joints.subarray(f * 66, (f + 1) * 66), t.joints.subarray(f * 66, (f + 1) * 66))).toBeLessThan(1e-3);
    const loop = await makeLoop(t, { action: 'a' }, 5, gen, lim);
    expect(maxDiff(loop.full.features.subarray(40 * D, 41 * D), t.features.subarray(0, D))).toBeLessThan(1e-4);
    await g.dispose();
  });
});

describe('easeSeams', () => {
  it('fades a large jump over more frames, so the fade stays within its acceleration; a small one over 10', () => {
    // the model may jump to the new prompt's pose in one frame (lie-down after standing); a fixed 10-frame fade made it a 0.5 s fall
    const n = 80;
    const f = new Float32Array(n * D);
    const keep = new Float32Array(n * D);
    for (let t = 0; t < n; t++) {
      f[t * D + 3] = t < 20 ? 0.89 : 0.08;
      for (let c = 4; c < 67; c++) f[t * D + c] = t < 20 ? 1 : -0.5; // every joint 1.5·√3 m
      if (t < 20) keep.fill(1, t * D, (t + 1) * D);
    }
    const g = easeSeams(f, n, keep);
    const m = Math.ceil(Math.PI * Math.sqrt((1.5 * Math.sqrt(3) * 400) / (2 * SEAM_EASE_ACCEL)));
    const o = new Float64Array(D).map((_, c) => g[20 * D + c] - f[20 * D + c]);
    expect(seamEaseFrames(o)).toBe(m);
    const b = m + SEAM_BLEND_EXTRA; // the offset's fade, then the cross-fade's extra frames
    expect(Array.from(g.subarray((20 + b) * D))).toEqual(Array.from(f.subarray((20 + b) * D)));
    expect(g[(19 + b) * D + 4]).not.toBe(f[(19 + b) * D + 4]);
    let peak = 0;
    for (let t = 1; t < n - 1; t++) peak = Math.max(peak, Math.abs(g[(t + 1) * D + 4] - 2 * g[t * D + 4] + g[(t - 1) * D + 4]) * Math.sqrt(3) * 400);
    expect(peak).toBeLessThanOrEqual(SEAM_EASE_ACCEL * 1.1); // the cross-fade on top adds 7.5 % here
    const small = new Float64Array(D);
    small[5] = 0.02;
    expect(seamEaseFrames(small)).toBe(SEAM_EASE_FRAMES);
  });

  it('a one-frame jitter at the end of the kept frames is not carried on past the seam (the kept side\'s mean velocity)', () => {
    // a still pose kept on frames 0…19 whose last frame jumps 0.45 m (a generated walk's foot jitter), generated 20…;
    // continued with its last step's velocity the joint slid on 0.42 m a frame, 1.5 m in all (Python twin's test)
    const n = 60;
    const f = new Float32Array(n * D);
    const keep = new Float32Array(n * D);
    for (let t = 0; t < n; t++) {
      f[t * D + 3] = 0.9;
      for (let c = 4; c < 67; c++) f[t * D + c] = 0.2;
      if (t < 20) keep.fill(1, t * D, (t + 1) * D);
    }
    for (let c = 4; c < 67; c += 3) f[19 * D + c] += 0.45;
    const g = easeSeams(f, n, keep);
    expect(Array.from(g.subarray(0, 20 * D))).toEqual(Array.from(f.subarray(0, 20 * D)));
    let travel = 0;
    let step = 0;
    for (let t = 20; t < n; t++) {
      travel = Math.max(travel, Math.abs(g[t * D + 4] - g[19 * D + 4]));
      step = Math.max(step, Math.abs(g[t * D + 4] - g[(t - 1) * D + 4]));
    }
    expect(travel).toBeLessThan(0.7);
    expect(step).toBeLessThan(0.2);
  });

  it('a timeline eases each seam at the seamAccel of the window before it: after a calm window, a drop in the first frames gets a longer cross-fade', async () => {
    // window 1: standing, one joint swaying (≈ 6 m/s²); window 2: its model frames hold two frames past the seam, then drop 0.9 m
    const calls: EditRequest[] = [];
    const gen: EditGenerate = async (r) => {
      calls.push(r);
      const f = new Float32Array(r.frames * D);
      for (let t = 0; t < r.frames; t++) {
        f[t * D + 3] = r.known && t >= C + 2 ? 0.1 : 1;
        f[t * D + 4] = 0.2 + 0.06 * Math.sin(t / 2);
        f[t * D + 5] = 0.3;
      }
      if (r.known) for (let i = 0; i < f.length; i++) if (r.known.keep[i]) f[i] = r.known.features[i];
      return { frames: r.frames, fps: 20, features: f, joints: recoverJoints(f, r.frames) };
    };
    const tl = await generateTimeline([{ prompt: 'stand', seconds: 2, seed: 1 }, { prompt: 'lie down', seconds: 2, seed: 2 }], gen, limits);
    const first = tl.features.subarray(0, 40 * D);
    const accel = seamAccel(first, 40);
    expect(accel).toBeGreaterThan(SEAM_EASE_ACCEL_MIN);
    expect(accel).toBeLessThan(8);
    const raw = await gen(calls[1]);
    const keep = calls[1].known!.keep;
    const eased = easeSeams(raw.features, C + 40, keep, SEAM_EASE_FRAMES, D, accel);
    expect(Array.from(tl.features.subarray(40 * D))).toEqual(Array.from(eased.subarray(C * D)));
    const b = seamBlendFrames(0.9, accel);
    expect(b).toBeGreaterThan(SEAM_EASE_FRAMES + SEAM_BLEND_EXTRA);
    expect(eased[(C + b - 1) * D + 3]).not.toBe(raw.features[(C + b - 1) * D + 3]); // the cross-fade's last frame
    expect(Array.from(eased.subarray((C + b) * D))).toEqual(Array.from(raw.features.subarray((C + b) * D)));
    // at the default 20 m/s² the fade's frames take the drop, and the seam is steeper
    const fast = easeSeams(raw.features, C + 40, keep);
    const peak = (g: Float32Array) => {
      let p = 0;
      for (let t = C - 1; t < C + 30; t++) p = Math.max(p, Math.abs(g[(t + 1) * D + 3] - 2 * g[t * D + 3] + g[(t - 1) * D + 3]) * 400);
      return p;
    };
    expect(peak(eased)).toBeLessThan(0.75 * peak(fast));
  });
});
