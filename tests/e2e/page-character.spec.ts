// The page's skinned character and its player, checked in Node (no browser needed): the body is built
// on the manifest's reference skeleton with smooth, normalised skin weights; posing the bones moves
// the right vertices; the player interpolates the 20 fps poses and loops.
import fs from 'node:fs';
import path from 'node:path';
import { expect, test } from '@playwright/test';
import { Box3, Quaternion, Vector3 } from 'three';
import { bodyParts, buildBodyGeometry, chainWeights } from '../../src/character/body';
import { applyPose, createCharacter } from '../../src/character/character';
import { MotionPlayer, samplePose, type PoseTrack } from '../../src/character/player';
import { restPositions } from '../../src/character/rig';
import type { SkeletonLike } from '../../src/skeleton';

const MANIFEST = path.join(process.cwd(), 'public/models/manifest.json');

function skeleton(): SkeletonLike {
  return JSON.parse(fs.readFileSync(MANIFEST, 'utf8')).skeleton;
}

/** World position of vertex i after skinning. */
function skinned(ch: ReturnType<typeof createCharacter>, i: number): Vector3 {
  ch.object.updateMatrixWorld(true);
  ch.skeleton.update();
  const v = new Vector3().fromBufferAttribute(ch.mesh.geometry.getAttribute('position'), i);
  return ch.mesh.applyBoneTransform(i, v).applyMatrix4(ch.mesh.matrixWorld);
}

test.describe('character', () => {
  test('chain weights are a smooth partition of unity, 50/50 at each joint', () => {
    const at = [0.1, 0.4];
    let worst = 0;
    let minW = 1;
    for (let u = -0.2; u <= 0.7; u += 0.01) {
      const w = chainWeights([3, 5, 7], at, 0.05, u);
      worst = Math.max(worst, Math.abs(w.reduce((a, [, x]) => a + x, 0) - 1));
      for (const [, x] of w) minW = Math.min(minW, x);
    }
    expect(worst).toBeLessThan(1e-9);
    expect(minW).toBeGreaterThan(0);
    const atJoint = chainWeights([3, 5, 7], at, 0.05, 0.1);
    expect(atJoint.map(([b]) => b)).toEqual([3, 5]);
    for (const [, x] of atJoint) expect(x).toBeCloseTo(0.5, 12);
    expect(chainWeights([3, 5, 7], at, 0.05, 0.25)).toEqual([[5, 1]]);
    expect(() => chainWeights([1, 2], [], 0.05, 0)).toThrow(/2 bones need 1 joints/);
  });

  test('the rest body stands on the floor, about 1.75 m tall, left/right symmetric, weights normalised', () => {
    const s = skeleton();
    const g = buildBodyGeometry(s);
    const box = new Box3().setFromBufferAttribute(g.getAttribute('position') as never);
    expect(box.min.y).toBeGreaterThan(-0.02);
    expect(box.min.y).toBeLessThan(0.02);
    expect(box.max.y).toBeGreaterThan(1.65);
    expect(box.max.y).toBeLessThan(1.85);
    expect(box.min.x + box.max.x).toBeCloseTo(0, 3);
    const idx = g.getAttribute('skinIndex');
    const wt = g.getAttribute('skinWeight');
    let worstSum = 0;
    let maxIndex = 0;
    for (let i = 0; i < wt.count; i++) {
      let sum = 0;
      for (let k = 0; k < 4; k++) {
        sum += wt.getComponent(i, k);
        maxIndex = Math.max(maxIndex, idx.getComponent(i, k));
      }
      worstSum = Math.max(worstSum, Math.abs(sum - 1));
    }
    expect(worstSum).toBeLessThan(1e-6);
    expect(maxIndex).toBe(s.joints.length - 1);
    expect(bodyParts(s).map((p) => p.name)).toEqual(expect.arrayContaining(['trunk', 'head', 'l-hand', 'r-foot', 'l-thigh']));
  });

  test('bending the left knee moves the shin and foot, not the thigh top or the other leg', () => {
    const s = skeleton();
    const ch = createCharacter(s);
    const rest = restPositions(s);
    const J = (n: string) => s.joints.indexOf(n);
    const pos = ch.mesh.geometry.getAttribute('position');
    const near = (p: Vector3) => {
      let best = 0;
      let d = Infinity;
      for (let i = 0; i < pos.count; i++) {
        const q = new Vector3().fromBufferAttribute(pos, i);
        if (q.distanceTo(p) < d) [best, d] = [i, q.distanceTo(p)];
      }
      return best;
    };
    const lAnkle = near(rest[J('l_ankle')].clone().add(new Vector3(0, 0.05, 0.04)));
    const lThighTop = near(rest[J('l_hip')].clone().add(new Vector3(0.09, -0.05, 0)));
    const rAnkle = near(rest[J('r_ankle')].clone().add(new Vector3(0, 0.05, 0.04)));
    const before = [lAnkle, lThighTop, rAnkle].map((i) => skinned(ch, i));
    const quats = new Float32Array(s.joints.length * 4);
    for (let j = 0; j < s.joints.length; j++) quats[j * 4 + 3] = 1;
    new Quaternion().setFromAxisAngle(new Vector3(1, 0, 0), Math.PI / 2).toArray(quats as unknown as number[], J('l_knee') * 4);
    applyPose(ch.bones, s.offsets[0], quats);
    const after = [lAnkle, lThighTop, rAnkle].map((i) => skinned(ch, i));
    expect(after[0].distanceTo(before[0])).toBeGreaterThan(0.3); // a 90° knee bend swings the ankle ~0.4 m
    expect(after[0].y).toBeGreaterThan(before[0].y + 0.3); // backwards-up, not through the floor
    expect(after[1].distanceTo(before[1])).toBeLessThan(0.005);
    expect(after[2].distanceTo(before[2])).toBeLessThan(1e-6);
    // Translating the root moves every vertex by the same amount.
    applyPose(ch.bones, [1, s.offsets[0][1], -2], quats);
    expect(skinned(ch, rAnkle).sub(after[2]).distanceTo(new Vector3(1, 0, -2))).toBeLessThan(1e-5);
    ch.dispose();
  });

  test('the player interpolates between 20 fps frames and loops', () => {
    const q0 = new Quaternion();
    const q1 = new Quaternion().setFromAxisAngle(new Vector3(0, 1, 0), Math.PI / 2);
    const track: PoseTrack = {
      frames: 3, fps: 20, joints: 1,
      rootPos: Float32Array.of(0, 0, 0, 1, 0, 0, 1, 0, 2),
      quats: Float32Array.of(...q0.toArray(), ...q1.toArray(), ...q1.toArray()),
    };
    const root = new Float32Array(3);
    const q = new Float32Array(4);
    expect(samplePose(track, 0.025, root, q)).toBeCloseTo(0.5, 9); // halfway between frames 0 and 1
    expect(Array.from(root)).toEqual([0.5, 0, 0]);
    const half = new Quaternion().setFromAxisAngle(new Vector3(0, 1, 0), Math.PI / 4);
    const got = Array.from(q);
    half.toArray().forEach((v, k) => expect(got[k]).toBeCloseTo(v, 6)); // slerp: 45° of the 90° turn
    const p = new MotionPlayer();
    p.setTrack(track);
    expect(p.duration).toBeCloseTo(0.15, 9); // 3 frames at 20 fps: the last one shown for its 0.05 s
    p.update(0.075);
    expect(p.frame).toBeCloseTo(1.5, 6);
    p.update(0.05); // the last frame's own time: held, not past the end
    expect([p.time, p.frame]).toEqual([expect.closeTo(0.125, 6), 2]);
    p.update(0.05); // past the end: wraps to 0.025 s
    expect(p.time).toBeCloseTo(0.025, 6);
    p.speed = 0.5;
    p.update(0.05);
    expect(p.time).toBeCloseTo(0.05, 6);
    p.playing = false;
    p.update(1);
    expect(p.time).toBeCloseTo(0.05, 6);
    p.seek(5);
    expect(p.time).toBeCloseTo(0.15, 9);
    expect(() => p.setTrack({ ...track, quats: new Float32Array(3) })).toThrow(/quats has 3 numbers, expected frames×joints×4 = 12/);
  });
});
