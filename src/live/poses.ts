/**
 * The live stream's bone rotations, solved once per window (src/live/stream.ts): a fixed ring of per-frame poses
 * keyed by stream frame, so frameAt reads (and interpolates) instead of solving IK for every frame it is asked.
 *
 * ```ts
 * const ring = new PoseRing();
 * const e = ring.changed(from, to);                 // display frames [from, to) were replaced: their poses are stale
 * ring.put(from, pose, to - from, e, origin);       // a solve of those frames, requested at epoch e, has arrived
 * ring.get(f, origin);                              // frame f's pose in stage coordinates, or null (none yet / stale)
 * ```
 *
 * A solve runs elsewhere (the generation worker) while the stream goes on, so its answer may come after a later window
 * replaced some of its frames: each slot remembers the epoch its frame last changed at, and a solve requested before
 * that is not written there. Root positions are kept in world coordinates (stage + origin at the solve), so the stage
 * moving back under the character (LiveCore's recentre) does not make them stale.
 */

/** Bone rotations of frames: the pelvis position (frames × 3) and local joint rotations (frames × 22 × 4, xyzw). */
export interface FramePose {
  rootPos: Float32Array;
  quats: Float32Array;
  /** the rest offsets (22 × 3) the rotations were solved with (a solve's MotionPose.offsets): a rig's bones go there */
  offsets?: Float32Array;
}

const Q = 22 * 4;

export class PoseRing {
  private readonly tag: Int32Array;
  private readonly stamp: Int32Array;
  private readonly root: Float64Array;
  private readonly quats: Float32Array;
  private readonly offsets: (Float32Array | undefined)[];     // per slot: its solve's offsets (shared, not copied)
  private epoch = 0;

  /** `capacity`: frames held (must exceed the frames buffered ahead of the playhead: LiveCore's lead + window + kept). */
  constructor(readonly capacity = 1024) {
    this.tag = new Int32Array(capacity).fill(-1);
    this.stamp = new Int32Array(capacity);
    this.root = new Float64Array(capacity * 3);
    this.quats = new Float32Array(capacity * Q);
    this.offsets = new Array<Float32Array | undefined>(capacity);
  }

  /** Frames [from, to) changed: their poses are dropped; returns the epoch a solve of the new frames is requested at. */
  changed(from: number, to: number): number {
    this.epoch++;
    for (let f = Math.max(from, to - this.capacity); f < to; f++) {
      const i = f % this.capacity;
      this.tag[i] = -1;
      this.stamp[i] = this.epoch;
    }
    return this.epoch;
  }

  /** The epoch now (what a solve requested now is tagged with). */
  get now(): number {
    return this.epoch;
  }

  /** Poses of `frames` frames from stream frame `from`, solved from the display as it was at `epoch` with the stage at `origin`. */
  put(from: number, pose: FramePose, frames: number, epoch: number, origin: readonly [number, number]): void {
    if (pose.rootPos.length !== frames * 3 || pose.quats.length !== frames * Q) {
      throw new RangeError(`live poses: a solve of ${frames} frames returned ${pose.rootPos.length / 3} root positions and ${pose.quats.length / Q} poses`);
    }
    for (let k = 0; k < frames; k++) {
      const i = (from + k) % this.capacity;
      if (this.stamp[i] > epoch) continue; // replaced after this solve was asked for
      this.tag[i] = from + k;
      this.root[i * 3] = pose.rootPos[k * 3] + origin[0];
      this.root[i * 3 + 1] = pose.rootPos[k * 3 + 1];
      this.root[i * 3 + 2] = pose.rootPos[k * 3 + 2] + origin[1];
      this.quats.set(pose.quats.subarray(k * Q, (k + 1) * Q), i * Q);
      this.offsets[i] = pose.offsets;
    }
  }

  /** Frame f's pose (stage coordinates for the stage at `origin`; new arrays), or null when none is held for it. */
  get(f: number, origin: readonly [number, number]): FramePose | null {
    const i = f % this.capacity;
    if (this.tag[i] !== f) return null;
    const rootPos = new Float32Array([this.root[i * 3] - origin[0], this.root[i * 3 + 1], this.root[i * 3 + 2] - origin[1]]);
    const offsets = this.offsets[i];
    return { rootPos, quats: this.quats.slice(i * Q, (i + 1) * Q), ...(offsets ? { offsets } : {}) };
  }
}

/** a + (b − a)·w of two frames' poses: positions linearly, rotations normalised-linearly on the same hemisphere. */
export function mixPose(a: FramePose, b: FramePose, w: number): FramePose {
  const rootPos = new Float32Array(3);
  for (let k = 0; k < 3; k++) rootPos[k] = a.rootPos[k] + (b.rootPos[k] - a.rootPos[k]) * w;
  const quats = new Float32Array(a.quats.length);
  for (let j = 0; j < quats.length; j += 4) {
    const s = a.quats[j] * b.quats[j] + a.quats[j + 1] * b.quats[j + 1] + a.quats[j + 2] * b.quats[j + 2] + a.quats[j + 3] * b.quats[j + 3] < 0 ? -1 : 1;
    let n = 0;
    for (let k = 0; k < 4; k++) {
      quats[j + k] = a.quats[j + k] * (1 - w) + s * b.quats[j + k] * w;
      n += quats[j + k] ** 2;
    }
    n = Math.sqrt(n) || 1;
    for (let k = 0; k < 4; k++) quats[j + k] /= n;
  }
  return { rootPos, quats, ...(a.offsets ? { offsets: a.offsets } : {}) };   // the bones stay where frame a's are
}
