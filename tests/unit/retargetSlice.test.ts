// retargetMotionAsync (src/character/retarget/retarget.ts): the page's retargeting in slices, so a 60 s
// motion does not freeze the page. It runs the same steps as retargetMotion, so its result is the same
// to the last bit; the rest pose is read before it returns (the character may be posed again meanwhile);
// an abort stops it between slices.
import fs from 'node:fs';
import path from 'node:path';
import type { KeyframeTrack, Object3D } from 'three';
import { describe, expect, it } from 'vitest';
import { loadCharacter } from '../../src/character/retarget/load';
import { type RetargetMotion, type RetargetResult, retargetMotion, retargetMotionAsync } from '../../src/character/retarget/retarget';
import { cleanupFootContacts, contactsFromFeatures } from '../../src/motion/footContact';
import { ROOT, fixtureExists, loadCase, manifestSkeleton } from './coreFixtures';
import { RIGS, buildRigGlb } from './retargetRigs';

const sk = manifestSkeleton();
const J = sk.joints.length;

/** A generated fixture motion (feet cleaned up as the page does), repeated to `frames` frames. */
function longMotion(frames: number): RetargetMotion {
  const name = ['model-emdm-t2m-web', 'recover'].find(fixtureExists);
  expect(name, 'a parity fixture with features (tests/fixtures/parity)').toBeTruthy();
  const fx = loadCase(name!);
  const n = fx.meta.frames;
  const c0 = contactsFromFeatures(fx.get('features'), n);
  const j0 = cleanupFootContacts(fx.get('joints'), n, c0, sk);
  const joints = new Float32Array(frames * J * 3);
  const contacts = new Float32Array(frames * 4);
  for (let f = 0; f < frames; f++) {
    const g = f % n;
    joints.set(j0.subarray(g * J * 3, (g + 1) * J * 3), f * J * 3);
    contacts.set(c0.subarray(g * 4, g * 4 + 4), f * 4);
  }
  return { joints, frames, fps: sk.fps, contacts };
}

function expectSame(a: RetargetResult, b: RetargetResult): void {
  expect(b.bones).toEqual(a.bones);
  expect([b.frames, b.fps, b.scale, b.yaw, b.pinnedFrames]).toEqual([a.frames, a.fps, a.scale, a.yaw, a.pinnedFrames]);
  expect(b.rotations.length).toBe(a.rotations.length);
  a.rotations.forEach((r, i) => expect(Buffer.from(b.rotations[i].buffer).equals(Buffer.from(r.buffer)), `rotations of ${a.bones[i].name}`).toBe(true));
  expect(Buffer.from(b.rootPositions.buffer).equals(Buffer.from(a.rootPositions.buffer))).toBe(true);
  expect(b.positions.map((p) => p.bone)).toEqual(a.positions.map((p) => p.bone));
  a.positions.forEach((p, i) => expect(Array.from(b.positions[i].data)).toEqual(Array.from(p.data)));
  const tracks = (r: RetargetResult) => r.clip.tracks.map((t: KeyframeTrack) => [t.name, Array.from(t.times), Array.from(t.values)]);
  expect(tracks(b)).toEqual(tracks(a));
  expect(b.clip.duration).toBe(a.clip.duration);
}

/** Every bone's local transform turned a little (the character playing some other clip). */
function disturb(root: Object3D): void {
  let k = 0;
  root.traverse((o) => {
    o.rotateX(0.3 + 0.01 * k++);
    o.position.x += 0.05;
  });
  root.updateMatrixWorld(true);
}

describe('retargeting in slices (retargetMotionAsync)', () => {
  const rigs = [
    { label: 'RobotExpressive.glb (feet as IK targets)', file: 'RobotExpressive.glb', bytes: () => new Uint8Array(fs.readFileSync(path.join(ROOT, 'tests', 'fixtures', 'rigs', 'RobotExpressive.glb'))) },
    { label: `${RIGS[0].label}`, file: 'rig.glb', bytes: () => buildRigGlb(sk, RIGS[0]) },
  ];
  for (const rig of rigs) {
    it(`gives exactly retargetMotion's result, slice by slice, though the character is posed meanwhile: ${rig.label}`, async () => {
      const ch = await loadCharacter([{ name: rig.file, data: rig.bytes() }]);
      const motion = longMotion(150);
      const once = retargetMotion(ch.root, ch.mapping, motion, sk);
      expect(once.pinnedFrames).toBeGreaterThan(0); // the feet passes ran
      const progress: number[] = [];
      // the smallest slice: the event loop runs after every frame of every pass
      const pending = retargetMotionAsync(ch.root, ch.mapping, motion, sk, { sliceMs: 1e-6, onProgress: (f) => progress.push(f) });
      disturb(ch.root); // the rest pose was read before retargetMotionAsync returned
      const sliced = await pending;
      expect(progress.length).toBeGreaterThan(5 * motion.frames); // six per-frame passes (our IK the first), most frames a slice
      expect(progress.every((f, i) => f > 0 && f <= 1 && (i === 0 || f >= progress[i - 1]))).toBe(true);
      expectSame(once, sliced);
      // and again with the default slice (fewer, longer slices)
      ch.restPose();
      expectSame(once, await retargetMotionAsync(ch.root, ch.mapping, motion, sk));
    }, 120_000);
  }

  it('an abort stops it at the next slice boundary (AbortError); an aborted signal starts nothing; bad input throws as retargetMotion does', async () => {
    const ch = await loadCharacter([{ name: 'rig.glb', data: buildRigGlb(sk, RIGS[0]) }]);
    const motion = longMotion(120);
    const ctl = new AbortController();
    let slices = 0;
    const run = retargetMotionAsync(ch.root, ch.mapping, motion, sk, {
      sliceMs: 1e-6, signal: ctl.signal,
      onProgress: () => {
        if (++slices === 3) ctl.abort();
      },
    });
    await expect(run).rejects.toMatchObject({ name: 'AbortError' });
    expect(slices).toBe(3);
    await expect(retargetMotionAsync(ch.root, ch.mapping, motion, sk, { signal: ctl.signal })).rejects.toMatchObject({ name: 'AbortError' });
    const reason = new Error('superseded by motion 2');
    await expect(retargetMotionAsync(ch.root, ch.mapping, motion, sk, { signal: AbortSignal.abort(reason) })).rejects.toBe(reason);
    await expect(retargetMotionAsync(ch.root, ch.mapping, { ...motion, fps: 0 }, sk)).rejects.toThrow('retargetMotion: fps must be > 0, got 0');
    await expect(retargetMotionAsync(ch.root, ch.mapping, motion, sk, { sliceMs: 0 })).rejects.toThrow('sliceMs must be > 0');
  }, 120_000);
});
