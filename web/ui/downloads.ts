// The page's side of the motion downloads: file names and Blobs. Every format is written by src/export/
// (BVH: writeBVH in metres or centimetres, the unit in the file name; the built-in character's GLB:
// motionToGLB of 'emdm-web/three'; the joints JSON: motionToJSON); view.ts binds them to the buttons and turns
// them on and off (setDownloads: off in live mode until a recording, #dl-note saying why).
import { type BvhUnits, bvhFileName, writeBVH, type Motion, type SkeletonLike } from '../../src/index';
import { byId } from './dom';

/** The download buttons (web/index.html). */
export const DOWNLOAD_IDS = ['dl-bvh', 'dl-glb', 'dl-json'] as const;

/** Why the downloads are off in live mode before a recording (they write the page's motion, which the stream is not). */
export const LIVE_DOWNLOAD_NOTE = 'Live mode: the downloads save a recording. Press “Record last 60 s” first.';

/** Enable or disable the download buttons; `note` ('' for none) is shown under them (#dl-note) and describes them. */
export function setDownloads(enabled: boolean, note: string): void {
  const n = byId('dl-note');
  n.textContent = note;
  n.hidden = !note;
  for (const id of DOWNLOAD_IDS) {
    const b = byId(id, HTMLButtonElement);
    b.disabled = !enabled;
    if (note) b.setAttribute('aria-describedby', 'dl-note');
    else b.removeAttribute('aria-describedby');
  }
}

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
