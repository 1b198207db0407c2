/**
 * The live stream's bookkeeping (issue 33), without a clock or a model: which window to generate next, and how a
 * generated window joins the motion being played. src/live/stream.ts runs it against a clock; Python twin
 * `emdm.motion.live` (the `tiny-live` parity fixture checks both).
 *
 * The contract (frames at `fps`, C = OVERLAP_FRAMES, W = window frames; frame numbers are the stream's clock):
 * - The buffer holds frames [base, end) of de-normalised features and joints (stage coordinates). The first window
 *   is an ordinary generation of C + W frames. Every later one is a timeline window (src/edit.ts): C + W frames, its
 *   first C kept from the buffer's frames [cut − C, cut) (imposed from TIMELINE_KEEP_FROM on), seed = seed0 + r
 *   (r: windows requested so far, dropped ones included).
 * - Next window: when fewer than `lead` frames are buffered after the playhead p (end − 1 − p < lead): cut = end.
 *   A prompt: the window in preparation is dropped, cut = clamp(p + promptLead, base + C, end): it continues the
 *   motion that will be playing when it is ready.
 * - Accepting a window at playhead p: eased as a timeline window (`easeSeams` at `seamAccel` of the C + W frames
 *   before the cut). Late (p ≥ cut: frames cut…p were shown from the old buffer) it is eased again with those shown
 *   frames kept too (k = C + p + 1 − cut kept frames), so the blend starts at p + 1; a window with nothing left after
 *   them is dropped. Joints: recovered, turned and shifted onto the buffer's frame cut + k − C − 1 (`alignSegment`);
 *   the buffer is cut there and the window's frames after the kept ones appended.
 * - Underrun (nothing buffered at the playhead): the motion is played back from its last frame (mirrored: frame
 *   end − 1 + i repeats frame end − 1 − i, velocities negated), COAST_FRAMES at a time, and counted; never a still frame.
 * - Stage: after a window, when the root at the buffer's last frame is over RECENTRE_M from the stage's centre in
 *   x or z, every buffered joint moves by whole metres back towards it (`origin` adds up the moves: world = joints +
 *   origin). Heights are never moved (the features' root height is absolute: no drift).
 * - Memory: frames before p − recordFrames are dropped (the record buffer; the rest is playback).
 */
import { type EditCondition, type EditLimits, EditError, OVERLAP_FRAMES, TIMELINE_KEEP_FROM, conditionOf, contextKeep } from '../edit';
import { recoverJoints } from '../motion/recover';
import { SEAM_EASE_FRAMES, easeSeams, seamAccel } from '../motion/seams';
import { alignSegment } from '../motion/stitch';
import type { KnownMotion } from '../sampler/mask';

const D = 263;
const JV = 22 * 3;
/** New frames of a live window (2 s at 20 fps): chosen by measurement (docs/RESULTS.md "Live stream"). */
export const LIVE_WINDOW_FRAMES = 40;
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

export interface LiveSettings {
  window: number;
  lead: number;
  promptLead: number;
  recordSeconds: number;
}

export const LIVE_DEFAULTS: LiveSettings = { window: LIVE_WINDOW_FRAMES, lead: LIVE_LEAD_FRAMES, promptLead: LIVE_PROMPT_LEAD_FRAMES, recordSeconds: LIVE_RECORD_SECONDS };

/** A window to generate: its condition, seed, frames (c kept + new), and where it joins (`cut`). */
export interface LiveWindowRequest extends EditCondition {
  id: number;
  seed: number;
  frames: number;
  c: number;
  cut: number;
  /** requested by a prompt (not by the lead running low) */
  prompted: boolean;
  /** the context it continues, de-normalised (EditRequest's `known`), imposed from TIMELINE_KEEP_FROM on */
  known?: Required<KnownMotion>;
}

/** What accepting a window did: the first frame it changed (`from`), or dropped (nothing left after the shown frames). */
export interface LiveAccepted {
  from: number;
  late: number;
  dropped: boolean;
}

export class LiveCore {
  readonly fps: number;
  readonly settings: LiveSettings;
  base = 0;
  frames = 0;
  features: Float32Array = new Float32Array(0);
  joints: Float32Array = new Float32Array(0);
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
    for (const k of ['window', 'lead', 'promptLead'] as const) {
      if (!Number.isInteger(s[k]) || s[k] < (k === 'window' ? 1 : 0)) throw new EditError(`live: ${k} must be a whole number of frames${k === 'window' ? ' ≥ 1' : ' ≥ 0'}, got ${s[k]}`);
    }
    if (OVERLAP_FRAMES + s.window > limits.maxFrames) throw new EditError(`live: a window of ${s.window} new frames + ${OVERLAP_FRAMES} kept exceeds the model's ${limits.maxFrames}`);
    this.cond = liveCondition(cond);
  }

  get end(): number {
    return this.base + this.frames;
  }

  get condition(): EditCondition {
    return { ...this.cond };
  }

  private next(cut: number, prompted: boolean): LiveWindowRequest {
    const seed = (this.seed + this.requested++) >>> 0;
    const id = this.requested;
    const W = this.settings.window;
    if (this.frames === 0) return (this.pending = { ...this.cond, id, seed, frames: OVERLAP_FRAMES + W, c: 0, cut: 0, prompted });
    const c = OVERLAP_FRAMES;
    const known = new Float32Array((c + W) * D);
    known.set(this.features.subarray((cut - c - this.base) * D, (cut - this.base) * D), 0);
    return (this.pending = { ...this.cond, id, seed, frames: c + W, c, cut, prompted, known: { features: known, keep: contextKeep(c, W), fromTime: TIMELINE_KEEP_FROM } });
  }

  /** The window to start now at playhead p (null: one is under way, or enough is buffered). */
  request(p: number): LiveWindowRequest | null {
    if (this.pending) return null;
    if (this.frames > 0 && this.end - 1 - p >= this.settings.lead) return null;
    return this.next(this.end, false);
  }

  /** A new prompt at playhead p: the window in preparation is dropped; the new one's request. */
  prompt(cond: EditCondition | string, p: number): LiveWindowRequest {
    this.cond = liveCondition(cond);
    this.pending = null;
    if (this.frames === 0) return this.next(0, true);
    const cut = Math.min(this.end, Math.max(this.base + OVERLAP_FRAMES, p + this.settings.promptLead));
    return this.next(cut, true);
  }

  /** Join a generated window (raw de-normalised features, req.frames × 263) at playhead p; a stale one is ignored (null). */
  accept(req: LiveWindowRequest, raw: Float32Array, p: number): LiveAccepted | null {
    if (this.pending?.id !== req.id) return null;
    this.pending = null;
    if (raw.length !== req.frames * D) throw new Error(`live: the generator returned ${raw.length / D} frames; asked for ${req.frames}`);
    if (req.c === 0 && this.frames === 0) {
      this.features = Float32Array.from(raw);
      this.joints = recoverJoints(this.features, req.frames);
      this.frames = req.frames;
      return { from: 0, late: 0, dropped: false };
    }
    const { c, cut } = req;
    this.extend(p);
    const before = Math.min(req.frames, cut - this.base);
    let f: Float32Array = easeSeams(raw, req.frames, req.known!.keep, SEAM_EASE_FRAMES, D, seamAccel(this.rows(this.features, cut - before, cut, D), before));
    const late = Math.max(0, p + 1 - cut);
    const k = c + late;
    if (k >= req.frames) return { from: cut, late, dropped: true };
    if (late > 0) {
      const known = Float32Array.from(f);
      known.set(this.rows(this.features, cut, cut + late, D), c * D);
      f = easeSeams(known, req.frames, contextKeep(k, req.frames - k), SEAM_EASE_FRAMES, D, seamAccel(this.rows(this.features, cut + late - before, cut + late, D), before));
    }
    const aligned = alignSegment(this.rows(this.joints, cut + late - k, cut + late, JV), k, recoverJoints(f, req.frames), req.frames, k);
    this.splice(cut + late, f.subarray(k * D), aligned.subarray(k * JV));
    this.recentre();
    this.trim(p);
    return { from: cut + late, late, dropped: false };
  }

  /** Frames [a, b) of a per-frame buffer (stream frame numbers). */
  private rows(buf: Float32Array, a: number, b: number, w: number): Float32Array {
    return buf.subarray((a - this.base) * w, (b - this.base) * w);
  }

  private splice(at: number, f: Float32Array, j: Float32Array): void {
    const keep = at - this.base;
    const n = f.length / D;
    const features = new Float32Array((keep + n) * D);
    features.set(this.features.subarray(0, keep * D), 0);
    features.set(f, keep * D);
    const joints = new Float32Array((keep + n) * JV);
    joints.set(this.joints.subarray(0, keep * JV), 0);
    joints.set(j, keep * JV);
    this.features = features;
    this.joints = joints;
    this.frames = keep + n;
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
      for (let i = 1; i <= n; i++) {
        const src = this.features.subarray((last - i) * D, (last - i + 1) * D);
        const row = f.subarray((i - 1) * D, i * D);
        row.set(src);
        for (const c of [0, 1, 2]) row[c] = -src[c];
        for (let c = 193; c < 259; c++) row[c] = -src[c];
        j.set(this.joints.subarray((last - i) * JV, (last - i + 1) * JV), (i - 1) * JV);
      }
      this.splice(this.end, f, j);
      this.coasted += n;
    }
  }

  private recentre(): void {
    const o = (this.frames - 1) * JV;
    const shift = [0, 2].map((x) => (Math.abs(this.joints[o + x]) > RECENTRE_M ? Math.trunc(this.joints[o + x]) : 0));
    if (!shift[0] && !shift[1]) return;
    for (let i = 0; i < this.joints.length; i += 3) {
      this.joints[i] -= shift[0];
      this.joints[i + 2] -= shift[1];
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
    this.base = from;
    this.frames -= k;
  }

  /** Joints of frame p (22 × 3, stage coordinates; a copy), frame p made available first (`extend`). */
  frameAt(p: number): Float32Array {
    if (this.frames === 0) throw new EditError('live: no frame yet (the first window is not ready)');
    const q = Math.max(p, this.base);
    this.extend(q);
    return this.joints.slice((q - this.base) * JV, (q - this.base + 1) * JV);
  }
}

/** A live prompt: text (non-empty) or an action; EditError otherwise. */
export function liveCondition(c: EditCondition | string): EditCondition {
  if (typeof c === 'string') return conditionOf({ prompt: c }, null);
  if (c === null || typeof c !== 'object') throw new EditError(`live: a prompt is text or {action}, got ${String(c)}`);
  return conditionOf(c, null);
}
