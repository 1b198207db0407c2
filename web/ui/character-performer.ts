// One copy of the visitor's character performing one motion (web/ui/character-picker.ts): the motion is
// retargeted onto it in slices (retargetMotionAsync: ~8 ms of work, then the page draws), then played on the
// page's clock; a newer motion for the same copy cancels the one under way.
import { AnimationMixer, type AnimationAction, type Group, LoopOnce, type Object3D } from 'three';
import { type LoadedCharacter, type Motion, type RetargetResult, retargetMotionAsync, type Skeleton } from '../../src/index';
import { contactsFromFeatures, plantContacts } from '../../src/motion/footContact';

export interface Performer {
  root: Object3D;
  holder: Group;
  mixer: AnimationMixer | null;
  action: AnimationAction | null;
  result: RetargetResult | null;
  /** the retargeting under way (aborted when a newer motion arrives), null when none */
  job: AbortController | null;
  /** the clock's time of the clip's first frame (live mode plays pieces of a stream; 0 otherwise) */
  start?: number;
}

/** Retargeting runs of this page visit (window.emdmCharacter.retargets). */
export interface RetargetStats {
  started: number;
  finished: number;
  /** stopped because a newer motion (or another character) came first */
  cancelled: number;
  /** the last one that finished: frames, wall time on the page and the slices it was cut into, performance.now() at start/end */
  last: { frames: number; ms: number; slices: number; start: number; end: number; firstSliceMs: number; longestSliceMs: number } | null;
}

/**
 * Retarget `m` onto one copy of the character (at rest as loaded; read before the first slice ends) in
 * slices, then play it on the page's clock from `clockStart` (s). A newer call for the same copy cancels this one: false then.
 */
export async function perform(p: Performer, m: Motion, ch: LoadedCharacter, skeleton: Skeleton, stats: RetargetStats, progress?: (fraction: number) => void, clockStart = 0): Promise<boolean> {
  p.job?.abort();
  const job = new AbortController();
  p.job = job;
  if (p.root !== ch.root) restLike(p.root, ch.root);
  // the runs our clean-up pinned (m.joints are the shown, cleaned joints): the character holds the same frames still
  const contacts = m.features.length === m.frames * 263 ? plantContacts(m.joints, m.frames, contactsFromFeatures(m.features, m.frames), skeleton) : null;
  stats.started++;
  const start = performance.now();
  let slices = 1;
  let res: RetargetResult;
  let firstSliceMs = NaN;
  let longestSliceMs = 0;
  try {
    const running = retargetMotionAsync(p.root, ch.mapping, { joints: m.joints, frames: m.frames, fps: m.fps, contacts }, skeleton, {
      signal: job.signal,
      onProgress: (f, ms) => {
        slices++;
        longestSliceMs = Math.max(longestSliceMs, ms);
        progress?.(f);
      },
    });
    // the first slice (the rest pose read, our IK solved for every frame) ran before retargetMotionAsync returned
    firstSliceMs = performance.now() - start;
    res = await running;
  } catch (e) {
    if (job.signal.aborted) {
      stats.cancelled++;
      return false;
    }
    if (p.job === job) p.job = null;
    throw e;
  }
  p.job = null;
  stats.finished++;
  const end = performance.now();
  stats.last = { frames: m.frames, ms: end - start, slices, start, end, firstSliceMs, longestSliceMs };
  play(p, res, clockStart);
  return true;
}

/** Play `res` on the copy (replacing its clip) from the clock's time `start`, at our size and facing. */
function play(p: Performer, res: RetargetResult, start: number): void {
  p.start = start;
  p.mixer?.stopAllAction();
  p.mixer?.uncacheRoot(p.root);
  // shown at our size and facing, so the camera that follows our pelvis follows it too
  p.holder.scale.setScalar(1 / res.scale);
  p.holder.rotation.y = -res.yaw;
  p.mixer = new AnimationMixer(p.root);
  p.action = p.mixer.clipAction(res.clip);
  p.action.setLoop(LoopOnce, 1);
  p.action.clampWhenFinished = true;
  p.action.play();
  p.result = res;
}

/** Take the copy off the stage (its retargeting stopped). */
export function drop(p: Performer): void {
  p.job?.abort();
  p.mixer?.stopAllAction();
  p.holder.removeFromParent();
}

/** Pose the copy at the clock's time `t` (seconds, from its clip's start; clamped to its clip). */
export function poseAt(p: Performer | null | undefined, t: number): void {
  if (!p?.mixer || !p.action || !p.result) return;
  p.action.time = Math.min(Math.max(t - (p.start ?? 0), 0), p.result.clip.duration);
  p.mixer.update(0);
}

/** Put every node under `copy` (a SkeletonUtils clone) at the transform of the same node under `original` (at rest). */
function restLike(copy: Object3D, original: Object3D): void {
  const a: Object3D[] = [];
  const b: Object3D[] = [];
  original.traverse((o) => a.push(o));
  copy.traverse((o) => b.push(o));
  a.forEach((o, i) => {
    b[i]?.position.copy(o.position);
    b[i]?.quaternion.copy(o.quaternion);
    b[i]?.scale.copy(o.scale);
  });
  copy.updateMatrixWorld(true);
}
