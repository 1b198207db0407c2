/**
 * The three.js entry of the library (docs/ARCHITECTURE.md "TypeScript library"): the skinned character
 * of the manifest's skeleton, the motion player, and joints → pose track.
 *
 * ```ts
 * const character = createCharacter(generator.skeleton);
 * scene.add(character.object);
 * character.play(motion);                       // a GeneratedMotion (createGenerator) or any Motion
 * renderer.setAnimationLoop(() => { character.update(clock.getDelta()); renderer.render(scene, camera); });
 * ```
 */
import { applyPose, type Character, createCharacter as createSkinnedCharacter } from './character/character';
import { MotionPlayer, type PoseTrack } from './character/player';
import { solveIK } from './motion/ik';
import type { Motion } from './motion/types';
import type { SkeletonLike } from './skeleton';

export { applyPose } from './character/character';
export type { Character } from './character/character';
export { HEAD_PITCH } from './character/body';
export { MotionPlayer, checkTrack, samplePose, trackDuration } from './character/player';
export type { PoseTrack } from './character/player';
export { buildBones, restPositions } from './character/rig';

/** A motion with bone rotations already solved (createGenerator's results carry them as `pose`). */
export type PosedMotion = Motion & { pose?: { rootPos: Float32Array; quats: Float32Array } };

/** The pose track of a motion: its `pose` when it has one, else the joints solved into rotations (IK). */
export function poseTrack(motion: PosedMotion, skeleton: SkeletonLike): PoseTrack {
  const pose = motion.pose ?? solveIK(motion.joints, motion.frames, skeleton);
  return { frames: motion.frames, fps: motion.fps, joints: skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats };
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
      applyPose(character.bones, player.root, player.quats);
    },
    update(dt) {
      if (!player.track) return;
      player.update(dt);
      applyPose(character.bones, player.root, player.quats);
    },
  };
}
