/**
 * Beyond one prompt (issue 14): a prompt timeline far past the model's window, in-betweening, body-part edits
 * and seamless loops — all the same move: generate with part of a known motion kept (`known`/`keep`,
 * docs/ARCHITECTURE.md "Sampling with constraints"). Python twin: `emdm.motion.edit` (same bookkeeping; the
 * `tiny-edit` parity fixture checks both).
 *
 * ```ts
 * const generator = await createGenerator();
 * const gen: EditGenerate = (r) => generator.generate(r);          // any function of this shape works
 * const limits = { fps: 20, maxFrames: 196 };
 * const t = await generateTimeline([
 *   { prompt: 'a person walks forward', seconds: 10, seed: 1 },
 *   { prompt: 'a person waves', seconds: 10, seed: 2 },
 *   { prompt: 'a person sits down', seconds: 10, seed: 3 },
 * ], gen, limits, { begin: (rs) => generator.begin(rs) });         // t.joints: 600 frames × 22 × 3, one motion
 * const again = await generateTimeline(withNewSeed(t.segments.map((s) => s.segment), 1), gen, limits, { previous: t });
 * // segment 0 is reused as it was; 1 and 2 are generated again (2 continues from the new 1)
 * const loop = await makeLoop(again, { prompt: 'a person waves' }, 7, gen, limits, { inPlace: true });
 * ```
 *
 * The contract (frames at `fps`, C = OVERLAP_FRAMES = 1 s):
 * - Timeline: segment k has n_k = round(seconds·fps) ≥ 1 new frames, made in windows. The timeline's first
 *   window is an ordinary generation; every later one holds c + m frames, c = min(C, frames so far), its first c
 *   frames kept (all channels) from the sequence's last c frames (the last one's root velocity [0:3], its step into
 *   the window, replaced by the frame's before: the window before never took it), generated with its segment's condition. A segment
 *   of n ≤ cap = maxFrames − C frames is one window (the first segment: up to maxFrames); a longer one is split
 *   into ⌈n/cap⌉ near-equal windows (the first ones one frame longer), window j seeded seed + j. Each later
 *   window's features are eased at the seam (`easeSeams`, at the `seamAccel` of the window before it) before
 *   anything else reads them. Joints: each window
 *   recovered, then `appendSegment(prev, window, c)`; features: the first window's, then every later window's
 *   frames [c, …), the frame before each of those taking the step its context gave it.
 *   Changing segment i regenerates i and every later one (they continue from it); those before are kept.
 *   With `begin` (the generator's), every window to generate is started at once, one model call per step for all,
 *   and stopped where its context joins (t ≤ TIMELINE_KEEP_FROM; its context frames sit those steps out, so they
 *   need nothing from the window before); then each is finished in turn (`resume`). The same motion as without it;
 *   faster where the runtime has threads or a GPU to spare for the larger calls. (A generator whose file quantises
 *   per call, the int8 files, begins them one by one: see Generator.batchesExactly.)
 * - In-between: keep frames [0, a] ∪ [b, N−1] (default a = C−1, b = N−C), all channels; the kept later part
 *   stays where it was in the world (`pinKeptRoot`, generate's default); then `easeSeams` and `pinKeptRoot` again.
 * - Body part: keep the root + legs groups on every frame (new upper body) or the upper group (new legs + root).
 * - Loop (K = LOOP_END_FRAMES): known = X with frames [N−K, N) replaced by X[0:K]; frames [0, K) ∪ [N−K, N) kept
 *   (the root at N−K pinned where X had it, eased and pinned again as the in-between). The clip is frames [0, N−K): played in a loop, frame N−K (the first
 *   pose again) follows its last frame. A longer X (a timeline, ≤ MAX_TIMELINE_SECONDS) has only its last window
 *   W = maxFrames sampled: known = X[N−W:] with its last K frames replaced by X[0:K], frames [0, C) ∪ [W−K, W) of
 *   the window kept (it continues X[:N−W], which stays as it was).
 *   In place: the root's x/z velocity (features [1:3]) is set to 0 on every frame (heading may still turn).
 *
 * Features here are de-normalised (`Motion.features`, what `known` takes); the sampler keeps the kept entries
 * exactly in its normalised space.
 */
import { recoverJoints } from './motion/recover';
import { ROOT_STEP_CHANNELS, SEAM_EASE_FRAMES, easeSeams, seamAccel } from './motion/seams';
import { appendSegment, pinKeptRoot } from './motion/stitch';
import { keepMask, type FeatureGroup, type KnownMotion } from './sampler/mask';
import { AbortError } from './sampler/sampler';
import type { SamplingSettings } from './sampler/settings';
import type { SampleState } from './openModel';

export {
  SEAM_BLEND_EXTRA, SEAM_BLEND_TAU, SEAM_BLEND_VELOCITY, SEAM_EASE_ACCEL, SEAM_EASE_ACCEL_MIN, SEAM_EASE_FRAMES, easeSeams, seamAccel, seamBlendFrames, seamEaseFrames,
} from './motion/seams';

const D = 263;
/** Frames each timeline window repeats from the one before (1 s at 20 fps). */
export const OVERLAP_FRAMES = 20;
/**
 * A timeline window imposes its kept second only at the denoising steps with t ≤ this (the sampler's
 * keepFromTime; the last step always): the earlier steps belong to the prompt. Imposed at every step, a window mostly
 * went on with the previous segment's action (Python twin `TIMELINE_KEEP_FROM`, where the figures are).
 */
export const TIMELINE_KEEP_FROM = 0.55;
/** The longest timeline, seconds. */
export const MAX_TIMELINE_SECONDS = 60;
/** Frames at each end of a loop that are inpainted to the same pose. */
export const LOOP_END_FRAMES = 10;
/** What a motion is about: a text prompt or an action (label name or index). */
export interface EditCondition {
  prompt?: string;
  action?: string | number;
}

export interface TimelineSegment extends EditCondition {
  seconds: number;
  /** uint32 */
  seed: number;
}

/** One generation as the edit functions ask for it (createGenerator's MotionRequest takes it as is). */
export interface EditRequest extends EditCondition {
  frames: number;
  seed: number;
  /** the motion to keep part of, de-normalised (MotionRequest's `known`; the model normalises it into SamplingSettings') */
  known?: KnownMotion;
  /** finish what `EditBegin` started for this request (the generator's SampleState) */
  resume?: SampleState;
}

/**
 * A timeline window's steps before its context joins, as `EditBegin` gets them: its condition, frames and seed, the
 * frames it will keep (SamplingSettings' `keep`, imposed from `keepFromTime` on; absent for the timeline's first
 * window) and `stopAt`.
 */
export interface EditBeginRequest extends EditCondition, Pick<SamplingSettings, 'keep' | 'keepFromTime'> {
  frames: number;
  seed: number;
  stopAt: number;
}

/**
 * Start several windows together, one model call per step (the generator's `begin`): a timeline window's steps
 * above TIMELINE_KEEP_FROM need nothing from the window before it, so they all run at once and each window is then
 * finished in turn with its state (`EditRequest.resume`). Optional: without it each window runs whole, in turn.
 */
export type EditBegin = (reqs: EditBeginRequest[]) => Promise<SampleState[]>;

/** A motion with its de-normalised features (frames × 263) and joints (frames × 22 × 3). */
export interface EditMotion {
  frames: number;
  fps: number;
  features: Float32Array;
  joints: Float32Array;
}

export type EditGenerate = (req: EditRequest) => Promise<EditMotion>;

/** The model's frame rate and window (manifest `fps`, `maxFrames`). */
export interface EditLimits {
  fps: number;
  maxFrames: number;
}

/** Bad input for an edit; `segment` is the timeline segment it names (0-based), or null. */
export class EditError extends Error {
  constructor(message: string, readonly segment: number | null = null) {
    super(message);
    this.name = 'EditError';
  }
}

const fmtS = (s: number) => `${Number(s.toFixed(2))} s`;
const label = (i: number) => `segment ${i + 1}`;

/** A segment's condition for the request ('' prompt and no action: an EditError naming it). */
export function conditionOf(c: EditCondition, i: number | null): EditCondition {
  if (c.action !== undefined && c.action !== '') return { action: c.action };
  const text = typeof c.prompt === 'string' ? c.prompt.trim() : '';
  if (!text) {
    throw new EditError(`${i === null ? 'the edit' : label(i)}: the prompt is empty; type what the character should do${i === null ? '' : ' in it, or remove the segment'}`, i);
  }
  return { prompt: text };
}

/** New frames of each window of a segment of n frames: one window when it fits (`first`: maxFrames for the
 * timeline's first segment, maxFrames − C after), else ⌈n/cap⌉ near-equal windows (the first ones one frame longer). */
function windowSizes(n: number, first: number, cap: number): number[] {
  if (n <= first) return [n];
  const m = Math.ceil(n / cap);
  const base = Math.floor(n / m);
  return Array.from({ length: m }, (_, j) => base + (j < n % m ? 1 : 0));
}

export interface TimelinePlan {
  /** new frames of each segment */
  frames: number[];
  /** per segment: new frames of each of its windows */
  windows: number[][];
  total: number;
}

/**
 * Check a timeline and plan its windows. Throws EditError naming the first bad segment (an empty prompt, a
 * length under one frame, a bad seed) or the total over MAX_TIMELINE_SECONDS.
 */
export function planTimeline(segments: readonly TimelineSegment[], limits: EditLimits): TimelinePlan {
  const { fps, maxFrames } = limits;
  const C = OVERLAP_FRAMES;
  if (!Array.isArray(segments) || segments.length === 0) throw new EditError('the timeline has no segments: add one');
  if (!(maxFrames > C)) throw new EditError(`the model's window (${maxFrames} frames) must be longer than the ${C}-frame overlap`);
  const frames: number[] = [];
  const windows: number[][] = [];
  segments.forEach((s, i) => {
    conditionOf(s, i);
    const n = Number.isFinite(s.seconds) ? Math.round(s.seconds * fps) : NaN;
    if (!(n >= 1)) {
      const len = Number.isFinite(s.seconds) ? `is ${fmtS(s.seconds)} long` : Number.isNaN(s.seconds) ? 'has no length' : `is ${String(s.seconds)} long`;
      throw new EditError(`${label(i)} ${len}; a segment needs at least one frame (${fmtS(1 / fps)}): set its seconds or remove it`, i);
    }
    if (!Number.isInteger(s.seed) || s.seed < 0 || s.seed > 0xffffffff) throw new EditError(`${label(i)}: seed must be an integer in 0…4294967295, got ${s.seed}`, i);
    // a segment longer than the whole timeline may be, refused before its windows are counted (1e308 s has Infinity frames)
    if (s.seconds > MAX_TIMELINE_SECONDS) {
      throw new EditError(`${label(i)} is ${s.seconds < 1e6 ? fmtS(s.seconds) : `${s.seconds.toExponential(2)} s`} long; a timeline is at most ${MAX_TIMELINE_SECONDS} s: shorten it`, i);
    }
    frames.push(n);
    windows.push(windowSizes(n, i === 0 ? maxFrames : maxFrames - C, maxFrames - C));
  });
  const total = frames.reduce((a, b) => a + b, 0);
  if (total > MAX_TIMELINE_SECONDS * fps) {
    throw new EditError(`the timeline is ${fmtS(total / fps)} in all; at most ${MAX_TIMELINE_SECONDS} s: shorten or remove a segment`);
  }
  return { frames, windows, total };
}

export interface SegmentResult {
  segment: TimelineSegment;
  /** new frames this segment adds to the timeline */
  frames: number;
  /** its generated windows (the later ones starting with the frames they continue from) */
  windows: EditMotion[];
  /** frames each window repeats from the sequence before it (0 for the timeline's first window) */
  overlaps: number[];
}

export interface Timeline extends EditMotion {
  segments: SegmentResult[];
  /** the first frame of each segment in the whole motion */
  starts: number[];
}

export interface TimelineOptions {
  /** an earlier result: its segments that equal (and precede every change in) the new list are reused as they were */
  previous?: Timeline | null;
  signal?: AbortSignal;
  /** before each window is generated: its segment, and windows done / to do in this call */
  onWindow?: (segment: number, done: number, total: number) => void;
  /** start the windows to generate together (see EditBegin); onWindow is first called with done = 0 before it */
  begin?: EditBegin;
}

const sameSegment = (a: TimelineSegment, b: TimelineSegment) =>
  a.seconds === b.seconds && a.seed === b.seed && (a.prompt ?? '') === (b.prompt ?? '') && a.action === b.action;

/** How many leading segments of `previous` can be kept for `segments` (they are equal and nothing before them changed). */
export function keptSegments(previous: Timeline | null | undefined, segments: readonly TimelineSegment[]): number {
  if (!previous) return 0;
  let i = 0;
  while (i < segments.length && i < previous.segments.length && sameSegment(previous.segments[i].segment, segments[i])) i++;
  return i;
}

/** The segments with segment i's seed changed (to `seed`, or the next uint32): "regenerate segment i". */
export function withNewSeed(segments: readonly TimelineSegment[], i: number, seed?: number): TimelineSegment[] {
  return segments.map((s, k) => (k === i ? { ...s, seed: seed ?? (s.seed + 1) >>> 0 } : { ...s }));
}

function throwIfAborted(signal: AbortSignal | undefined): void {
  if (signal?.aborted) throw new AbortError('timeline cancelled');
}

function checkMotion(m: EditMotion, frames: number, what: string): void {
  if (m.frames !== frames || m.features.length !== frames * D || m.joints.length !== frames * 22 * 3) {
    throw new Error(`${what}: the generator returned ${m.frames} frames (${m.features.length} feature values, ${m.joints.length} joint values); asked for ${frames}`);
  }
}

/** The timeline's whole motion from its segments' windows (features and joints stitched). */
export function stitchTimeline(segments: SegmentResult[], fps: number): Timeline {
  const wins = segments.flatMap((s) => s.windows.map((w, j) => ({ w, c: s.overlaps[j] })));
  const total = wins.reduce((a, { w, c }) => a + w.frames - c, 0);
  const features = new Float32Array(total * D);
  let joints = wins[0].w.joints;
  let frames = wins[0].w.frames;
  features.set(wins[0].w.features, 0);
  for (const { w, c } of wins.slice(1)) {
    // the step into the window's first new frame: the step before it (the window's context, as generateTimeline gave it)
    if (c >= 2) features.copyWithin((frames - 1) * D, (frames - 2) * D, (frames - 2) * D + ROOT_STEP_CHANNELS);
    features.set(w.features.subarray(c * D), frames * D);
    const next = appendSegment(joints, frames, w.joints, w.frames, c);
    joints = next.joints;
    frames = next.frames;
  }
  const starts: number[] = [];
  let at = 0;
  for (const s of segments) {
    starts.push(at);
    at += s.frames;
  }
  return { frames, fps, features, joints: Float32Array.from(joints), segments, starts };
}

/** A window to generate: its segment i, new frames m, seed, and c frames kept from the sequence before it. */
interface PlannedWindow { i: number; m: number; seed: number; c: number }

/** The windows of segments `from`… in order, `sofar` frames of the sequence made before them. */
function windowsToGenerate(segments: readonly TimelineSegment[], plan: TimelinePlan, from: number, sofar: number): PlannedWindow[] {
  const wins: PlannedWindow[] = [];
  for (let i = from; i < segments.length; i++) {
    plan.windows[i].forEach((m, j) => {
      wins.push({ i, m, seed: (segments[i].seed + j) >>> 0, c: Math.min(OVERLAP_FRAMES, sofar) });
      sofar += m;
    });
  }
  return wins;
}

/** A window's keep mask: its first c frames (the sequence's last c) on every channel, then m free frames. */
export const contextKeep = (c: number, m: number): Float32Array => keepMask(c + m, [{ frames: [[0, c - 1]] }]);

/**
 * Generate a timeline window by window (see the header); segments before the first change from
 * `opts.previous` are reused untouched. Bad input throws EditError before anything is generated.
 */
export async function generateTimeline(segments: readonly TimelineSegment[], gen: EditGenerate, limits: EditLimits, opts: TimelineOptions = {}): Promise<Timeline> {
  const plan = planTimeline(segments, limits);
  const keep = keptSegments(opts.previous, segments);
  const out: SegmentResult[] = opts.previous ? opts.previous.segments.slice(0, keep) : [];
  const wins = windowsToGenerate(segments, plan, keep, out.reduce((a, s) => a + s.frames, 0));
  const todo = wins.length;
  let done = 0;
  // every window's steps before its context joins, together: known from the plan alone (frames, seed, overlap)
  let states: SampleState[] | null = null;
  if (opts.begin && todo > 0) {
    const reqs = wins.map(({ i, m, seed, c }): EditBeginRequest => ({
      ...conditionOf(segments[i], i), frames: c + m, seed, stopAt: TIMELINE_KEEP_FROM,
      ...(c ? { keep: contextKeep(c, m), keepFromTime: TIMELINE_KEEP_FROM } : {}),
    }));
    throwIfAborted(opts.signal);
    opts.onWindow?.(keep, 0, todo);
    states = await opts.begin(reqs);
    if (states.length !== reqs.length) throw new Error(`timeline: begin returned ${states.length} states for ${reqs.length} windows`);
  }
  for (let i = keep; i < segments.length; i++) {
    const seg = { ...segments[i] };
    const cond = conditionOf(seg, i);
    const result: SegmentResult = { segment: seg, frames: plan.frames[i], windows: [], overlaps: [] };
    for (let j = 0; j < plan.windows[i].length; j++) {
      throwIfAborted(opts.signal);
      opts.onWindow?.(i, done, todo);
      const { m, seed, c } = wins[done];
      const resume = states ? { resume: states[done] } : {};
      let w: EditMotion;
      if (c === 0) {
        w = await gen({ ...cond, frames: m, seed, ...resume });
      } else {
        // the sequence so far ends with this window's predecessor: its last c frames are the sequence's last c
        const prev = (result.windows.at(-1) ?? out.at(-1)?.windows.at(-1))!;
        const known = new Float32Array((c + m) * D);
        known.set(prev.features.subarray((prev.frames - c) * D), 0);
        // its last frame's step is into the window: the step before it (as easeSeams takes it)
        if (c >= 2) known.copyWithin((c - 1) * D, (c - 2) * D, (c - 2) * D + ROOT_STEP_CHANNELS);
        const keep = contextKeep(c, m);
        const raw = await gen({ ...cond, frames: c + m, seed, known: { features: known, keep, fromTime: TIMELINE_KEEP_FROM }, ...resume });
        checkMotion(raw, c + m, label(i));
        // the seam eased before the next window continues it, no faster than the window before it moves
        const features = easeSeams(raw.features, c + m, keep, SEAM_EASE_FRAMES, D, seamAccel(prev.features, prev.frames));
        w = { ...raw, features, joints: recoverJoints(features, c + m) };
      }
      checkMotion(w, c + m, label(i));
      result.windows.push(w);
      result.overlaps.push(c);
      done++;
    }
    out.push(result);
  }
  throwIfAborted(opts.signal);
  opts.onWindow?.(segments.length - 1, done, todo);
  return stitchTimeline(out, limits.fps);
}

function checkEditable(m: EditMotion, limits: EditLimits, what: string, min: number): void {
  if (m.frames > limits.maxFrames) {
    throw new EditError(`${what} works on a motion of at most ${limits.maxFrames} frames (${fmtS(limits.maxFrames / limits.fps)}), the model's window; this one is ${m.frames} frames (${fmtS(m.frames / m.fps)}): generate a shorter motion first`);
  }
  if (m.frames < min) throw new EditError(`${what} needs a motion of at least ${min} frames (${fmtS(min / m.fps)}); this one is ${m.frames}`);
  if (m.features.length !== m.frames * D) throw new Error(`${what}: the motion has ${m.features.length} feature values, expected ${m.frames} × ${D}`);
}

/** Whether frames 0…a and b…N−1 of an N-frame motion are an in-between's kept ends: a whole frame range each, with at
 * least one frame between them to generate. */
const keepsAMiddle = (N: number, { a, b }: { a: number; b: number }): boolean =>
  Number.isInteger(a) && Number.isInteger(b) && a >= 0 && b <= N - 1 && b - a >= 2;

/**
 * The range `inBetween` keeps for `firstSeconds` at the start and `lastSeconds` at the end of `motion` (frames 0…a and
 * b…N−1), or an EditError in those seconds where they leave no middle to regenerate (the page's in-between fields); a
 * motion `inBetween` cannot edit at all (longer than the model's window, under 3 frames) is refused as it refuses it.
 */
export function inBetweenRange(motion: EditMotion, firstSeconds: number, lastSeconds: number, limits: EditLimits): { a: number; b: number } {
  checkEditable(motion, limits, 'in-betweening', 3);
  if (!(firstSeconds > 0) || !(lastSeconds > 0)) {
    throw new EditError(`in-betweening: keep more than 0 s at each end (got first ${firstSeconds} s, last ${lastSeconds} s)`);
  }
  const N = motion.frames;
  const fps = motion.fps;
  const range = { a: Math.round(firstSeconds * fps) - 1, b: N - Math.round(lastSeconds * fps) };
  if (!keepsAMiddle(N, range)) {
    throw new EditError(`in-betweening: keeping the first ${fmtS(firstSeconds)} and the last ${fmtS(lastSeconds)} of this ${fmtS(N / fps)} motion leaves no middle to regenerate; keep at least ${fmtS(1 / fps)} at each end and at most ${fmtS(N / fps - 1 / fps)} in all`);
  }
  return range;
}

/**
 * In-betweening: keep frames [0, a] and [b, N−1] of `motion` (default: its first and last second; in seconds:
 * `inBetweenRange`) and generate the frames between from `cond`; the kept end stays where it was in the world.
 */
export async function inBetween(motion: EditMotion, cond: EditCondition, seed: number, gen: EditGenerate, limits: EditLimits, range?: { a: number; b: number }): Promise<EditMotion> {
  const c = conditionOf(cond, null);
  const N = motion.frames;
  checkEditable(motion, limits, 'in-betweening', 3);
  const a = range?.a ?? OVERLAP_FRAMES - 1;
  const b = range?.b ?? N - OVERLAP_FRAMES;
  if (!keepsAMiddle(N, { a, b })) {
    throw new EditError(`in-betweening: keep frames 0…a and b…${N - 1} with 0 ≤ a, a + 2 ≤ b ≤ ${N - 1} (at least one frame between); got a = ${a}, b = ${b}`);
  }
  const keep = keepMask(N, [{ frames: [[0, a], [b, N - 1]] }]);
  const r = await gen({ ...c, frames: N, seed, known: { features: Float32Array.from(motion.features), keep } });
  checkMotion(r, N, 'in-betweening');
  // generate() pinned the kept end; ease both seams, then pin again (the easing moved the free frames' root)
  const features = pinKeptRoot(easeSeams(r.features, N, keep), N, keep, motion.features);
  return { ...r, features, joints: recoverJoints(features, N) };
}

/** Which part a body-part edit keeps: 'lower' (root + legs: a new upper body) or 'upper' (new legs and root). */
export type KeptPart = 'lower' | 'upper';
const PART_GROUPS: Record<KeptPart, FeatureGroup[]> = { lower: ['root', 'legs'], upper: ['upper'] };

/** Body-part edit: keep `part` of `motion` on every frame and generate the rest from `cond`. */
export async function bodyPartEdit(motion: EditMotion, part: KeptPart, cond: EditCondition, seed: number, gen: EditGenerate, limits: EditLimits): Promise<EditMotion> {
  const c = conditionOf(cond, null);
  if (!(part in PART_GROUPS)) throw new EditError(`body-part edit: keep 'lower' (root and legs) or 'upper', got ${JSON.stringify(part)}`);
  checkEditable(motion, limits, 'body-part editing', 1);
  const N = motion.frames;
  const keep = keepMask(N, [{ groups: PART_GROUPS[part] }]);
  const r = await gen({ ...c, frames: N, seed, known: { features: Float32Array.from(motion.features), keep } });
  checkMotion(r, N, 'body-part edit');
  return r;
}

export interface LoopResult {
  /** the looping clip: frames [0, N−K) of `full` (export and play this in a loop) */
  clip: EditMotion;
  /** all N frames: frame N−K repeats frame 0's pose */
  full: EditMotion;
}

/**
 * Seamless loop: the last K frames of a new N-frame motion are inpainted to the first K (see the header);
 * `inPlace` zeroes the root's horizontal velocity. `decode` turns the in-place features back into joints
 * (default `recoverJoints`; the page adds its smoothing).
 */
export async function makeLoop(motion: EditMotion, cond: EditCondition, seed: number, gen: EditGenerate, limits: EditLimits,
  opts: { inPlace?: boolean; decode?: (features: Float32Array, frames: number) => Float32Array } = {}): Promise<LoopResult> {
  const c = conditionOf(cond, null);
  const K = LOOP_END_FRAMES;
  const N = motion.frames;
  // a motion longer than the model's window (a timeline) has only its last window W sampled, continuing the frames
  // before it (its first C frames kept, as a timeline window's)
  const longest = MAX_TIMELINE_SECONDS * limits.fps;
  if (N > longest) throw new EditError(`looping works on a motion of at most ${longest} frames (${fmtS(MAX_TIMELINE_SECONDS)}, a timeline's longest); this one is ${N} frames`);
  if (N < 2 * K + 1) throw new EditError(`looping needs a motion of at least ${2 * K + 1} frames (${fmtS((2 * K + 1) / motion.fps)}); this one is ${N}`);
  if (motion.features.length !== N * D) throw new Error(`looping: the motion has ${motion.features.length} feature values, expected ${N} × ${D}`);
  const W = Math.min(N, limits.maxFrames);
  const first = W === N ? K : OVERLAP_FRAMES;
  if (W - K - first < 1) throw new EditError(`looping: the model's window (${limits.maxFrames} frames) leaves no frame to regenerate between the ${first} kept at its start and the ${K} at its end`);
  const known = Float32Array.from(motion.features.subarray((N - W) * D));
  known.set(motion.features.subarray(0, K * D), (W - K) * D);
  const keep = keepMask(W, [{ frames: [[0, first - 1], [W - K, W - 1]] }]);
  const win = await gen({ ...c, frames: W, seed, known: { features: known, keep } });
  checkMotion(win, W, 'looping');
  const eased = new Float32Array(N * D);
  eased.set(motion.features.subarray(0, (N - W) * D), 0);
  eased.set(pinKeptRoot(easeSeams(win.features, W, keep), W, keep, known), (N - W) * D); // as inBetween
  let full: EditMotion = { frames: N, fps: win.fps, features: eased, joints: (opts.decode ?? ((f, n) => recoverJoints(f, n)))(eased, N) };
  if (opts.inPlace) {
    const features = Float32Array.from(full.features);
    for (let t = 0; t < N; t++) {
      features[t * D + 1] = 0;
      features[t * D + 2] = 0;
    }
    full = { frames: N, fps: full.fps, features, joints: (opts.decode ?? ((f, n) => recoverJoints(f, n)))(features, N) };
  }
  const n = N - K;
  const clip: EditMotion = { frames: n, fps: full.fps, features: full.features.slice(0, n * D), joints: full.joints.slice(0, n * 22 * 3) };
  return { clip, full };
}
