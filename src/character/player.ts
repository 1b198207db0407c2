// Plays a solved motion (root positions + local joint quaternions at the motion's frame rate, 20 fps)
// at the display rate: the pose at any time is interpolated between the two neighbouring frames
// (lerp for the root, shortest-path slerp for the rotations). Loops, pauses, seeks, changes speed.
import { Quaternion } from 'three';

export interface PoseTrack {
  frames: number;
  fps: number;
  joints: number;          // joints per frame
  rootPos: Float32Array;   // frames × 3
  quats: Float32Array;     // frames × joints × 4 (xyzw, local)
  /** the rest offsets the rotations go with (joints × 3; a MotionPose's): the rig's bones go there (placeBones);
   * absent: the skeleton's reference offsets */
  offsets?: Float32Array;
}

export function checkTrack(t: PoseTrack): void {
  if (!(Number.isInteger(t.frames) && t.frames >= 1)) throw new Error(`pose track: frames must be a positive integer, got ${t.frames}`);
  if (!(t.fps > 0)) throw new Error(`pose track: fps must be positive, got ${t.fps}`);
  if (t.rootPos.length !== t.frames * 3) throw new Error(`pose track: rootPos has ${t.rootPos.length} numbers, expected frames×3 = ${t.frames * 3}`);
  if (t.quats.length !== t.frames * t.joints * 4) {
    throw new Error(`pose track: quats has ${t.quats.length} numbers, expected frames×joints×4 = ${t.frames * t.joints * 4}`);
  }
  if (t.offsets !== undefined && (t.offsets.length !== t.joints * 3 || !t.offsets.every(Number.isFinite))) {
    throw new Error(`pose track: offsets has ${t.offsets.length} numbers, expected joints×3 = ${t.joints * 3}, all finite`);
  }
}

/** The time of a track's last frame, in seconds ((frames − 1) / fps; a player plays it one frame longer: MotionPlayer.duration). */
export function trackDuration(t: PoseTrack): number {
  return (t.frames - 1) / t.fps;
}

/**
 * The pose at `time` seconds (clamped into the track): writes the root (3) and the quaternions
 * (joints × 4) into the output arrays. Returns the fractional frame index that was sampled.
 */
export function samplePose(t: PoseTrack, time: number, outRoot: Float32Array, outQuats: Float32Array): number {
  const f = Math.min(Math.max(time * t.fps, 0), t.frames - 1);
  const i0 = Math.floor(f);
  const i1 = Math.min(i0 + 1, t.frames - 1);
  const a = f - i0;
  for (let k = 0; k < 3; k++) outRoot[k] = t.rootPos[i0 * 3 + k] * (1 - a) + t.rootPos[i1 * 3 + k] * a;
  const stride = t.joints * 4;
  for (let j = 0; j < t.joints; j++) {
    // three's typings say number[]; slerpFlat only indexes, so typed arrays work the same.
    Quaternion.slerpFlat(outQuats as unknown as number[], j * 4, t.quats as unknown as number[], i0 * stride + j * 4,
      t.quats as unknown as number[], i1 * stride + j * 4, a);
  }
  return f;
}

/** Playback clock + current pose of one track. */
export class MotionPlayer {
  track: PoseTrack | null = null;
  time = 0;
  speed = 1;
  playing = true;
  loop = true;
  readonly root = new Float32Array(3);
  quats: Float32Array = new Float32Array(0);

  setTrack(track: PoseTrack): void {
    checkTrack(track);
    this.track = track;
    this.time = 0;
    if (this.quats.length !== track.joints * 4) this.quats = new Float32Array(track.joints * 4);
    this.sample();
  }

  /**
   * How long the track plays: its frames at its frame rate (a 100-frame track at 20 fps plays 5 s, as its caption
   * says; the last frame is shown for one frame's time, as a video's is, and a seamless loop's last frame is one
   * frame's time from its first when it wraps). trackDuration is the time of the last frame, one frame less.
   */
  get duration(): number {
    return this.track ? this.track.frames / this.track.fps : 0;
  }

  /** Advance the clock by dt seconds of wall time (scaled by speed) and resample. */
  update(dt: number): void {
    if (!this.track) return;
    if (this.playing) {
      const d = this.duration;
      this.time += dt * this.speed;
      if (this.time > d) {
        if (this.loop && d > 0) this.time %= d;
        else {
          this.time = d;
          this.playing = false;
        }
      }
    }
    this.sample();
  }

  seek(time: number): void {
    this.time = Math.min(Math.max(time, 0), this.duration);
    this.sample();
  }

  /** Current fractional frame index. */
  frame = 0;

  private sample(): void {
    if (this.track) this.frame = samplePose(this.track, this.time, this.root, this.quats);
  }
}
