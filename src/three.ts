/**
 * The three.js entry of the library (docs/ARCHITECTURE.md "TypeScript library"): the skinned character
 * of the manifest's skeleton, the motion player, joints → pose track, and its GLB download (motionToGLB).
 *
 * ```ts
 * const character = createCharacter(generator.skeleton);
 * scene.add(character.object);
 * character.play(motion);                       // a GeneratedMotion (createGenerator) or any Motion
 * renderer.setAnimationLoop(() => { character.update(clock.getDelta()); renderer.render(scene, camera); });
 * ```
 */
import { Box3, type PerspectiveCamera, Vector3 } from 'three';
import { applyPose, type Character, createCharacter as createSkinnedCharacter, placeBones } from './character/character';
import { MotionPlayer, type PoseTrack } from './character/player';
import { solvePose } from './motion/ik';
import type { Motion } from './motion/types';
import type { SkeletonLike } from './skeleton';

export { applyPose, placeBones } from './character/character';
export type { Character } from './character/character';
export { HEAD_PITCH } from './character/body';
export { MotionPlayer, checkTrack, samplePose, trackDuration } from './character/player';
export type { PoseTrack } from './character/player';
export { buildBones, restPositions } from './character/rig';
export { motionToGLB, trackToClip } from './export/builtinGlb';

/** A motion with bone rotations already solved (createGenerator's results carry them as `pose`, with the rest
 * `offsets` they go with). */
export type PosedMotion = Motion & { pose?: { rootPos: Float32Array; quats: Float32Array; offsets?: Float32Array } };

/** The pose track of a motion: its `pose` when it has one, else the joints solved into rotations (IK); with the
 * offsets the rotations go with, where known (a pose without them plays on the reference offsets). */
export function poseTrack(motion: PosedMotion, skeleton: SkeletonLike): PoseTrack {
  const pose = motion.pose ?? solvePose(motion.joints, motion.frames, skeleton);
  const track: PoseTrack = { frames: motion.frames, fps: motion.fps, joints: skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats };
  if (pose.offsets) track.offsets = pose.offsets;
  return track;
}

/** The built-in character with a player: `play(motion)`, then `update(dt)` once per rendered frame. */
export interface PlayableCharacter extends Character {
  readonly player: MotionPlayer;
  /** Play a motion from its start (looping). */
  play(motion: PosedMotion): void;
  /** Advance the player by `dt` seconds and pose the bones. */
  update(dt: number): void;
}

export function createCharacter(skeleton: SkeletonLike): PlayableCharacter {
  const character = createSkinnedCharacter(skeleton);
  const player = new MotionPlayer();
  return {
    ...character,
    player,
    play(motion) {
      player.setTrack(poseTrack(motion, skeleton));
      player.playing = true;
      placeBones(character.bones, skeleton, player.track!.offsets);   // the motion's own proportions
      applyPose(character.bones, player.root, player.quats);
    },
    update(dt) {
      if (!player.track) return;
      player.update(dt);
      applyPose(character.bones, player.root, player.quats);
    },
  };
}

/**
 * Aim `camera` from its current view direction at the whole motion: every joint on every frame in the
 * picture (the joints' bounding box fitted to the field of view, `margin` to spare). Returns the point
 * it now looks at (for OrbitControls: `controls.target.copy(frameMotion(camera, motion)); controls.update()`).
 * A walk of 4 s covers 5–10 m and a run more, so a fixed camera loses the character on the way.
 */
export function frameMotion(camera: PerspectiveCamera, motion: Pick<Motion, 'joints' | 'frames'>, margin = 1.1): Vector3 {
  const box = new Box3();
  const p = new Vector3();
  for (let i = 0; i + 2 < motion.joints.length; i += 3) box.expandByPoint(p.set(motion.joints[i], motion.joints[i + 1], motion.joints[i + 2]));
  if (box.isEmpty()) throw new RangeError(`frameMotion: the motion has no joints (frames ${motion.frames}, joints ${motion.joints.length})`);
  const center = box.getCenter(new Vector3());
  // camera axes: right u, up v, forward w; a corner at offset (cu, cv, cw) from the centre is inside the
  // picture at distance d when |cu| ≤ tanH·(d + cw)/margin and |cv| ≤ tanV·(d + cw)/margin
  camera.updateMatrixWorld();
  const u = new Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
  const v = new Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
  const w = camera.getWorldDirection(new Vector3());
  const tanV = Math.tan((camera.fov * Math.PI) / 360);
  const tanH = tanV * camera.aspect;
  let distance = camera.near + 0.5;
  for (let k = 0; k < 8; k++) {
    p.set(k & 1 ? box.max.x : box.min.x, k & 2 ? box.max.y : box.min.y, k & 4 ? box.max.z : box.min.z).sub(center);
    const cw = p.dot(w);
    distance = Math.max(distance, (margin * Math.abs(p.dot(u))) / tanH - cw, (margin * Math.abs(p.dot(v))) / tanV - cw);
  }
  camera.position.copy(center).addScaledVector(w, -distance);
  camera.updateMatrixWorld();
  return center;
}
