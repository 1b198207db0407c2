// Keeping the character in the picture: the page's follow point (web/ui/follow.ts) and the library's
// frameMotion (src/three.ts), on motions that travel as far as a run does.
import { PerspectiveCamera, Vector3 } from 'three';
import { describe, expect, it } from 'vitest';
import { frameMotion } from '../../src/three';
import { RootFollower } from '../../web/ui/follow';

/** A straight run along +X at `speed` m/s, `frames` at 20 fps, 22 joints spread ±0.3 m around a 0.9 m pelvis. */
function run(speed: number, frames: number): { joints: Float32Array; frames: number } {
  const joints = new Float32Array(frames * 22 * 3);
  for (let f = 0; f < frames; f++) {
    for (let j = 0; j < 22; j++) {
      const o = (f * 22 + j) * 3;
      joints[o] = (speed * f) / 20 + 0.3 * Math.sin(j);
      joints[o + 1] = 0.9 + 0.8 * Math.cos(j * 1.3);
      joints[o + 2] = 0.3 * Math.cos(j * 0.7);
    }
  }
  return { joints, frames };
}

describe('RootFollower', () => {
  it('sits on a root moving at a steady 3 m/s (a plain trail with the same time constant lags 1 m)', () => {
    const f = new RootFollower();
    const dt = 1 / 30;
    let x = 0;
    for (let i = 0; i < 120; i++) {
      x += 3 * dt;
      f.update([x, 0.9, 0], dt);
    }
    expect(Math.abs(f.point.x - x)).toBeLessThan(0.05);
    expect(f.point.y).toBeCloseTo(0.9);
  });

  it('snaps onto the root on the first frame and on a jump (a loop wrapping to its start), and returns the move', () => {
    const f = new RootFollower();
    expect(f.update([4, 0, -2], 1 / 60).toArray()).toEqual([4, 0, -2]);
    expect(f.point.toArray()).toEqual([4, 0.9, -2]);
    for (let i = 1; i <= 30; i++) f.update([4 + i * 0.05, 0, -2], 1 / 60); // 3 m/s
    const before = f.point.x;
    expect(before).toBeGreaterThan(5);
    const moved = f.update([0, 0, 0], 1 / 60).clone(); // 5.5 m in one frame: a wrap
    expect(f.point.toArray()).toEqual([0, 0.9, 0]);
    expect(moved.x).toBeCloseTo(-before, 6);
    f.update([0.05, 0, 0], 1 / 60); // the velocity was forgotten: no lead from before the wrap
    expect(f.point.x).toBeGreaterThan(0);
    expect(f.point.x).toBeLessThan(0.05);
  });

  it('trails smoothly: a 0.4 m step of the root moves the point only part of the way in one frame', () => {
    const f = new RootFollower();
    f.update([0, 0, 0], 1 / 60);
    f.update([0.4, 0, 0], 1 / 60);
    expect(f.point.x).toBeGreaterThan(0);
    expect(f.point.x).toBeLessThan(0.4);
  });
});

describe('frameMotion', () => {
  for (const [speed, aspect] of [[3.4, 16 / 9], [1.3, 9 / 16], [0, 1]] as const) {
    it(`every joint of every frame in the picture: ${speed} m/s for 4 s, aspect ${aspect.toFixed(2)}`, () => {
      const m = run(speed, 80);
      const camera = new PerspectiveCamera(40, aspect, 0.1, 100);
      camera.position.set(7, 2.6, 7.5);
      camera.lookAt(0, 0.9, 2.5);
      const dirBefore = camera.getWorldDirection(new Vector3());
      const target = frameMotion(camera, m);
      expect(camera.getWorldDirection(new Vector3()).dot(dirBefore)).toBeCloseTo(1, 6); // same view direction
      const v = new Vector3();
      let worst = 0;
      for (let i = 0; i < m.joints.length; i += 3) {
        v.set(m.joints[i], m.joints[i + 1], m.joints[i + 2]).project(camera);
        worst = Math.max(worst, Math.abs(v.x), Math.abs(v.y));
        expect(v.z).toBeLessThan(1);
      }
      expect(worst).toBeLessThanOrEqual(1);
      expect(worst).toBeGreaterThan(0.75); // framed (the box's corners fitted), not lost in the distance
      expect(target.x).toBeCloseTo((speed * 79) / 20 / 2, 0);
    });
  }

  it('says what is wrong with a motion without joints', () => {
    expect(() => frameMotion(new PerspectiveCamera(), { joints: new Float32Array(0), frames: 0 })).toThrow(/no joints/);
  });
});
