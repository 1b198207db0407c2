// The compare view's figures (web/ui/motion-figures.ts) on motions whose answer is known.
import { describe, expect, it } from 'vitest';
import type { Capabilities } from '../../src/capabilities';
import { realSpeedNote, realSpeedOf } from '../../web/ui/compare-figures';
import { FOOT_JOINTS, motionFigures } from '../../web/ui/motion-figures';

const J = 22;
const FPS = 20;

/** frames × 22 joints, each placed by `pos(f, j)`. */
function motion(frames: number, pos: (f: number, j: number) => [number, number, number]): Float32Array {
  const out = new Float32Array(frames * J * 3);
  for (let f = 0; f < frames; f++) for (let j = 0; j < J; j++) out.set(pos(f, j), (f * J + j) * 3);
  return out;
}

describe('motionFigures', () => {
  it('a body gliding at a steady 1 m/s on the floor: no jerk, feet skating at 100 cm/s', () => {
    const m = motion(40, (f, j) => [f / FPS, j === 10 || j === 11 ? 0.03 : 0.5 + j * 0.05, 0]);
    const r = motionFigures(m, 40, FPS);
    expect(r.jerk).toBeLessThan(0.01); // float32 rounding × fps³
    expect(r.footSkate).toBeCloseTo(100, 3);
  });

  it('jerk: one joint with x = t³ has third difference 6·dt³ each frame, i.e. 6 m/s³, averaged over 22 joints', () => {
    const m = motion(30, (f, j) => [j === 5 ? (f / FPS) ** 3 : 0, 1, 0]);
    expect(motionFigures(m, 30, FPS).jerk).toBeCloseTo(6 / J, 3);
  });

  it('a foot only counts while below 5 cm: a lifted foot moving fast adds nothing', () => {
    // left foot planted (still) on the floor; right foot 0.3 m up, moving 2 m/s
    const m = motion(20, (f, j) => (j === FOOT_JOINTS[0] ? [0, 0.02, 0] : j === FOOT_JOINTS[1] ? [2 * f / FPS, 0.32, 0] : [0, 1, 0]));
    const r = motionFigures(m, 20, FPS);
    expect(r.footSkate).toBe(0);
    // never on the floor (a motion of fewer than 2 frames): NaN, not 0
    expect(motionFigures(m, 1, FPS).footSkate).toBeNaN();
    expect(motionFigures(m, 3, FPS).jerk).toBeNaN();
  });

  it('speed: the median horizontal root speed, m/s (one jump of the root does not move it; height does not count)', () => {
    // the pelvis walks 1.2 m/s along x, bobbing up and down, and teleports 1 m sideways once
    const m = motion(41, (f, j) => [j === 0 ? 1.2 * f / FPS : 0, 1 + 0.05 * Math.sin(f), j === 0 && f >= 20 ? 1 : 0]);
    expect(motionFigures(m, 41, FPS).speed).toBeCloseTo(1.2, 4);
    expect(motionFigures(m, 1, FPS).speed).toBeNaN();
  });
});

describe("the real clips' speed beside the figure", () => {
  const walk = { median: 1.11, low: 0.55, high: 1.43, clips: 90 };
  const caps = { actions: [{ label: 'walk-turn-left', rate: 1, covered: true, realSpeed: walk }, { label: 'kick', rate: 0, covered: false }] } as unknown as Capabilities;

  it("is the prompt's nearest action's, from the capabilities file, only for a prompt the check knows", () => {
    const check = { known: true, score: 0.9, action: 'walk-turn-left', covered: true, nearest: [] };
    expect(realSpeedOf(caps, check)).toEqual({ action: 'walk-turn-left', speed: walk });
    expect(realSpeedNote(realSpeedOf(caps, check)!)).toBe('real walk turn left 0.55–1.43');
    expect(realSpeedOf(caps, { ...check, known: false })).toBeNull();          // far prompt: its "nearest" action is a guess
    expect(realSpeedOf(caps, { ...check, action: 'kick' })).toBeNull();        // no real clips
    expect(realSpeedOf(null, check)).toBeNull();
    expect(realSpeedOf(caps, undefined)).toBeNull();
  });
});
