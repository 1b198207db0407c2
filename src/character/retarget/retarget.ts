/**
 * Retargeting: our generated motion (22 joint positions per frame) → an AnimationClip for a user's
 * character, whatever its rest pose (T or A), bone rolls and axes.
 *
 * ```ts
 * const { clip } = retargetMotion(character.root, character.mapping, { joints, frames, fps, contacts }, manifest.skeleton);
 * new AnimationMixer(character.root).clipAction(clip).play();
 * ```
 *
 * On a page, `await retargetMotionAsync(...)` (the same arguments, plus `{ signal, sliceMs }`) gives the
 * same result to the bit in ~8 ms slices with the event loop between them, so a 60 s motion (1,200 frames)
 * does not stop the page drawing; aborting `signal` stops it (the demo: a newer motion wins).
 *
 * Everything is computed in the frame of `root` (the loaded scene; the character must be in its rest
 * pose, as loaded: stop its mixer and call LoadedCharacter.restPose() first). Per frame:
 *  1. Our IK (src/motion/ik.ts: solveIK) gives every joint's global rotation G_j relative to our rest
 *     T-pose, with the twist taken from body planes.
 *  2. Facing: C = the rotation about Y that turns our rest "left" (l_hip − r_hip) onto the character's,
 *     so a character modelled facing −Z (VRM 0.x) walks where it faces.
 *  3. Limbs and spine (a joint j with a mapped joint k further down our chain): rest alignment
 *     S_j = the smallest rotation turning the character's rest direction bone(j)→bone(k) onto ours
 *     (C·(rest_k − rest_j)); the bone's world rotation is Δ_j · R_j (R_j: its rest world rotation) with
 *     Δ_j = C·G_j·C⁻¹·S_j, then swung (smallest rotation) so bone(j)→bone(k) points exactly along our
 *     joints' C·(P_k − P_j): the direction comes from our positions, the twist from our IK.
 *     Pelvis and chest (spine3) use two directions: hips across + up, and up + collars (or shoulders)
 *     across. A mapped joint with nothing mapped below (e.g. an ankle without toes) turns with G_j.
 *     A foot rigged as an IK target outside the pelvis's tree (three.js's RobotExpressive) is placed
 *     where the character's shin ends (position track) and turned like a mapped ankle.
 *  4. Every other bone (fingers, twist, hair, our leaves: head, hands, toes) keeps its rest LOCAL
 *     rotation, so it follows its parent rigidly. Local rotation = (parent world)⁻¹ · world.
 *  5. Root: the midpoint of the character's hip joints follows ours scaled by s = character leg / our
 *     leg (hip→knee→ankle): horizontally s·P, vertically s·(our hip height above our standing ankle
 *     height) above its rest ankle height; the pelvis bone hangs off it with its rest offset, turned.
 *  6. Feet: on our contact frames (the four contact channels, threshold 0.5) each foot is put on the
 *     floor: horizontally, the joint in contact (the ankle where the heel is down, else the toe bone)
 *     is held at its mean position over that contact run (as our clean-up, src/motion/footContact.ts,
 *     holds ours), and vertically the lower of heel (ankle) and ball (toe) is at its rest height, frame
 *     by frame (the foot rolls heel → toe as ours does). A rig without a toe bone, on the ball of its
 *     foot only, keeps its ankle as high above its rest height as ours is above our standing ankle
 *     height (scaled), less any lift of our toe above its floor height (the ball is in contact). The root makes the feet's mean horizontal move (no limb turns for that) and, of
 *     the heights between the feet's needs, the vertical move that leaves the feet nearest their
 *     targets once the legs have done what they can; a two-bone IK on thigh and shin (keeping the knee's
 *     bend plane) moves each ankle the rest of the way and the foot keeps its world rotation. Where the
 *     leg is nearly straight, so that holding the foot would turn thigh or shin by more than
 *     `maxPinDeg` (9°) from our motion's direction, only the part of the move within it is made. Over
 *     `blend` frames on both sides of a stretch of contact the correction of its first/last frame fades
 *     out (not a blend towards the target: our clean-up has made that transition already).
 * The passes, in the order the data flows: rest.ts (the character's rest pose; posing one frame), drives.ts
 * (step 3's Δ per bone), this file (checks, facing, the root), feet.ts (step 6), tracks.ts (the clip).
 */
import { type AnimationClip, type Object3D, Quaternion, Vector3 } from 'three';
import { type IKResult, solveIKSteps } from '../../motion/ik';
import type { V3 } from '../../motion/math3';
import { type JointName, type SkeletonLike, standardJoints } from '../../skeleton';
import { nextTask } from '../../yield';
import { restPositions } from '../rig';
import { drivesFor, frameDeltas } from './drives';
import { pinFeet } from './feet';
import { type BoneInfo, type BoneMapping, validateMapping } from './mapping';
import { type RestRig, readRest } from './rest';
import { clipOf, trackSteps } from './tracks';

export interface RetargetMotion {
  /** frames × 22 × 3 world joint positions (SMPL order), metres, Y up */
  joints: Float32Array;
  frames: number;
  fps: number;
  /** frames × 4 foot contacts (l_ankle, l_foot, r_ankle, r_foot), e.g. contactsFromFeatures(features); none: no pinning */
  contacts?: Float32Array | null;
}

export interface RetargetOptions {
  /** contact threshold (default 0.5) */
  threshold?: number;
  /** frames over which a pinned foot fades in/out (default 3) */
  blend?: number;
  /** the most a foot pin may turn thigh or shin away from our motion's direction, degrees (default 9) */
  maxPinDeg?: number;
  /** clip name (default 'emdm') */
  name?: string;
}

export interface RetargetResult {
  clip: AnimationClip;
  frames: number;
  fps: number;
  /** the animated objects (quaternion tracks), in hierarchy order; bones[0] is the pelvis bone */
  bones: Object3D[];
  /** per animated object: frames × 4 local quaternions (x, y, z, w) */
  rotations: Float32Array[];
  /** frames × 3: the pelvis bone's local position */
  rootPositions: Float32Array;
  /** other animated positions (frames × 3, local): feet rigged as IK targets outside the pelvis's tree */
  positions: { bone: Object3D; data: Float32Array }[];
  /** leg length ratio (character / ours) applied to the root translation */
  scale: number;
  /** yaw (radians about +Y) from our facing to the character's rest facing */
  yaw: number;
  /** number of frames on which a foot was pinned (both feet counted) */
  pinnedFrames: number;
}

/** The bones (isBone objects) under `root` with parent indices (nearest bone ancestor; −1: none). */
export function bonesOf(root: Object3D): { objects: Object3D[]; infos: BoneInfo[] } {
  const objects: Object3D[] = [];
  root.traverse((o) => {
    if ((o as { isBone?: boolean }).isBone) objects.push(o);
  });
  const index = new Map(objects.map((o, i) => [o, i]));
  const infos = objects.map((o) => {
    let p = o.parent;
    while (p && !index.has(p)) p = p.parent;
    return { name: o.name, parent: p ? index.get(p)! : -1 };
  });
  return { objects, infos };
}

/** Per-frame passes of the retargeting (our IK, deltas, contact poses, root search, pins, tracks), for progress. */
const PASSES = 6;

/** Our IK's frames as the retargeting's first pass (its progress scaled to that pass). */
function* ikSteps(steps: Generator<number, IKResult, void>): Generator<number, IKResult, void> {
  for (;;) {
    const r = steps.next();
    if (r.done) return r.value;
    yield r.value / PASSES;
  }
}

/** Retarget `motion` onto the character under `root` in one go (see the file's comment). */
export function retargetMotion(root: Object3D, mapping: BoneMapping, motion: RetargetMotion, skeleton: SkeletonLike, opts: RetargetOptions = {}): RetargetResult {
  const steps = retargetSteps(root, mapping, motion, skeleton, opts);
  for (;;) {
    const r = steps.next();
    if (r.done) return r.value;
  }
}

export interface RetargetSliceOptions extends RetargetOptions {
  /** the most time one slice of work may take before the page gets its thread back, ms (default 8) */
  sliceMs?: number;
  /** aborting stops the work at the next slice boundary; the promise rejects with an AbortError */
  signal?: AbortSignal;
  /** called at the end of each slice (but the last) with the share of the work done (0–1) and the slice's duration, ms */
  onProgress?: (fraction: number, sliceMs: number) => void;
}

/**
 * The same retargeting as retargetMotion (the same steps, so the same numbers to the last bit), cut into
 * slices of at most about `sliceMs` with the event loop run between them, so that a long motion (60 s:
 * 1,200 frames) does not stop the page from drawing or answering input. The character's rest pose is
 * read synchronously, before this returns: the caller may pose `root` again (e.g. keep playing its
 * previous clip) while the rest is computed. Aborting `signal` stops it at the next slice boundary.
 */
export async function retargetMotionAsync(root: Object3D, mapping: BoneMapping, motion: RetargetMotion, skeleton: SkeletonLike, opts: RetargetSliceOptions = {}): Promise<RetargetResult> {
  const { signal, onProgress } = opts;
  const sliceMs = opts.sliceMs ?? 8;
  if (!(sliceMs > 0)) throw new RangeError(`retargetMotionAsync: sliceMs must be > 0, got ${sliceMs}`);
  const aborted = () => signal?.reason instanceof Error ? signal.reason : new DOMException('retargetMotionAsync: cancelled (a newer motion arrived)', 'AbortError');
  if (signal?.aborted) throw aborted();
  const steps = retargetSteps(root, mapping, motion, skeleton, opts);
  // the first slice runs now, synchronously: it reads the rest pose from the scene
  let t0 = performance.now();
  for (;;) {
    const r = steps.next();
    if (r.done) return r.value;
    if (performance.now() - t0 < sliceMs) continue;
    onProgress?.(r.value, performance.now() - t0);
    await nextTask();
    if (signal?.aborted) throw aborted();
    t0 = performance.now();
  }
}

/**
 * The retargeting, as a generator that yields (the share of the work done, 0–1) after each frame of each
 * per-frame pass: retargetMotion runs it through, retargetMotionAsync a slice at a time. Everything it reads
 * from the scene it reads before its first yield.
 */
function* retargetSteps(root: Object3D, mapping: BoneMapping, motion: RetargetMotion, skeleton: SkeletonLike, opts: RetargetOptions): Generator<number, RetargetResult, void> {
  const { joints, frames, fps } = motion;
  const threshold = opts.threshold ?? 0.5;
  const I = checkMotion(motion, skeleton);
  const J = skeleton.joints.length;
  const { objects, infos } = bonesOf(root);
  validateMapping(mapping, infos);
  const rig = readRest(root, mapping, objects); // the rest pose, in the frame of `root`

  // ---- our side: rest (reference T-pose) and the IK's global rotations
  const ours = restPositions(skeleton).map((p) => p.clone());
  const ik = yield* ikSteps(solveIKSteps(joints, frames, skeleton)); // in slices too: the first of six passes
  const P = (f: number, j: JointName) => new Vector3(joints[(f * J + I(j)) * 3], joints[(f * J + I(j)) * 3 + 1], joints[(f * J + I(j)) * 3 + 2]);

  // ---- facing: C turns our rest left (+X) onto the character's
  const yawOf = (a: Vector3) => Math.atan2(-a.z, a.x);
  const charAcross = rig.restPos('l_hip').clone().sub(rig.restPos('r_hip'));
  const ourAcross = ours[I('l_hip')].clone().sub(ours[I('r_hip')]);
  const yaw = yawOf(charAcross) - yawOf(ourAcross);
  const C = new Quaternion().setFromAxisAngle(new Vector3(0, 1, 0), yaw);

  const drives = drivesFor(rig, mapping, ours, I, C);
  const animated = new Set(drives.map((d) => rig.S(d.j)));
  const contact = (f: number, c: number) => (motion.contacts ? motion.contacts[f * 4 + c] > threshold : false);
  const place = rootPlacement(rig, ik, I, P, C, frames, !!motion.contacts, contact);

  // ---- per frame: Δ (world delta rotation) of every animated slot, and the root
  const deltas: Map<number, Quaternion>[] = [];
  const rootPs: Vector3[] = [];
  const done = (pass: number, f: number) => (1 + pass + (f + 1) / frames) / PASSES;
  for (let f = 0; f < frames; f++) {
    const dir = (a: JointName, b: JointName) => P(f, b).sub(P(f, a)).applyQuaternion(C);
    deltas.push(frameDeltas(drives, rig, I, C, ourGlobal(ik, skeleton, f), dir));
    rootPs.push(place.rootWorld(f, deltas[f].get(0) ?? new Quaternion()));
    yield done(0, f);
  }

  // ---- feet: pin the ankle on contact frames (two-bone IK on thigh and shin)
  const maxPin = ((opts.maxPinDeg ?? 9) * Math.PI) / 180;
  const pinnedFrames = motion.contacts
    ? yield* pinFeet({ rig, frames, contact, P, scale: place.scale, ho: place.ho, hoToe: place.hoToe, blend: opts.blend ?? 3, maxPin, deltas, rootPs, done })
    : 0;

  const tracks = yield* trackSteps(rig, animated, deltas, rootPs, (f) => done(4, f));
  const clip = clipOf(root, rig, tracks, fps, opts.name ?? 'emdm');
  return { clip, frames, fps, ...tracks, scale: place.scale, yaw, pinnedFrames };
}

/** The joint index function of a motion that is fit to retarget (RangeError naming what is not). */
function checkMotion(motion: RetargetMotion, skeleton: SkeletonLike): (j: JointName) => number {
  const { joints, frames, fps } = motion;
  if (!(frames >= 1)) throw new RangeError('retargetMotion: the motion has no frames');
  if (!(fps > 0)) throw new RangeError(`retargetMotion: fps must be > 0, got ${fps}`);
  const I = standardJoints(skeleton, 'retargetMotion');
  const J = skeleton.joints.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`retargetMotion: joints has ${joints.length} values, expected ${frames} × ${J} × 3`);
  if (motion.contacts && motion.contacts.length !== frames * 4) throw new RangeError(`retargetMotion: contacts has ${motion.contacts.length} values, expected ${frames} × 4`);
  for (let i = 0; i < joints.length; i++) {
    if (!Number.isFinite(joints[i])) throw new RangeError(`retargetMotion: joint value ${i} is ${joints[i]}; the motion must be finite`);
  }
  return I;
}

/** Our IK's global rotation of every joint at frame f. */
function ourGlobal(ik: IKResult, skeleton: SkeletonLike, f: number): Quaternion[] {
  const J = skeleton.joints.length;
  const G: Quaternion[] = new Array(J);
  for (let j = 0; j < J; j++) {
    const o = (f * J + j) * 4;
    const L = new Quaternion(ik.quats[o], ik.quats[o + 1], ik.quats[o + 2], ik.quats[o + 3]);
    const p = skeleton.parents[j];
    G[j] = p < 0 ? L : G[p].clone().multiply(L);
  }
  return G;
}

/**
 * Step 5, the root: the leg-length ratio `scale`, our ankle's and toe's floor heights (ho, hoToe), and
 * `rootWorld(f, pelvisDelta)`, the pelvis bone's world position at frame f.
 */
function rootPlacement(rig: RestRig, ik: IKResult, I: (j: JointName) => number, P: (f: number, j: JointName) => Vector3, C: Quaternion,
  frames: number, hasContacts: boolean, contact: (f: number, c: number) => boolean) {
  const { restPos } = rig;
  const legLen = (hip: Vector3, knee: Vector3, ankle: Vector3) => hip.distanceTo(knee) + knee.distanceTo(ankle);
  const side = (s: 'l' | 'r') => [`${s}_hip`, `${s}_knee`, `${s}_ankle`] as JointName[];
  const charLeg = (['l', 'r'] as const).reduce((acc, s) => acc + legLen(...(side(s).map((j) => restPos(j)) as [Vector3, Vector3, Vector3])), 0) / 2;
  const offLen = (j: JointName) => Math.hypot(...(ik.offsets[I(j)] as V3));
  const ourLeg = (offLen('l_knee') + offLen('l_ankle') + offLen('r_knee') + offLen('r_ankle')) / 2;
  const scale = charLeg / ourLeg;
  // our joint's height when on the floor: over the frames where its contact channel (c: left, c + 2: right)
  // is on, else over both sides' lower one per frame; the median where the motion has contacts, else the
  // lowest 5 %. The ankle's places the root; the toe's serves a rig without a toe bone standing on the ball
  // of its foot
  const floorHeight = (c: number, joint: 'ankle' | 'foot'): number => {
    const l = `l_${joint}` as const;
    const r = `r_${joint}` as const;
    const hs: number[] = [];
    for (let f = 0; f < frames; f++) {
      if (contact(f, c)) hs.push(P(f, l).y);
      if (contact(f, c + 2)) hs.push(P(f, r).y);
    }
    if (!hs.length) for (let f = 0; f < frames; f++) hs.push(Math.min(P(f, l).y, P(f, r).y));
    hs.sort((a, b) => a - b);
    return hs[Math.floor((hs.length - 1) * (hasContacts ? 0.5 : 0.05))];
  };
  const ho = floorHeight(0, 'ankle');
  const hoToe = floorHeight(1, 'foot');
  const hc = (restPos('l_ankle').y + restPos('r_ankle').y) / 2;
  // the root is placed through the hip joints' midpoint (rigs put their pelvis bone at different
  // places around the hips; a lever between them would move the feet as the pelvis turns)
  const hipMid = (f: number) => P(f, 'l_hip').add(P(f, 'r_hip')).multiplyScalar(0.5);
  const charHipMid = restPos('l_hip').clone().add(restPos('r_hip')).multiplyScalar(0.5);
  const hipToPelvis = restPos('pelvis').clone().sub(charHipMid);
  const rootWorld = (f: number, pelvisDelta: Quaternion) => {
    const m = hipMid(f);
    const h = new Vector3(m.x * scale, 0, m.z * scale).applyQuaternion(C);
    const mid = new Vector3(charHipMid.x + h.x, hc + scale * (m.y - ho), charHipMid.z + h.z);
    return mid.add(hipToPelvis.clone().applyQuaternion(pelvisDelta));
  };
  return { scale, ho, hoToe, rootWorld };
}
