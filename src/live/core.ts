/**
 * The live stream's bookkeeping (issue 33), without a clock or a model: which window to generate next, and how a
 * generated window joins the motion being played. src/live/stream.ts runs it against a clock; Python twin
 * `emdm.motion.live` (the `tiny-live` parity fixture checks both).
 *
 * The contract (frames at `fps`, C = OVERLAP_FRAMES, W = window frames; frame numbers are the stream's clock):
 * - The buffer holds frames [base, end) of de-normalised features and joints (stage coordinates). The first window
 *   is an ordinary generation of C + W frames. Every later one is a timeline window (src/edit.ts): C + W frames, its
 *   first C kept from the buffer's frames [cut − C, cut) (the last one's root velocity, its step into the window, the
 *   one before it, as in a timeline; imposed from TIMELINE_KEEP_FROM on; in a prompt's window from
 *   LIVE_PROMPT_KEEP_FROM on), seed = seed0 + r
 *   (r: windows requested so far, dropped ones included).
 * - Next window: when fewer than `lead` frames are buffered after the playhead p (end − 1 − p < lead): cut = end.
 * - Lead: adapted to what windows cost. A window's cost is the frames played between its request and its join
 *   (p − start). After each join (or drop for being too late), with need = ⌈LEAD_SAFETY · cost⌉: need > lead raises
 *   the lead to min(maxLead, need) at once (a late window is an underrun the visitor sees); need ≤ lead / 2
 *   (comfortably early) lowers it by LEAD_STEP_DOWN frames, never below the configured `lead`.
 *   A prompt: the window in preparation is dropped, cut = clamp(p + promptLead, base + C, end): it continues the
 *   motion that will be playing when it is ready.
 * - Accepting a window at playhead p: eased as a timeline window (`easeSeams` at `seamAccel` of the C + W frames
 *   before the cut). Late (p ≥ cut: frames cut…p were shown from the old buffer) it is eased again with those shown
 *   frames kept too (k = C + p + 1 − cut kept frames, frame cut − 1 as shown), so the blend starts at p + 1; a window
 *   with nothing left after them is dropped. Joints: recovered, turned and shifted onto the buffer's frame
 *   cut + k − C − 1 (`alignSegment`); the buffer is cut there and the window's frames after the kept ones appended,
 *   the frame before them taking the window's step into them (its root velocity [0:3]).
 * - Display (what frameAt gives, what record keeps): the joints as a generated motion is shown (`decodeJoints`: σ = 1
 *   smoothing, feet cleaned up) of each whole window (its kept frames give the smoothing and the clean-up their past),
 *   moved as its recovered joints are. Causal where it joins: frames up to the playhead never change; from
 *   s = max(p + 1, at − LIVE_DISPLAY_PAD) on the window's display replaces the buffer's, plus the difference between
 *   the buffer's display and the window's at frame s − 1 (the last one kept), faded out linearly over
 *   LIVE_DISPLAY_FADE frames (weights 1 − (i + 1)/(FADE + 1)), so the display stays continuous where it joins; a faded
 *   frame whose lowest foot joint is then below the floor is lifted by that depth (as the clean-up's floor step).
 * - Underrun (nothing buffered at the playhead): the motion is played back from its last frame (mirrored: frame
 *   end − 1 + i repeats frame end − 1 − i, velocities negated; its display likewise), COAST_FRAMES at a time, and
 *   counted; never a still frame.
 * - Stage: when the root shown at the playhead (after a window joins, and at every frameAt) is over RECENTRE_M from
 *   the stage's centre in x or z, every buffered joint moves by whole metres back towards it (`origin` adds up the
 *   moves: world = joints + origin; the display moves with them), so what plays stays within RECENTRE_M + 1 m of it
 *   however far the buffer reaches ahead (a raised lead holds up to 8 s: 24 m of running). Heights are never moved (the
 *   features' root height is absolute: no drift).
 * - Memory: frames before p − recordFrames are dropped (the record buffer; the rest is playback).
 */
import { type EditCondition, type EditLimits, EditError, OVERLAP_FRAMES, TIMELINE_KEEP_FROM, conditionOf, contextKeep } from '../edit';
import { decodeJoints } from '../motion/decode';
import type { FootRig } from '../motion/footContact';
import { recoverJoints } from '../motion/recover';
import { ROOT_STEP_CHANNELS, SEAM_EASE_FRAMES, easeSeams, seamAccel } from '../motion/seams';
import { alignSegment } from '../motion/stitch';
import type { KnownMotion } from '../sampler/mask';
import { FOOT_JOINT_NAMES, JOINT_NAMES, PARENTS } from '../skeleton';

const D = 263;
const JV = 22 * 3;
/** New frames of a live window (3 s at 20 fps). With 40 the covered actions' live segments were recognised as their
 * prompt 86–89 % of the time against 92–94 % alone (a jog in a circle, a throw, a climb began again from each window's
 * second of context); with 60 as often as alone, blends as smooth (Python twin `WINDOW`, where the figures are;
 * docs/RESULTS.md "Seams and loops"). */
export const LIVE_WINDOW_FRAMES = 60;
/** The next window is started when fewer frames than this are buffered after the playhead. */
export const LIVE_LEAD_FRAMES = 30;
/** A prompt's window continues the motion this many frames after the playhead (what plays when it is ready). */
export const LIVE_PROMPT_LEAD_FRAMES = 8;
/** Seconds of motion kept behind the playhead (what `record` gives). */
export const LIVE_RECORD_SECONDS = 60;
/** Frames played back at a time when nothing is buffered (an underrun). */
export const COAST_FRAMES = 10;
/** The root is moved back towards the stage's centre (by whole metres) once this far from it in x or z. */
export const RECENTRE_M = 2;
/** The lead is never raised past this (6 s): a window that costs more than half of it cannot be hidden by buffering. */
export const LIVE_MAX_LEAD_FRAMES = 120;
/** The lead is raised to this many times the last window's cost when it is short of it. */
export const LEAD_SAFETY = 2;
/** Frames the lead comes down after a comfortably early window (cost ≤ lead / (2 · LEAD_SAFETY)). */
export const LEAD_STEP_DOWN = 4;
/** A window's display replaces the buffer's from this many frames before its join (the σ = 1 smoothing's radius). */
export const LIVE_DISPLAY_PAD = 3;
/** Frames over which the difference between a window's display and the one it replaces is faded out. */
export const LIVE_DISPLAY_FADE = 6;
/** A prompt's window imposes its kept second only at steps with t ≤ this and the last (later windows: TIMELINE_KEEP_FROM,
 * 0.55), so more of its steps belong to the new prompt: with 0.55 its segment was recognised as the prompt 85 % of the
 * time against 94 % alone, at 10 steps with the context at the last step only 93 %, blends as smooth (Python twin
 * `PROMPT_KEEP_FROM`, where the figures are). */
export const LIVE_PROMPT_KEEP_FROM = 0.15;
/** The rig the display's foot clean-up reads (the reference skeleton's structure). */
const RIG: FootRig = { parents: [...PARENTS], footJoints: FOOT_JOINT_NAMES.map((n) => JOINT_NAMES.indexOf(n)) };

export interface LiveSettings {
  window: number;
  /** the starting and lowest lead (frames) */
  lead: number;
  /** the highest the lead is raised to when windows come late (frames; = lead: no adaptation) */
  maxLead: number;
  promptLead: number;
  recordSeconds: number;
}

export const LIVE_DEFAULTS: LiveSettings = {
  window: LIVE_WINDOW_FRAMES, lead: LIVE_LEAD_FRAMES, maxLead: LIVE_MAX_LEAD_FRAMES, promptLead: LIVE_PROMPT_LEAD_FRAMES, recordSeconds: LIVE_RECORD_SECONDS,
};

/** A window to generate: its condition, seed, frames (c kept + new), and where it joins (`cut`). */
export interface LiveWindowRequest extends EditCondition {
  id: number;
  seed: number;
  frames: number;
  c: number;
  cut: number;
  /** requested by a prompt (not by the lead running low) */
  prompted: boolean;
  /** the playhead when it was requested (its cost is counted from here) */
  start: number;
  /** the context it continues, de-normalised (EditRequest's `known`), imposed from TIMELINE_KEEP_FROM on (a prompt's: LIVE_PROMPT_KEEP_FROM) */
  known?: Required<KnownMotion>;
}

/** What accepting a window did: the first frame it changed (`from`) and the first frame of display it changed
 * (`shown`), or dropped (nothing left after the shown frames); `cost`: frames played while it was generated. */
export interface LiveAccepted {
  from: number;
  shown: number;
  late: number;
  dropped: boolean;
  cost: number;
}

export class LiveCore {
  readonly fps: number;
  readonly settings: LiveSettings;
  base = 0;
  frames = 0;
  features: Float32Array = new Float32Array(0);
  joints: Float32Array = new Float32Array(0);
  /** the joints as shown (see the header): frames × 22 × 3, stage coordinates */
  display: Float32Array = new Float32Array(0);
  /** the lead in use (frames), adapted to what windows cost */
  lead: number;
  /** frames [from, to) of display were replaced or added (the stream's poses of them are stale) */
  onChange?: (from: number, to: number) => void;
  origin: [number, number] = [0, 0];
  pending: LiveWindowRequest | null = null;
  requested = 0;
  underruns = 0;
  coasted = 0;
  private cond: EditCondition;

  constructor(readonly limits: EditLimits, cond: EditCondition | string, readonly seed: number, settings: Partial<LiveSettings> = {}) {
    this.fps = limits.fps;
    this.settings = { ...LIVE_DEFAULTS, ...settings };
    const s = this.settings;
    if (!Number.isInteger(seed) || seed < 0 || seed > 0xffffffff) throw new EditError(`live: seed must be an integer in 0…4294967295, got ${seed}`);
    for (const k of ['window', 'lead', 'maxLead', 'promptLead'] as const) {
      if (!Number.isInteger(s[k]) || s[k] < (k === 'window' ? 1 : 0)) throw new EditError(`live: ${k} must be a whole number of frames${k === 'window' ? ' ≥ 1' : ' ≥ 0'}, got ${s[k]}`);
    }
    if (s.maxLead < s.lead) throw new EditError(`live: maxLead (${s.maxLead} frames) must be at least lead (${s.lead})`);
    this.lead = s.lead;
    if (OVERLAP_FRAMES + s.window > limits.maxFrames) throw new EditError(`live: a window of ${s.window} new frames + ${OVERLAP_FRAMES} kept exceeds the model's ${limits.maxFrames}`);
    this.cond = liveCondition(cond);
  }

  get end(): number {
    return this.base + this.frames;
  }

  get condition(): EditCondition {
    return { ...this.cond };
  }

  private next(cut: number, prompted: boolean, start: number): LiveWindowRequest {
    const seed = (this.seed + this.requested++) >>> 0;
    const id = this.requested;
    const W = this.settings.window;
    if (this.frames === 0) return (this.pending = { ...this.cond, id, seed, frames: OVERLAP_FRAMES + W, c: 0, cut: 0, prompted, start });
    const c = OVERLAP_FRAMES;
    const known = new Float32Array((c + W) * D);
    known.set(this.features.subarray((cut - c - this.base) * D, (cut - this.base) * D), 0);
    known.copyWithin((c - 1) * D, (c - 2) * D, (c - 2) * D + ROOT_STEP_CHANNELS); // its step is into the window (as in a timeline)
    return (this.pending = { ...this.cond, id, seed, frames: c + W, c, cut, prompted, start, known: { features: known, keep: contextKeep(c, W), fromTime: prompted ? LIVE_PROMPT_KEEP_FROM : TIMELINE_KEEP_FROM } });
  }

  /** The window to start now at playhead p (null: one is under way, or enough is buffered). */
  request(p: number): LiveWindowRequest | null {
    if (this.pending) return null;
    if (this.frames > 0 && this.end - 1 - p >= this.lead) return null;
    return this.next(this.end, false, p);
  }

  /** A new prompt at playhead p: the window in preparation is dropped; the new one's request. */
  prompt(cond: EditCondition | string, p: number): LiveWindowRequest {
    this.cond = liveCondition(cond);
    this.pending = null;
    if (this.frames === 0) return this.next(0, true, p);
    const cut = Math.min(this.end, Math.max(this.base + OVERLAP_FRAMES, p + this.settings.promptLead));
    return this.next(cut, true, p);
  }

  /** Join a generated window (raw de-normalised features, req.frames × 263) at playhead p; a stale one is ignored (null). */
  accept(req: LiveWindowRequest, raw: Float32Array, p: number): LiveAccepted | null {
    if (this.pending?.id !== req.id) return null;
    this.pending = null;
    if (raw.length !== req.frames * D) throw new Error(`live: the generator returned ${raw.length / D} frames; asked for ${req.frames}`);
    const cost = Math.max(0, p - req.start);
    if (req.c === 0 && this.frames === 0) {
      this.features = Float32Array.from(raw);
      this.joints = recoverJoints(this.features, req.frames);
      this.display = decodeJoints(this.features, req.frames, RIG, { smooth: true, footCleanup: true });
      this.frames = req.frames;
      this.onChange?.(0, this.end);
      return { from: 0, shown: 0, late: 0, dropped: false, cost };
    }
    const { c, cut } = req;
    this.extend(p);
    this.adapt(cost);
    const before = Math.min(req.frames, cut - this.base);
    let f: Float32Array = easeSeams(raw, req.frames, req.known!.keep, SEAM_EASE_FRAMES, D, seamAccel(this.rows(this.features, cut - before, cut, D), before));
    const late = Math.max(0, p + 1 - cut);
    const k = c + late;
    if (k >= req.frames) return { from: cut, shown: cut, late, dropped: true, cost };
    if (late > 0) {
      const known = Float32Array.from(f);
      known.set(this.rows(this.features, cut - 1, cut + late, D), (c - 1) * D); // as shown (the first easing took a step out of row c − 1)
      f = easeSeams(known, req.frames, contextKeep(k, req.frames - k), SEAM_EASE_FRAMES, D, seamAccel(this.rows(this.features, cut + late - before, cut + late, D), before));
    }
    const at = cut + late;
    const prev = this.rows(this.joints, at - k, at, JV);
    const rec = recoverJoints(f, req.frames);
    const aligned = alignSegment(prev, k, rec, req.frames, k);
    const shown = alignSegment(prev, k, decodeJoints(f, req.frames, RIG, { smooth: true, footCleanup: true }), req.frames, k, rec);
    const s = Math.max(p + 1, at - LIVE_DISPLAY_PAD, this.base);
    this.splice(at, f.subarray(k * D), aligned.subarray(k * JV), s, shown.subarray((k - (at - s) - 1) * JV));
    // the step into the window's first new frame is the seam's (easeSeams)
    if (at - 1 >= this.base) this.features.set(f.subarray((k - 1) * D, (k - 1) * D + ROOT_STEP_CHANNELS), (at - 1 - this.base) * D);
    this.recentre(p);
    this.trim(p);
    return { from: at, shown: s, late, dropped: false, cost };
  }

  /** The lead after a window that cost `cost` frames (see the header). */
  private adapt(cost: number): void {
    const need = Math.ceil(LEAD_SAFETY * cost);
    const { lead, maxLead } = this.settings;
    if (need > this.lead) this.lead = Math.min(maxLead, need);
    else if (2 * need <= this.lead) this.lead = Math.max(lead, this.lead - LEAD_STEP_DOWN);
  }

  /** Frames [a, b) of a per-frame buffer (stream frame numbers). */
  private rows(buf: Float32Array, a: number, b: number, w: number): Float32Array {
    return buf.subarray((a - this.base) * w, (b - this.base) * w);
  }

  /** Features and joints from frame `at` on; display from frame `s` ≤ at on, `d` holding it from frame s − 1 on: its
   * difference to the buffer's display at s − 1 is faded out over LIVE_DISPLAY_FADE frames. */
  private splice(at: number, f: Float32Array, j: Float32Array, s: number, d: Float32Array): void {
    const keep = at - this.base;
    const n = f.length / D;
    const features = new Float32Array((keep + n) * D);
    features.set(this.features.subarray(0, keep * D), 0);
    features.set(f, keep * D);
    const joints = new Float32Array((keep + n) * JV);
    joints.set(this.joints.subarray(0, keep * JV), 0);
    joints.set(j, keep * JV);
    const display = new Float32Array((keep + n) * JV);
    const ks = s - this.base;
    display.set(this.display.subarray(0, ks * JV), 0);
    display.set(d.subarray(JV), ks * JV);
    for (let i = 0; i < LIVE_DISPLAY_FADE && ks + i < keep + n && ks > 0; i++) {
      const w = 1 - (i + 1) / (LIVE_DISPLAY_FADE + 1);
      const o = (ks + i) * JV;
      for (let x = 0, q = (ks - 1) * JV; x < JV; x++) display[o + x] += w * (this.display[q + x] - d[x]);
      const low = Math.min(...RIG.footJoints.map((j) => display[o + j * 3 + 1]));
      if (low < 0) for (let y = o + 1; y < o + JV; y += 3) display[y] -= low; // the floor stays under the feet
    }
    this.features = features;
    this.joints = joints;
    this.display = display;
    this.frames = keep + n;
    this.onChange?.(s, this.end);
  }

  /** Make frame p buffered: play the motion back from its last frame (an underrun) while it is not. */
  extend(p: number): void {
    if (this.frames === 0 || p < this.end) return;
    this.underruns++;
    while (p >= this.end) {
      const n = Math.min(COAST_FRAMES, this.frames - 1);
      const last = this.frames - 1;
      const f = new Float32Array(n * D);
      const j = new Float32Array(n * JV);
      const d = new Float32Array(n * JV);
      for (let i = 1; i <= n; i++) {
        const src = this.features.subarray((last - i) * D, (last - i + 1) * D);
        const row = f.subarray((i - 1) * D, i * D);
        row.set(src);
        for (const c of [0, 1, 2]) row[c] = -src[c];
        for (let c = 193; c < 259; c++) row[c] = -src[c];
        j.set(this.joints.subarray((last - i) * JV, (last - i + 1) * JV), (i - 1) * JV);
        d.set(this.display.subarray((last - i) * JV, (last - i + 1) * JV), (i - 1) * JV);
      }
      const dd = new Float32Array((n + 1) * JV);
      dd.set(this.display.subarray(last * JV, (last + 1) * JV), 0);
      dd.set(d, JV);
      this.splice(this.end, f, j, this.end, dd);
      this.coasted += n;
    }
  }

  /** Move the stage back under the root shown at frame p (see the header). */
  private recentre(p: number): void {
    const o = (Math.min(Math.max(p, this.base), this.end - 1) - this.base) * JV;
    const shift = [0, 2].map((x) => (Math.abs(this.display[o + x]) > RECENTRE_M ? Math.trunc(this.display[o + x]) : 0));
    if (!shift[0] && !shift[1]) return;
    for (const a of [this.joints, this.display]) {
      for (let i = 0; i < a.length; i += 3) {
        a[i] -= shift[0];
        a[i + 2] -= shift[1];
      }
    }
    this.origin = [this.origin[0] + shift[0], this.origin[1] + shift[1]];
  }

  /** Drop frames before p − recordSeconds (always keeping C frames before the earliest cut a prompt may take). */
  trim(p: number): void {
    const from = Math.min(p - Math.round(this.settings.recordSeconds * this.fps), this.end - OVERLAP_FRAMES - this.settings.window);
    if (from <= this.base) return;
    const k = from - this.base;
    this.features = this.features.slice(k * D);
    this.joints = this.joints.slice(k * JV);
    this.display = this.display.slice(k * JV);
    this.base = from;
    this.frames -= k;
  }

  /** Joints of frame p as shown (display, 22 × 3, stage coordinates; a copy), frame p made available first (`extend`);
   * the stage is first moved under the root of frame `centre` (the playhead: reading frames ahead, or behind, of it
   * must not move the stage away from what plays). */
  frameAt(p: number, centre = p): Float32Array {
    if (this.frames === 0) throw new EditError('live: no frame yet (the first window is not ready)');
    const q = Math.max(p, this.base);
    this.extend(q);
    this.recentre(Math.max(centre, this.base));
    return this.display.slice((q - this.base) * JV, (q - this.base + 1) * JV);
  }
}

/** A live prompt: text (non-empty) or an action; EditError otherwise. */
export function liveCondition(c: EditCondition | string): EditCondition {
  if (typeof c === 'string') return conditionOf({ prompt: c }, null);
  if (c === null || typeof c !== 'object') throw new EditError(`live: a prompt is text or {action}, got ${String(c)}`);
  return conditionOf(c, null);
}
