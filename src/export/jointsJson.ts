/**
 * The joints download: the motion's joint positions as one JSON document (`emdm-joints/1`), for tools that
 * want positions rather than a rig. Metres, Y up, facing +Z at frame 0; values rounded to 0.1 mm.
 *
 * ```ts
 * const text = motionToJSON(generator.skeleton, motion.joints, motion.frames, motion.fps, { model: 'emdm-text', seed: 7 });
 * ```
 */
import type { SkeletonLike } from '../skeleton';

export interface JointsDocument {
  format: 'emdm-joints/1';
  fps: number;
  frames: number;
  joints: string[];
  parents: number[];
  units: 'metres, Y up, facing +Z at frame 0';
  generator: Record<string, unknown>;
  /** frames × joints × [x, y, z], rounded to 0.1 mm */
  positions: number[][][];
}

/** The JSON text of `joints` (frames × joints × 3, metres); `generator` says what made it (model, seed, …; the demo
 * page's block, with a timeline's segments, an edit's inputs or a live recording's prompts: docs/ARCHITECTURE.md
 * "Motion files"). */
export function motionToJSON(s: SkeletonLike & { parents: number[] }, joints: Float32Array, frames: number, fps: number,
  generator: Record<string, unknown>): string {
  const J = s.joints.length;
  if (joints.length !== frames * J * 3) throw new Error(`joints JSON: ${joints.length} values, expected ${frames}×${J}×3`);
  const r = (v: number) => Math.round(v * 1e4) / 1e4;
  const positions: number[][][] = [];
  for (let f = 0; f < frames; f++) {
    const row: number[][] = [];
    for (let j = 0; j < J; j++) {
      const o = (f * J + j) * 3;
      row.push([r(joints[o]), r(joints[o + 1]), r(joints[o + 2])]);
    }
    positions.push(row);
  }
  const doc: JointsDocument = {
    format: 'emdm-joints/1', fps, frames, joints: s.joints, parents: s.parents,
    units: 'metres, Y up, facing +Z at frame 0', generator, positions,
  };
  return JSON.stringify(doc);
}
