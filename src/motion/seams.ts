/**
 * Seams between a kept motion and generated frames (src/edit.ts: timeline windows, in-betweens, loops): how
 * fast a seam's jump may be eased out (`seamEaseFrames`, `seamAccel`, `seamBlendFrames`) and the easing
 * itself (`easeSeams`), on de-normalised features. Python twin: `emdm.motion.edit` (seam_ease_frames,
 * seam_accel, …; the `tiny-edit` parity fixture checks both).
 */
import { recoverJoints } from './recover';

const D = 263;
/** The fewest generated frames over which a seam's offset is eased out (`easeSeams`). */
export const SEAM_EASE_FRAMES = 10;
/** The seam easing's peak joint acceleration, m/s²: a larger jump is eased over more frames (`seamEaseFrames`). */
export const SEAM_EASE_ACCEL = 20; // the median real test clip's 95th percentile of joint acceleration
/** The cross-fade into the generated frames lasts this many frames longer than the offset's fade (`easeSeams`). */
export const SEAM_BLEND_EXTRA = 4;
/** The velocity a seam's cross-fade continues is the kept side's mean over up to this many steps (`easeSeams`; over
 * one, a foot's one-frame jitter at a walk's end was carried on: python -m emdm.eval.seams). */
export const SEAM_BLEND_VELOCITY = 3;
/** The lower bound of a timeline seam's easing acceleration, m/s² (`seamAccel`). */
export const SEAM_EASE_ACCEL_MIN = 5;
/** Frames: the kept side's velocity, continued into the cross-fade, decays with this time constant (or a longer one
 * where a fast kept side would stop faster than the seam's accel: `easeSeams`). */
export const SEAM_BLEND_TAU = 3;

/**
 * Frames m over which `easeSeams` fades a seam's offset `o` (de-normalised features, ≥ 67 values; Python
 * `emdm.motion.edit.seam_ease_frames`): at least `ease`, and enough that the fade's peak joint acceleration,
 * jump·(π/m)²/2·fps², stays within `accel` m/s², jump being the largest offset of a joint position (root height [3],
 * a root-relative joint [4:67], metres): m = max(ease, ⌈π·√(jump·fps²/(2·accel))⌉). 1.5 m (standing → lying): 13.
 */
export function seamEaseFrames(o: ArrayLike<number>, ease = SEAM_EASE_FRAMES, accel = SEAM_EASE_ACCEL, fps = 20): number {
  return Math.max(ease, Math.ceil(Math.PI * Math.sqrt((reach(o) * fps * fps) / (2 * accel)) - 1e-9));
}

/** The largest joint-position distance in a feature difference `d` (root height [3], root-relative joints [4:67], metres). */
function reach(d: ArrayLike<number>): number {
  let r = Math.abs(d[3]);
  for (let j = 0; j < 21; j++) {
    const x = d[4 + 3 * j];
    const y = d[5 + 3 * j];
    const z = d[6 + 3 * j];
    r = Math.max(r, Math.sqrt(x * x + y * y + z * z));
  }
  return r;
}

/**
 * The peak joint acceleration (m/s²) a timeline seam's easing keeps to (Python `emdm.motion.edit.seam_accel`):
 * the 95th percentile (linear interpolation, as numpy) over frames 1..F−2 of the largest joint's |J[t+1] − 2J[t] +
 * J[t−1]|·fps² in the window before the seam (de-normalised features, joints by recoverJoints), within
 * [SEAM_EASE_ACCEL_MIN, SEAM_EASE_ACCEL]: the seam is measured against its own timeline, and a calm one's 95th
 * percentile is a third of a real clip's (climb → walk backward → lie down: 6.6 m/s²; its lie-down, eased to 20,
 * reached 1.77× that at the seam).
 */
export function seamAccel(features: ArrayLike<number>, frames: number, fps = 20, dim = D): number {
  if (frames < 3) return SEAM_EASE_ACCEL;
  const acc = Array.from(jointAccelerations(recoverJoints(Float32Array.from(features), frames, dim), frames, fps).subarray(1, frames - 1));
  acc.sort((x, y) => x - y);
  const pos = 0.95 * (acc.length - 1);
  const lo = Math.floor(pos);
  const p95 = acc[lo] + (acc[Math.min(lo + 1, acc.length - 1)] - acc[lo]) * (pos - lo);
  return Math.min(SEAM_EASE_ACCEL, Math.max(SEAM_EASE_ACCEL_MIN, p95));
}

/**
 * The largest joint's acceleration |J[t+1] − 2J[t] + J[t−1]|·fps² (m/s²) of each frame t = 1..F−2 of frames × 22 × 3
 * joints, 0 at the two ends (Python `emdm.motion.seams.joint_acceleration`): what a seam's easing keeps to.
 */
export function jointAccelerations(j: ArrayLike<number>, frames: number, fps = 20): Float64Array {
  const acc = new Float64Array(frames);
  for (let t = 1; t < frames - 1; t++) {
    let a = 0;
    for (let k = 0; k < 22; k++) {
      let q = 0;
      for (let x = 0; x < 3; x++) {
        const v = j[((t + 1) * 22 + k) * 3 + x] - 2 * j[(t * 22 + k) * 3 + x] + j[((t - 1) * 22 + k) * 3 + x];
        q += v * v;
      }
      a = Math.max(a, Math.sqrt(q) * fps * fps);
    }
    acc[t] = a;
  }
  return acc;
}

/** Frames b of a cross-fade over `r` metres whose peak acceleration r·(π/(b+1))²/2·fps² stays within `accel`. */
export function seamBlendFrames(r: number, accel = SEAM_EASE_ACCEL, fps = 20): number {
  return Math.ceil(Math.PI * Math.sqrt((r * fps * fps) / (2 * accel)) - 1e-9) - 1;
}

/** Root angular and linear velocity, channels [0, 3): frame t's is the root's step from t to t + 1. At a left seam
 * `easeSeams` takes it for the last kept frame from the frame before; callers that keep their own copy of the kept
 * frames take the same step (`generateTimeline` gives it to the window's context before sampling, the live stream
 * writes it back into its buffer). */
export const ROOT_STEP_CHANNELS = 3;

/** The farthest frame k0 + step·q, q = 1…SEAM_BLEND_VELOCITY, with every frame from k0 to it kept (−1: k0 + step is
 * not kept): the kept side's velocity at a seam is (f[k0] − f[k]) / q (Python `_kept_back`). */
function keptBack(kept: boolean[], k0: number, step: number): number {
  let k = -1;
  for (let q = 1; q <= SEAM_BLEND_VELOCITY; q++) {
    const t = k0 + step * q;
    if (t < 0 || t >= kept.length || !kept[t]) break;
    k = t;
  }
  return k;
}

/**
 * Ease out the jump between kept frames and generated ones (Python `emdm.motion.edit.ease_seams`, the same
 * arithmetic): the sampler keeps the known frames exactly, but the model's first generated frame need not
 * continue them (emdm-t2m-web, 10 steps: timeline seams up to 117× the 95th percentile of joint acceleration
 * without this), and where the new prompt's pose is far from the kept one it jumps there in one frame (lie-down
 * after raised hands: root height 0.89 → 0.08 m). For every run [s, e) of frames with no kept channel, next to a
 * frame kept whole: o_L = f[s−1] + v − f[s] (v: the mean of f[s−1] − f[s−2] when s−2 is kept and f[s+1] − f[s]
 * when s+1 < e), o_R = f[e] − v − f[e−1] (v: the mean of f[e+1] − f[e] when e+1 is kept and f[e−1] − f[e−2] when
 * e−2 ≥ s), both from the un-eased features, contacts zeroed; then f[s+i] += w_i·o_L and f[e−1−i] += w_i·o_R with
 * w_i = (1 + cos(π·i/m))/2, i < m = min(seamEaseFrames(o), e − s): a large jump fades over more frames (a fixed 10
 * made the 1.5 m one a 0.5 s fall, 2× the timeline's 95th percentile at the seam; a long fade is a blend the action
 * classifier reads as another action: the trade-off is measured in the Python twin's doc). Then each seam is
 * cross-faded from the kept side's motion continued, c_i = k + v·τ·(1 − exp(−(i+1)/τ)) (k the kept frame at the
 * seam, v its mean velocity over the up to SEAM_BLEND_VELOCITY kept frames beyond it (`keptBack`), or 0; τ = max(SEAM_BLEND_TAU, r(v)·fps²/accel), r the largest joint
 * distance: stopping a fast kept side stays within accel), into the eased frames: f[s+i] ← (1 − β_i)·c_i +
 * β_i·f[s+i], β_i = (1 − cos(π(i+1)/(b+1)))/2, b = min(m + SEAM_BLEND_EXTRA, e − s), left seam then right (mirrored):
 * the offset fixes where the first generated frame is, the cross-fade damps the model's own fast first frames
 * (raised hands dropped in two frames: 13× the 95th percentile). Foot contacts [259:263] stay; frames kept in part
 * (body-part edits) are left alone. First of all, at a left seam with two kept frames before it, the last kept frame's
 * root velocity [0:3] becomes the one before it (`ROOT_STEP_CHANNELS`): it is the step into the first generated frame,
 * which the window before a timeline's seam never took (its last frames wander: 3 of 144 timeline seams had root
 * jumps over 1.5× the timeline's 95th percentile, each on that step).
 */
export function easeSeams(features: ArrayLike<number>, frames: number, keep: ArrayLike<number>, ease = SEAM_EASE_FRAMES, dim = D, accel = SEAM_EASE_ACCEL): Float32Array {
  if (features.length !== frames * dim || keep.length !== frames * dim) {
    throw new RangeError(`easeSeams: features (${features.length}) and keep (${keep.length}) must both hold frames (${frames}) × ${dim} values`);
  }
  const f = Float64Array.from(features);
  const kept: boolean[] = [];
  const free: boolean[] = [];
  for (let t = 0; t < frames; t++) {
    let all = true;
    let any = false;
    for (let c = 0; c < dim; c++) {
      if (keep[t * dim + c] === 1) any = true;
      else all = false;
    }
    kept.push(all);
    free.push(!any);
  }
  // a left seam's last kept frame: its root velocity [0:3] is its step into the first generated frame (the seam's,
  // not the kept motion's), so it repeats the step before it (Python twin's doc)
  for (let s = 2; s < frames; s++) {
    if (free[s] && kept[s - 1] && kept[s - 2]) for (let c = 0; c < ROOT_STEP_CHANNELS; c++) f[(s - 1) * dim + c] = f[(s - 2) * dim + c];
  }
  const row = (t: number) => f.subarray(t * dim, (t + 1) * dim);
  const adds: { t: number; w: number; o: Float64Array }[] = [];
  /** cross-fades, in order: kept frame k0 at the seam, k1 the farthest of up to SEAM_BLEND_VELOCITY kept frames beyond it (or −1), the first generated row `at` and the
   * direction `step` from the seam out, the fade's frames b and the most the run allows */
  const blends: { k0: number; k1: number; at: number; step: number; b: number; most: number }[] = [];
  const offset = (base: Float64Array, sign: number, terms: [Float64Array, Float64Array][], to: Float64Array) => {
    const o = new Float64Array(dim);
    for (let c = 0; c < dim; c++) {
      let v = 0;
      for (const [a, b] of terms) v += a[c] - b[c];
      o[c] = base[c] + (terms.length ? (sign * v) / terms.length : 0) - to[c];
    }
    for (let c = 259; c < Math.min(263, dim); c++) o[c] = 0;
    return o;
  };
  for (let t = 0; t < frames; ) {
    if (!free[t]) {
      t++;
      continue;
    }
    const s = t;
    while (t < frames && free[t]) t++;
    const e = t;
    const fade = (o: Float64Array) => {
      const m = Math.min(seamEaseFrames(o, ease, accel), e - s);
      return { w: Array.from({ length: m }, (_, i) => 0.5 * (1 + Math.cos((Math.PI * i) / m))), b: Math.min(m + SEAM_BLEND_EXTRA, e - s) };
    };
    if (s >= 1 && kept[s - 1]) {
      const beyond = s >= 2 && kept[s - 2] ? s - 2 : -1; // a second kept frame: the kept side's velocity
      const terms: [Float64Array, Float64Array][] = [];
      if (beyond >= 0) terms.push([row(s - 1), row(beyond)]);
      if (s + 1 < e) terms.push([row(s + 1), row(s)]);
      const o = offset(row(s - 1), 1, terms, row(s));
      const { w, b } = fade(o);
      w.forEach((wi, i) => adds.push({ t: s + i, w: wi, o }));
      blends.push({ k0: s - 1, k1: keptBack(kept, s - 1, -1), at: s, step: 1, b, most: e - s });
    }
    if (e < frames && kept[e]) {
      const beyond = e + 1 < frames && kept[e + 1] ? e + 1 : -1;
      const terms: [Float64Array, Float64Array][] = [];
      if (beyond >= 0) terms.push([row(beyond), row(e)]);
      if (e - 2 >= s) terms.push([row(e - 1), row(e - 2)]);
      const o = offset(row(e), -1, terms, row(e - 1));
      const { w, b } = fade(o);
      w.forEach((wi, i) => adds.push({ t: e - 1 - i, w: wi, o }));
      blends.push({ k0: e, k1: keptBack(kept, e, 1), at: e - 1, step: -1, b, most: e - s });
    }
  }
  for (const { t, w, o } of adds) {
    for (let c = 0; c < dim; c++) f[t * dim + c] += w * o[c];
  }
  for (const { k0, k1, at, step, b: fadeB, most } of blends) {
    // the kept side's motion continued, row i from the seam out: its velocity v decays at a rate (peak |v|/τ·fps²)
    // within accel
    const vel = new Float64Array(dim);
    if (k1 >= 0) for (let c = 0; c < dim; c++) vel[c] = (f[k0 * dim + c] - f[k1 * dim + c]) / Math.abs(k0 - k1);
    const tau = Math.max(SEAM_BLEND_TAU, (reach(vel) * 20 * 20) / accel); // fps 20, as seamBlendFrames
    const gone = (i: number) => tau * (1 - Math.exp(-(i + 1) / tau)); // row i: k0 + v·gone(i)
    // longer where the model's first frames leave the continued motion further than the fade's b can take
    let far = 0;
    const d = new Float64Array(67);
    for (let i = 0; i < fadeB; i++) {
      const t = at + step * i;
      const g = gone(i);
      for (let c = 3; c < 67; c++) d[c] = f[t * dim + c] - (f[k0 * dim + c] + vel[c] * g);
      far = Math.max(far, reach(d));
    }
    const b = Math.min(Math.max(fadeB, seamBlendFrames(far, accel)), most);
    for (let i = 0; i < b; i++) {
      const t = at + step * i;
      const g = gone(i);
      const beta = 0.5 * (1 - Math.cos((Math.PI * (i + 1)) / (b + 1)));
      for (let c = 0; c < dim; c++) {
        if (c >= 259 && c < 263) continue; // foot contacts stay
        f[t * dim + c] = (1 - beta) * (f[k0 * dim + c] + vel[c] * g) + beta * f[t * dim + c];
      }
    }
  }
  return Float32Array.from(f);
}
