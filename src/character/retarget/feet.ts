/**
 * Feet on the floor (retarget.ts's step 6): on our contact frames each foot of the character is held where
 * ours is held and put at its rest height; the root makes the feet's mean horizontal move and the vertical
 * move that leaves them nearest their targets, and a two-bone IK on thigh and shin moves each ankle the
 * rest of the way (within `maxPin` of our motion's direction). Three per-frame passes (contact positions,
 * root, legs), each yielding the share of the retargeting done; the result is the number of pinned frames,
 * and `deltas` / `rootPs` are corrected in place.
 */
import { type Matrix4, type Quaternion, Vector3 } from 'three';
import { twoBoneIK } from '../../motion/math3';
import type { JointName } from '../../skeleton';
import { arr, swing, v } from './drives';
import { type RestRig, posOf, poseFrame } from './rest';

export interface FootInputs {
  rig: RestRig;
  frames: number;
  /** contact channel c (0..3: l_ankle, l_foot, r_ankle, r_foot) is on at frame f */
  contact(f: number, c: number): boolean;
  /** our joint's world position at frame f */
  P(f: number, j: JointName): Vector3;
  /** character leg / our leg */
  scale: number;
  /** our ankle's and toe's heights on the floor */
  ho: number;
  hoToe: number;
  blend: number;
  /** radians: the most a pin may turn thigh or shin */
  maxPin: number;
  /** per frame: slot → world delta rotation (thigh and shin corrected in place) */
  deltas: Map<number, Quaternion>[];
  /** per frame: the pelvis bone's position (corrected in place) */
  rootPs: Vector3[];
  /** the share of the retargeting done after frame f of pass `pass` */
  done(pass: number, f: number): number;
}

type Side = 'l' | 'r';
interface LegPlan {
  s: Side;
  /** per frame: how far the ankle should move (null: not at all) */
  move: (Vector3 | null)[];
  /** per frame: the weight of that move (1 on contact, fading over `blend` frames) */
  wgt: Float64Array;
}

const LEGS = (['l', 'r'] as const).map((s, c) => ({ s, c: c * 2 }));

/** Pin the feet (see the file's comment); returns the number of frames a foot was pinned on (both feet counted). */
export function* pinFeet(x: FootInputs): Generator<number, number, void> {
  const { ankles, toes } = yield* contactPositions(x);
  const plans = LEGS.map(({ s, c }, li) => planLeg(x, s, c, ankles[li], toes[li]));
  yield* moveRoot(x, plans);
  return yield* turnLegs(x, plans);
}

/** Pass 1: the character's ankle and toe positions on every frame, as driven so far. */
function* contactPositions(x: FootInputs) {
  const ankles = LEGS.map(() => [] as Vector3[]);
  const toes = LEGS.map(() => [] as Vector3[]);
  for (let f = 0; f < x.frames; f++) {
    const { M } = poseFrame(x.rig, x.deltas[f], x.rootPs[f], true);
    LEGS.forEach(({ s }, li) => {
      ankles[li].push(posOf(x.rig, M, `${s}_ankle`));
      if (x.rig.mapped(`${s}_foot`)) toes[li].push(posOf(x.rig, M, `${s}_foot`));
    });
    yield x.done(1, f);
  }
  return { ankles, toes };
}

/**
 * Per frame: how far the ankle should move. On a contact frame: horizontally, the joint in contact (the ankle
 * where the heel is down, else the toe) onto its mean position over that contact run (as our clean-up pinned
 * it); vertically, so that the lower of heel (ankle) and ball (toe) is at its rest height, i.e. on the floor
 * (per frame: the foot rolls from heel to toe as ours does). In the fades (blend frames on both sides of a
 * stretch of contact frames), the correction of the stretch's first/last frame, scaled down, so a fade our
 * own clean-up already made is not made twice.
 */
function planLeg(x: FootInputs, s: Side, c: number, ankles: Vector3[], toes: Vector3[]): LegPlan {
  const { rig, frames, contact, P, scale, ho, hoToe, blend } = x;
  const move: (Vector3 | null)[] = new Array(frames).fill(null);
  const wgt = new Float64Array(frames);
  const restA = rig.restPos(`${s}_ankle`).y;
  const restT = rig.mapped(`${s}_foot`) ? rig.restPos(`${s}_foot`).y : null;
  const hasToe = restT !== null;
  const heel = (f: number) => contact(f, c);
  const ball = (f: number) => hasToe && contact(f, c + 1);
  // a rig without a toe bone, on the ball of its foot only: its ankle as high above its rest height
  // as ours is above our standing ankle height (scaled), where ours rolls forward (not held)
  const tiptoe = (f: number) => !hasToe && !contact(f, c) && contact(f, c + 1);
  const held = heldPositions(frames, heel, ankles);
  if (hasToe) {
    const toeHeld = heldPositions(frames, ball, toes);
    for (let f = 0; f < frames; f++) if (!heel(f) && toeHeld[f]) held[f] = toeHeld[f];
  }
  const correction = (f: number): Vector3 => {
    if (tiptoe(f)) {
      // the ball is on the floor: only the foot's pitch raises the ankle, not a lift of our whole foot
      // (our toe above its floor height on a frame flagged as ball contact)
      const lift = Math.max(0, P(f, `${s}_foot`).y - hoToe);
      return new Vector3(0, scale * Math.max(0, P(f, `${s}_ankle`).y - ho - lift) - (ankles[f].y - restA), 0);
    }
    const pt = heel(f) ? ankles[f] : toes[f];
    const dy = Math.min(ankles[f].y - restA, hasToe ? toes[f].y - restT! : Infinity);
    return new Vector3(held[f]!.x - pt.x, -dy, held[f]!.z - pt.z);
  };
  let start = -1;
  for (let f = 0; f <= frames; f++) {
    const on = f < frames && (held[f] !== null || tiptoe(f));
    if (on && start < 0) start = f;
    if (!on && start >= 0) {
      const e = f - 1;
      const first = correction(start);
      const last = correction(e);
      for (let g = Math.max(0, start - blend); g <= Math.min(frames - 1, e + blend); g++) {
        const w = g < start ? 1 - (start - g) / (blend + 1) : g > e ? 1 - (g - e) / (blend + 1) : 1;
        if (w > wgt[g]) {
          wgt[g] = w;
          move[g] = (g < start ? first.clone() : g > e ? last.clone() : correction(g)).multiplyScalar(w);
        }
      }
      start = -1;
    }
  }
  return { s, move, wgt };
}

/** The held horizontal position of each frame where `on`: the mean of `pts` over its run of such frames. */
function heldPositions(frames: number, on: (f: number) => boolean, pts: Vector3[]): (Vector3 | null)[] {
  const held: (Vector3 | null)[] = new Array(frames).fill(null);
  let start = -1;
  for (let f = 0; f <= frames; f++) {
    const o = f < frames && on(f);
    if (o && start < 0) start = f;
    if (!o && start >= 0) {
      const m = new Vector3();
      for (let g = start; g < f; g++) m.add(pts[g]);
      m.divideScalar(f - start);
      for (let g = start; g < f; g++) held[g] = m;
      start = -1;
    }
  }
  return held;
}

/** Thigh and shin turns that move the ankle A by d (two-bone IK in the knee's plane). */
function legPin(H: Vector3, K: Vector3, A: Vector3, d: Vector3) {
  const r = twoBoneIK(arr(H), arr(A.clone().add(d)), arr(K), H.distanceTo(K), K.distanceTo(A));
  const q1 = swing(K.clone().sub(H), v(r.knee).sub(H));
  const shin = A.clone().sub(K).applyQuaternion(q1);
  const q2 = swing(shin, v(r.ankle).sub(v(r.knee)));
  const turn = Math.max(K.clone().sub(H).angleTo(v(r.knee).sub(H)), A.clone().sub(K).angleTo(v(r.ankle).sub(v(r.knee))));
  return { q1, q2, turn, reached: v(r.ankle) };
}

const legAt = (rig: RestRig, M: Matrix4[], s: Side) => ({ H: posOf(rig, M, `${s}_hip`), K: posOf(rig, M, `${s}_knee`), A: posOf(rig, M, `${s}_ankle`) });

/** The largest part t of a move (all of it where possible) that turns thigh and shin by at most
 * maxPin: near a straight leg a small move of the ankle would swing the whole leg. */
function reach(maxPin: number, solve: (t: number) => ReturnType<typeof legPin>) {
  let best = solve(1);
  if (best.turn <= maxPin) return { ...best, t: 1 };
  let lo = 0;
  let hi = 1;
  best = solve(0);
  for (let it = 0; it < 10; it++) {
    const mid = (lo + hi) / 2;
    const m = solve(mid);
    if (m.turn > maxPin) hi = mid;
    else {
      lo = mid;
      best = m;
    }
  }
  return { ...best, t: lo };
}

/**
 * Pass 2: the root takes the weighted mean of the feet's horizontal moves (no limb turns for that); its
 * vertical move is, among heights between the feet's needs, the one that leaves the feet nearest their
 * targets once the legs have done what they can (a nearly straight leg can hardly reach further, a bent one
 * can); the legs make the rest.
 */
function* moveRoot(x: FootInputs, plans: LegPlan[]) {
  for (let f = 0; f < x.frames; f++) {
    yield x.done(2, f);
    const active = plans.filter((p) => p.wgt[f] > 0);
    if (!active.length) continue;
    const corr = new Vector3();
    let sw = 0;
    for (const p of active) {
      corr.addScaledVector(p.move[f]!, p.wgt[f]);
      sw += p.wgt[f];
    }
    corr.divideScalar(sw);
    if (active.length > 1) corr.y = rootHeight(x, f, active, corr);
    x.rootPs[f].add(corr);
    for (const p of active) p.move[f] = p.move[f]!.clone().sub(corr);
  }
}

/** Frame f's vertical root move with both feet active: a search between the feet's needs. */
function rootHeight(x: FootInputs, f: number, active: LegPlan[], corr: Vector3): number {
  const { M } = poseFrame(x.rig, x.deltas[f], x.rootPs[f], true);
  const legs = active.map((p) => legAt(x.rig, M, p.s));
  const ys = active.map((p) => p.move[f]!.y);
  const lo = Math.min(...ys);
  const hi = Math.max(...ys);
  const cost = (y: number) => Math.max(...active.map((p, k) => {
    // how far (vertically) the ankle stays from its target: what the cap leaves, or out of reach
    const d = p.move[f]!.clone().sub(new Vector3(corr.x, y, corr.z));
    const { reached } = reach(x.maxPin, (t) => legPin(legs[k].H, legs[k].K, legs[k].A, d.clone().multiplyScalar(t)));
    return p.wgt[f] * Math.abs(legs[k].A.y + d.y - reached.y); // a foot fading in/out counts less
  }));
  let best = lo;
  let bestCost = cost(best);
  // (stops once the feet are within 0.1 mm: most frames need no search)
  for (let k = 1; k <= 16 && bestCost > 1e-4 * (legs[0].H.distanceTo(legs[0].K) / 0.4); k++) {
    const y = lo + ((hi - lo) * k) / 16;
    const c = cost(y);
    if (c < bestCost - 1e-9) {
      best = y;
      bestCost = c;
    }
  }
  return best;
}

/** Pass 3: thigh and shin turn so each ankle makes the rest of its move; every other driven bone (the
 * ankle's too) keeps its world rotation. Returns the pinned frames (both feet counted). */
function* turnLegs(x: FootInputs, plans: LegPlan[]) {
  const { rig } = x;
  let pinnedFrames = 0;
  for (let f = 0; f < x.frames; f++) {
    yield x.done(3, f);
    if (!plans.some((p) => p.wgt[f] > 0)) continue;
    const { M } = poseFrame(rig, x.deltas[f], x.rootPs[f], true);
    for (const { s, move, wgt } of plans) {
      if (!(wgt[f] > 0)) continue;
      pinnedFrames++;
      const { H, K, A } = legAt(rig, M, s);
      const { q1, q2 } = reach(x.maxPin, (t) => legPin(H, K, A, move[f]!.clone().multiplyScalar(t)));
      const d = x.deltas[f];
      const hipSlot = rig.S(`${s}_hip`);
      const kneeSlot = rig.S(`${s}_knee`);
      d.set(hipSlot, q1.clone().multiply(d.get(hipSlot)!));
      d.set(kneeSlot, q2.clone().multiply(q1).multiply(d.get(kneeSlot)!));
    }
  }
  return pinnedFrames;
}
