// The page's side of the motion downloads: file names and Blobs. Every format is written by src/export/
// (BVH: writeBVH in metres or centimetres, the unit in the file name; the built-in character's GLB:
// motionToGLB of 'emdm-web/three'; the joints JSON: motionToJSON); view.ts binds them to the buttons.
import { type BvhUnits, bvhFileName, writeBVH, type Motion, type SkeletonLike } from '../../src/index';

/** The BVH file of a motion at its own 20 fps in `units` ('m' | 'cm', from the page's unit select), named
 * `<stem>-metres.bvh` / `<stem>-centimetres.bvh`. Another value is a RangeError naming it. */
export function motionToBVH(s: SkeletonLike, motion: Motion, stem: string, units: string): { blob: Blob; filename: string } {
  const u = units as BvhUnits; // writeBVH checks it
  const text = writeBVH(motion, s, { fps: 20, units: u });
  return { blob: new Blob([text], { type: 'text/plain' }), filename: bvhFileName(stem, u) };
}

/** A file name from the condition: 'emdm-a-person-walks-seed42'. */
export function fileStem(label: string, seed: number): string {
  const slug = label.toLowerCase().replace(/[^a-z0-9]+/g, '-').replace(/^-+|-+$/g, '').slice(0, 40) || 'motion';
  return `emdm-${slug}-seed${seed}`;
}
