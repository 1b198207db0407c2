/**
 * The retargeting's last pass (retarget.ts): every animated bone's local rotation per frame (sign-continuous
 * quaternions), the pelvis bone's local position, detached feet's positions, and the AnimationClip of them.
 */
import { AnimationClip, type Object3D, PropertyBinding, type Quaternion, QuaternionKeyframeTrack, type Vector3, VectorKeyframeTrack } from 'three';
import { type RestRig, poseFrame } from './rest';

export interface Tracks {
  /** the animated objects in hierarchy order; bones[0] is the pelvis bone */
  bones: Object3D[];
  rotations: Float32Array[];
  rootPositions: Float32Array;
  positions: { bone: Object3D; data: Float32Array }[];
}

/** The tracks of the slots in `animated` (and of any slot a frame's deltas turn), yielding `done(f)` per frame. */
export function* trackSteps(rig: RestRig, animated: Set<number>, deltas: Map<number, Quaternion>[], rootPs: Vector3[], done: (f: number) => number): Generator<number, Tracks, void> {
  const { subtree } = rig;
  const frames = deltas.length;
  const tracked = subtree.map((_, i) => i).filter((i) => animated.has(i) || deltas.some((d) => d.has(i)));
  if (!tracked.includes(0)) tracked.unshift(0);
  const rotations = tracked.map(() => new Float32Array(frames * 4));
  const rootPositions = new Float32Array(frames * 3);
  const positions = rig.detachedSlots.map(({ slot: i }) => ({ bone: subtree[i], data: new Float32Array(frames * 3) }));
  for (let f = 0; f < frames; f++) {
    const { L, P: detachedP } = poseFrame(rig, deltas[f], rootPs[f], false);
    detachedP.forEach((p, k) => positions[k].data.set([p.x, p.y, p.z], f * 3));
    tracked.forEach((i, t) => {
      const q = L[i];
      const o = f * 4;
      const r = rotations[t];
      const flip = f > 0 && r[o - 4] * q.x + r[o - 3] * q.y + r[o - 2] * q.z + r[o - 1] * q.w < 0 ? -1 : 1;
      r.set([q.x * flip, q.y * flip, q.z * flip, q.w * flip], o);
    });
    const lp = rootPs[f].clone().applyMatrix4(rig.pelvisParentInv);
    rootPositions.set([lp.x, lp.y, lp.z], f * 3);
    yield done(f);
  }
  for (const r of rotations) for (let i = 0; i < r.length; i++) if (!Number.isFinite(r[i])) throw new Error('retargetMotion: a bone rotation came out non-finite (degenerate rest pose?)');
  return { bones: tracked.map((i) => subtree[i]), rotations, rootPositions, positions };
}

/** The AnimationClip of `t` on the scene under `root`: bones by name where the name is unique and bindable, else by uuid. */
export function clipOf(root: Object3D, rig: RestRig, t: Tracks, fps: number, name: string): AnimationClip {
  const frames = t.rootPositions.length / 3;
  const names = new Map<string, number>();
  root.traverse((o) => names.set(o.name, (names.get(o.name) ?? 0) + 1));
  const target = (o: Object3D) => (o.name && names.get(o.name) === 1 && PropertyBinding.sanitizeNodeName(o.name) === o.name ? o.name : o.uuid);
  const times = Array.from({ length: frames }, (_, f) => f / fps);
  const tracks = [new VectorKeyframeTrack(`${target(rig.pelvisBone)}.position`, times, Array.from(t.rootPositions))];
  t.bones.forEach((o, i) => tracks.push(new QuaternionKeyframeTrack(`${target(o)}.quaternion`, times, Array.from(t.rotations[i]))));
  for (const p of t.positions) tracks.push(new VectorKeyframeTrack(`${target(p.bone)}.position`, times, Array.from(p.data)));
  return new AnimationClip(name, (frames - 1) / fps, tracks);
}
