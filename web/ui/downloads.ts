// What the visitor can download for the motion on screen: BVH (writeBVH of the TypeScript core, in
// metres or centimetres, the unit in the file name), a binary glTF of the skinned character with the
// motion as an animation (three's GLTFExporter; metres, as glTF requires), and the joint positions as JSON.
import { AnimationClip, QuaternionKeyframeTrack, VectorKeyframeTrack } from 'three';
import { GLTFExporter } from 'three/addons/exporters/GLTFExporter.js';
import { createCharacter, type PoseTrack } from '../../src/three';
import { type BvhUnits, bvhFileName, writeBVH, type Motion, type SkeletonLike } from '../../src/index';

/** The BVH file of a motion at its own 20 fps in `units` ('m' | 'cm', from the page's unit select), named
 * `<stem>-metres.bvh` / `<stem>-centimetres.bvh`. Another value is a RangeError naming it. */
export function motionToBVH(s: SkeletonLike, motion: Motion, stem: string, units: string): { blob: Blob; filename: string } {
  const u = units as BvhUnits; // writeBVH checks it
  const text = writeBVH(motion, s, { fps: 20, units: u });
  return { blob: new Blob([text], { type: 'text/plain' }), filename: bvhFileName(stem, u) };
}

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
  try {
    const clip = trackToClip(s, t);
    const out = await new GLTFExporter().parseAsync(ch.object, { binary: true, animations: [clip], onlyVisible: false });
    if (!(out instanceof ArrayBuffer)) throw new Error('GLTFExporter returned JSON where a binary .glb was requested');
    return out;
  } finally {
    ch.dispose();
  }
}

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

/** A file name from the condition: 'emdm-a-person-walks-seed42'. */
export function fileStem(label: string, seed: number): string {
  const slug = label.toLowerCase().replace(/[^a-z0-9]+/g, '-').replace(/^-+|-+$/g, '').slice(0, 40) || 'motion';
  return `emdm-${slug}-seed${seed}`;
}
