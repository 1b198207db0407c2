// What the denoising steps change in a motion, measured on the joints the page shows (the compare view's small
// chart, issue 30): jerk (how unsteady the movement is), foot skate (how much a foot slides while it is on the
// floor) and speed (to set beside the real clips of the prompt's action). Pure functions over frames × 22 joints × 3 (metres, Y up, floor at y = 0), at `fps` frames per second.

/** The SMPL-order foot joints (l_foot, r_foot): the ball of each foot, the part that rests on the floor. */
export const FOOT_JOINTS = [10, 11] as const;
/**
 * A foot joint below this height (m) touches the floor: the definition of scripts/emdm/eval/plausibility.py (its
 * skate_cm_s), so the page's figure reads like docs/results' realism tables (real walking clips: about 38 cm/s).
 */
export const CONTACT_HEIGHT = 0.05;

export interface MotionFigures {
  /** mean magnitude of the third difference of every joint's position, in m/s³ (NaN with fewer than 4 frames) */
  jerk: number;
  /** mean horizontal speed of a foot joint between two frames in which it touches the floor (below CONTACT_HEIGHT), in
   * cm/s (NaN: never) */
  footSkate: number;
  /** median horizontal speed of the root (pelvis) between two frames, in m/s (NaN with fewer than 2 frames): the
   * realism benchmark's speed (scripts/emdm/eval/kinematics.py descriptors), as the capabilities file's realSpeed */
  speed: number;
}

/** The median of a non-empty list (the mean of the middle two for an even count, as numpy's). */
function median(xs: number[]): number {
  const s = [...xs].sort((a, b) => a - b);
  const m = s.length >> 1;
  return s.length % 2 ? s[m] : (s[m - 1] + s[m]) / 2;
}

/** Jerk, foot skate and speed of a motion (see MotionFigures). `joints` holds frames × J × 3 values. */
export function motionFigures(joints: ArrayLike<number>, frames: number, fps: number, J = 22): MotionFigures {
  const at = (f: number, j: number, k: number) => joints[(f * J + j) * 3 + k];
  let jerkSum = 0;
  let jerkN = 0;
  for (let f = 3; f < frames; f++) {
    for (let j = 0; j < J; j++) {
      let sq = 0;
      for (let k = 0; k < 3; k++) {
        const d = at(f, j, k) - 3 * at(f - 1, j, k) + 3 * at(f - 2, j, k) - at(f - 3, j, k);
        sq += d * d;
      }
      jerkSum += Math.sqrt(sq);
      jerkN++;
    }
  }
  let skateSum = 0;
  let skateN = 0;
  for (let f = 1; f < frames; f++) {
    for (const j of FOOT_JOINTS) {
      if (!(at(f, j, 1) < CONTACT_HEIGHT && at(f - 1, j, 1) < CONTACT_HEIGHT)) continue;
      skateSum += Math.hypot(at(f, j, 0) - at(f - 1, j, 0), at(f, j, 2) - at(f - 1, j, 2));
      skateN++;
    }
  }
  const root: number[] = [];
  for (let f = 1; f < frames; f++) root.push(Math.hypot(at(f, 0, 0) - at(f - 1, 0, 0), at(f, 0, 2) - at(f - 1, 0, 2)) * fps);
  return {
    jerk: jerkN ? (jerkSum / jerkN) * fps ** 3 : NaN,
    footSkate: skateN ? (skateSum / skateN) * fps * 100 : NaN,
    speed: root.length ? median(root) : NaN,
  };
}
