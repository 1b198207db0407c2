/**
 * The built-in character's download: a binary glTF (.glb) of the skinned character (character/character.ts,
 * its own copy) with the motion as its one animation, written by three's GLTFExporter, in metres as glTF
 * requires. A user's character keeps its own document instead (characterGlb.ts).
 *
 * ```ts
 * const glb = await motionToGLB(generator.skeleton, poseTrack(motion, generator.skeleton)); // 'emdm-web/three'
 * ```
 */
import { AnimationClip, QuaternionKeyframeTrack, VectorKeyframeTrack } from 'three';
import { GLTFExporter } from 'three/addons/exporters/GLTFExporter.js';
import { createCharacter, placeBones } from '../character/character';
import type { PoseTrack } from '../character/player';
import type { SkeletonLike } from '../skeleton';

/** An AnimationClip of a pose track for bones named after the skeleton's joints. */
export function trackToClip(s: SkeletonLike, t: PoseTrack, name = 'emdm'): AnimationClip {
  const times = new Float32Array(t.frames);
  for (let i = 0; i < t.frames; i++) times[i] = i / t.fps;
  const tracks = [new VectorKeyframeTrack(`${s.joints[0]}.position`, Array.from(times), Array.from(t.rootPos))];
  for (let j = 0; j < t.joints; j++) {
    const q = new Float32Array(t.frames * 4);
    for (let i = 0; i < t.frames; i++) q.set(t.quats.subarray((i * t.joints + j) * 4, (i * t.joints + j) * 4 + 4), i * 4);
    tracks.push(new QuaternionKeyframeTrack(`${s.joints[j]}.quaternion`, Array.from(times), Array.from(q)));
  }
  return new AnimationClip(name, (t.frames - 1) / t.fps, tracks);
}

/** Binary glTF (.glb): the skinned character (own copy) with the motion as its one animation. */
export async function motionToGLB(s: SkeletonLike, t: PoseTrack): Promise<ArrayBuffer> {
  const ch = createCharacter(s);
  placeBones(ch.bones, s, t.offsets);   // the nodes' rest translations: the offsets the track's rotations go with
  try {
    const clip = trackToClip(s, t);
    const out = await new GLTFExporter().parseAsync(ch.object, { binary: true, animations: [clip], onlyVisible: false });
    if (!(out instanceof ArrayBuffer)) throw new Error('GLTFExporter returned JSON where a binary .glb was requested');
    return out;
  } finally {
    ch.dispose();
  }
}
