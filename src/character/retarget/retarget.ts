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
 */
import { AnimationClip, Matrix4, type Object3D, PropertyBinding, Quaternion, QuaternionKeyframeTrack, Vector3, VectorKeyframeTrack } from 'three';
import { type IKResult, solveIKSteps } from '../../motion/ik';
import { type V3, alignFrames, quatFromMat, twoBoneIK } from '../../motion/math3';
import { JOINT_NAMES, PARENTS, type JointName, type SkeletonLike, standardJoints } from '../../skeleton';
import { nextTask } from '../../yield';
import { restPositions } from '../rig';
import { type BoneInfo, type BoneMapping, MappingError, validateMapping } from './mapping';

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

const v = (a: V3) => new Vector3(a[0], a[1], a[2]);
const arr = (a: Vector3): V3 => [a.x, a.y, a.z];
/** The smallest rotation taking direction a onto direction b. */
const swing = (a: Vector3, b: Vector3) => new Quaternion().setFromUnitVectors(a.clone().normalize(), b.clone().normalize());
const quatOfM3 = (m: number[]) => {
  const q = quatFromMat(m);
  return new Quaternion(q[0], q[1], q[2], q[3]);
};

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

/** Our joint → the next joint down its chain whose direction drives it (PRIMARY child). */
const PRIMARY: Partial<Record<JointName, JointName>> = {
  pelvis: 'spine1', spine1: 'spine2', spine2: 'spine3', spine3: 'neck', neck: 'head',
  l_hip: 'l_knee', l_knee: 'l_ankle', l_ankle: 'l_foot', r_hip: 'r_knee', r_knee: 'r_ankle', r_ankle: 'r_foot',
  l_collar: 'l_shoulder', l_shoulder: 'l_elbow', l_elbow: 'l_wrist', r_collar: 'r_shoulder', r_shoulder: 'r_elbow', r_elbow: 'r_wrist',
};

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
  const blend = opts.blend ?? 3;
  const maxPin = ((opts.maxPinDeg ?? 9) * Math.PI) / 180;
  if (!(frames >= 1)) throw new RangeError('retargetMotion: the motion has no frames');
  if (!(fps > 0)) throw new RangeError(`retargetMotion: fps must be > 0, got ${fps}`);
  const I = standardJoints(skeleton, 'retargetMotion');
  const J = skeleton.joints.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`retargetMotion: joints has ${joints.length} values, expected ${frames} × ${J} × 3`);
  if (motion.contacts && motion.contacts.length !== frames * 4) throw new RangeError(`retargetMotion: contacts has ${motion.contacts.length} values, expected ${frames} × 4`);
  for (let i = 0; i < joints.length; i++) {
    if (!Number.isFinite(joints[i])) throw new RangeError(`retargetMotion: joint value ${i} is ${joints[i]}; the motion must be finite`);
  }
  const { objects, infos } = bonesOf(root);
  validateMapping(mapping, infos);
  const byName = new Map<string, Object3D>();
  objects.forEach((o) => {
    if (!byName.has(o.name)) byName.set(o.name, o);
  });
  const bone = (j: JointName): Object3D | undefined => (mapping[j] !== undefined ? byName.get(mapping[j]!) : undefined);
  const mapped = (j: JointName) => mapping[j] !== undefined;

  // ---- rest pose, in the frame of `root`
  root.updateMatrixWorld(true);
  const rootInv = root.matrixWorld.clone().invert();
  const relWorld = (o: Object3D) => new Matrix4().multiplyMatrices(rootInv, o.matrixWorld);
  const pelvisBone = bone('pelvis')!;
  const subtree: Object3D[] = [];
  pelvisBone.traverse((o) => subtree.push(o)); // parents before children
  // feet rigged as IK targets outside the pelvis's tree (validateMapping allows that for ankles): their
  // subtrees follow, and their roots are placed where the shin ends
  const inPelvis = new Set(subtree);
  const detached = (['l', 'r'] as const).filter((s) => mapped(`${s}_ankle`) && !inPelvis.has(bone(`${s}_ankle`)!));
  for (const s of detached) bone(`${s}_ankle`)!.traverse((o) => subtree.push(o));
  const chainRoots = [pelvisBone, ...detached.map((s) => bone(`${s}_ankle`)!)];
  const slot = new Map(subtree.map((o, i) => [o, i]));
  const parentSlot = subtree.map((o) => (chainRoots.includes(o) ? -1 : slot.get(o.parent!)!));
  const constParent = new Map(chainRoots.map((o) => {
    const m = o.parent ? relWorld(o.parent) : new Matrix4();
    return [slot.get(o)!, { m, inv: m.clone().invert(), q: new Quaternion().setFromRotationMatrix(new Matrix4().extractRotation(m)) }];
  }));
  const detachedSlots = detached.map((s) => ({ s, slot: slot.get(bone(`${s}_ankle`)!)! }));
  const restLocalQ = subtree.map((o) => o.quaternion.clone());
  const restLocalP = subtree.map((o) => o.position.clone());
  const restLocalS = subtree.map((o) => o.scale.clone());
  const restWorldM = subtree.map((o) => relWorld(o));
  const restWorldQ = restWorldM.map((m) => new Quaternion().setFromRotationMatrix(new Matrix4().extractRotation(m)));
  const restWorldP = restWorldM.map((m) => new Vector3().setFromMatrixPosition(m));
  const pelvisParentM = pelvisBone.parent ? relWorld(pelvisBone.parent) : new Matrix4();
  const pelvisParentInv = pelvisParentM.clone().invert();
  const S = (j: JointName): number => slot.get(bone(j)!)!;
  const restPos = (j: JointName) => restWorldP[S(j)];

  // ---- our side: rest (reference T-pose) and the IK's global rotations
  const ours = restPositions(skeleton).map((p) => p.clone());
  const ik = yield* ikSteps(solveIKSteps(joints, frames, skeleton)); // in slices too: the first of six passes
  const P = (f: number, j: JointName) => new Vector3(joints[(f * J + I(j)) * 3], joints[(f * J + I(j)) * 3 + 1], joints[(f * J + I(j)) * 3 + 2]);

  // ---- facing: C turns our rest left (+X) onto the character's
  const yawOf = (a: Vector3) => Math.atan2(-a.z, a.x);
  const charAcross = restPos('l_hip').clone().sub(restPos('r_hip'));
  const ourAcross = ours[I('l_hip')].clone().sub(ours[I('r_hip')]);
  const yaw = yawOf(charAcross) - yawOf(ourAcross);
  const C = new Quaternion().setFromAxisAngle(new Vector3(0, 1, 0), yaw);
  const Cinv = C.clone().invert();

  // ---- what drives each mapped joint
  const descendant = (j: JointName): JointName | null => {
    for (let k = PRIMARY[j]; k; k = PRIMARY[k]) if (mapped(k)) return k;
    return null;
  };
  type Drive =
    | { kind: 'frame'; j: JointName; a: [JointName, JointName]; b: [JointName, JointName] }
    | { kind: 'limb'; j: JointName; k: JointName; S: Quaternion }
    | { kind: 'turn'; j: JointName; S: Quaternion };
  const drives: Drive[] = [];
  const restAlign = new Map<JointName, Quaternion>();
  JOINT_NAMES.forEach((j) => {
    if (!mapped(j)) return;
    const k = descendant(j);
    if (j === 'pelvis') {
      const up = k ?? 'neck';
      if (!mapped(up)) throw new MappingError('bone map: the pelvis needs a mapped spine joint, neck or head above it');
      drives.push({ kind: 'frame', j, a: ['r_hip', 'l_hip'], b: [j, up] });
      restAlign.set(j, new Quaternion());
      return;
    }
    if (j === 'spine3' && k) {
      const across: [JointName, JointName] | null = mapped('l_collar') && mapped('r_collar') ? ['r_collar', 'l_collar']
        : mapped('l_shoulder') && mapped('r_shoulder') ? ['r_shoulder', 'l_shoulder'] : null;
      if (across) {
        drives.push({ kind: 'frame', j, a: [j, k], b: across });
        restAlign.set(j, new Quaternion());
        return;
      }
    }
    // nearest mapped ancestor's rest alignment (for joints with nothing mapped below)
    let a = skeletonParent(j);
    while (a && !restAlign.has(a)) a = skeletonParent(a);
    if (k) {
      const e = restPos(k).clone().sub(restPos(j));
      const d = ours[I(k)].clone().sub(ours[I(j)]).applyQuaternion(C);
      if (e.lengthSq() < 1e-12) throw new MappingError(`bone map: ${j} → '${mapping[j]}' and ${k} → '${mapping[k]}' are at the same place in the rest pose; map ${k} to a bone further along the limb`);
      const Sj = swing(e, d);
      restAlign.set(j, Sj);
      drives.push({ kind: 'limb', j, k, S: Sj });
    } else if (PRIMARY[j]) {
      const Sa = a ? restAlign.get(a)! : new Quaternion();
      restAlign.set(j, Sa);
      drives.push({ kind: 'turn', j, S: Sa });
    }
    // our leaves (head, wrists, toes) keep their rest local rotation
  });
  const animated = new Set(drives.map((d) => S(d.j)));

  // ---- root translation
  const legLen = (hip: Vector3, knee: Vector3, ankle: Vector3) => hip.distanceTo(knee) + knee.distanceTo(ankle);
  const side = (s: 'l' | 'r') => [`${s}_hip`, `${s}_knee`, `${s}_ankle`] as JointName[];
  const charLeg = (['l', 'r'] as const).reduce((acc, s) => acc + legLen(...(side(s).map((j) => restPos(j)) as [Vector3, Vector3, Vector3])), 0) / 2;
  const offLen = (j: JointName) => Math.hypot(...(ik.offsets[I(j)] as V3));
  const ourLeg = (offLen('l_knee') + offLen('l_ankle') + offLen('r_knee') + offLen('r_ankle')) / 2;
  const scale = charLeg / ourLeg;
  const contact = (f: number, c: number) => (motion.contacts ? motion.contacts[f * 4 + c] > threshold : false);
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
    return hs[Math.floor((hs.length - 1) * (motion.contacts ? 0.5 : 0.05))];
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

  // ---- per frame: Δ (world delta rotation) of every animated slot
  const ourGlobal = (f: number): Quaternion[] => {
    const G: Quaternion[] = new Array(J);
    for (let j = 0; j < J; j++) {
      const o = (f * J + j) * 4;
      const L = new Quaternion(ik.quats[o], ik.quats[o + 1], ik.quats[o + 2], ik.quats[o + 3]);
      const p = skeleton.parents[j];
      G[j] = p < 0 ? L : G[p].clone().multiply(L);
    }
    return G;
  };
  const deltas = (f: number): Map<number, Quaternion> => {
    const G = ourGlobal(f);
    const out = new Map<number, Quaternion>();
    const dir = (a: JointName, b: JointName) => P(f, b).sub(P(f, a)).applyQuaternion(C);
    const rdir = (a: JointName, b: JointName) => restPos(b).clone().sub(restPos(a));
    for (const d of drives) {
      let D: Quaternion;
      if (d.kind === 'frame') {
        // primary a (exact), secondary b (its part across a)
        D = quatOfM3(alignFrames(arr(rdir(...d.a)), arr(rdir(...d.b)), arr(dir(...d.a)), arr(dir(...d.b))));
      } else {
        D = C.clone().multiply(G[I(d.j)]).multiply(Cinv).multiply(d.S);
        if (d.kind === 'limb') {
          const cur = rdir(d.j, d.k).applyQuaternion(D);
          D = swing(cur, dir(d.j, d.k)).multiply(D);
        }
      }
      out.set(S(d.j), D);
    }
    return out;
  };

  /** Where a detached ankle goes: the end of the shin (knee + its rest offset turned with the knee). */
  const detachedAt = (s: 'l' | 'r', M: Matrix4[], delta: Map<number, Quaternion>) =>
    new Vector3().setFromMatrixPosition(M[S(`${s}_knee`)]).add(restPos(`${s}_ankle`).clone().sub(restPos(`${s}_knee`)).applyQuaternion(delta.get(S(`${s}_knee`)) ?? new Quaternion()));

  /** Local rotations of the subtree (and world matrices, detached ankle positions when `withPositions`) for one frame. */
  const pose = (delta: Map<number, Quaternion>, rootP: Vector3, withPositions: boolean) => {
    const n = subtree.length;
    const W: Quaternion[] = new Array(n);
    const L: Quaternion[] = new Array(n);
    const M: Matrix4[] = new Array(n);
    const P: Vector3[] = [];
    withPositions ||= detached.length > 0;
    for (let i = 0; i < n; i++) {
      const cp = constParent.get(i);
      const pW = cp ? cp.q : W[parentSlot[i]];
      const D = delta.get(i);
      if (D) {
        W[i] = D.clone().multiply(restWorldQ[i]);
        L[i] = pW.clone().invert().multiply(W[i]).normalize();
      } else {
        L[i] = restLocalQ[i];
        W[i] = pW.clone().multiply(L[i]);
      }
      if (withPositions) {
        let pos = restLocalP[i];
        if (i === 0) pos = rootP.clone().applyMatrix4(pelvisParentInv);
        else if (cp) {
          const at = detachedAt(detachedSlots.find((d) => d.slot === i)!.s, M, delta);
          pos = at.applyMatrix4(cp.inv);
          P.push(pos);
        }
        const local = new Matrix4().compose(pos, L[i], restLocalS[i]);
        M[i] = new Matrix4().multiplyMatrices(cp ? cp.m : M[parentSlot[i]], local);
      }
    }
    return { L, M, P };
  };
  const posOf = (M: Matrix4[], j: JointName) => new Vector3().setFromMatrixPosition(M[S(j)]);

  const allDeltas: Map<number, Quaternion>[] = [];
  const rootPs: Vector3[] = [];
  const done = (pass: number, f: number) => (1 + pass + (f + 1) / frames) / PASSES;
  for (let f = 0; f < frames; f++) {
    allDeltas.push(deltas(f));
    rootPs.push(rootWorld(f, allDeltas[f].get(0) ?? new Quaternion()));
    yield done(0, f);
  }

  // ---- feet: pin the ankle on contact frames (two-bone IK on thigh and shin)
  let pinnedFrames = 0;
  if (motion.contacts) {
    const legs = (['l', 'r'] as const).map((s, c) => ({ s, c: c * 2 }));
    const ankles = legs.map(() => [] as Vector3[]);
    const toes = legs.map(() => [] as Vector3[]);
    for (let f = 0; f < frames; f++) {
      const { M } = pose(allDeltas[f], rootPs[f], true);
      legs.forEach(({ s }, li) => {
        ankles[li].push(posOf(M, `${s}_ankle`));
        if (mapped(`${s}_foot`)) toes[li].push(posOf(M, `${s}_foot`));
      });
      yield done(1, f);
    }
    // per frame: how far the ankle should move. On a contact frame: horizontally, the joint in contact
    // (the ankle where the heel is down, else the toe) onto its mean position over that contact run (as
    // our clean-up pinned it); vertically, so that the lower of heel (ankle) and ball (toe) is at its rest
    // height, i.e. on the floor (per frame: the foot rolls from heel to toe as ours does). In the fades
    // (blend frames on both sides of a stretch of contact frames), the correction of the stretch's
    // first/last frame, scaled down, so a fade our own clean-up already made is not made twice.
    const plans = legs.map(({ s, c }, li) => {
      const move: (Vector3 | null)[] = new Array(frames).fill(null);
      const wgt = new Float64Array(frames);
      const restA = restPos(`${s}_ankle`).y;
      const restT = mapped(`${s}_foot`) ? restPos(`${s}_foot`).y : null;
      const hasToe = restT !== null;
      const heel = (f: number) => contact(f, c);
      const ball = (f: number) => hasToe && contact(f, c + 1);
      // a rig without a toe bone, on the ball of its foot only: its ankle as high above its rest height
      // as ours is above our standing ankle height (scaled), where ours rolls forward (not held)
      const tiptoe = (f: number) => !hasToe && !contact(f, c) && contact(f, c + 1);
      // the held horizontal position of each frame's contact joint: its mean over its contact run
      const held: (Vector3 | null)[] = new Array(frames).fill(null);
      const holdRuns = (on: (f: number) => boolean, pts: Vector3[], skip: (f: number) => boolean) => {
        let start = -1;
        for (let f = 0; f <= frames; f++) {
          const o = f < frames && on(f);
          if (o && start < 0) start = f;
          if (!o && start >= 0) {
            const m = new Vector3();
            for (let g = start; g < f; g++) m.add(pts[g]);
            m.divideScalar(f - start);
            for (let g = start; g < f; g++) if (!skip(g)) held[g] = m;
            start = -1;
          }
        }
      };
      holdRuns(heel, ankles[li], () => false);
      if (hasToe) holdRuns(ball, toes[li], heel);
      const correction = (f: number): Vector3 => {
        if (tiptoe(f)) {
          // the ball is on the floor: only the foot's pitch raises the ankle, not a lift of our whole foot
          // (our toe above its floor height on a frame flagged as ball contact)
          const lift = Math.max(0, P(f, `${s}_foot`).y - hoToe);
          return new Vector3(0, scale * Math.max(0, P(f, `${s}_ankle`).y - ho - lift) - (ankles[li][f].y - restA), 0);
        }
        const pt = heel(f) ? ankles[li][f] : toes[li][f];
        const dy = Math.min(ankles[li][f].y - restA, hasToe ? toes[li][f].y - restT! : Infinity);
        return new Vector3(held[f]!.x - pt.x, -dy, held[f]!.z - pt.z);
      };
      let start = -1;
      for (let f = 0; f <= frames; f++) {
        const on = f < frames && (held[f] !== null || tiptoe(f));
        if (on && start < 0) start = f;
        if (!on && start >= 0) {
          const e = f - 1;
          const first = correction(start);
          const last = correction(e);
          for (let g = Math.max(0, start - blend); g <= Math.min(frames - 1, e + blend); g++) {
            const w = g < start ? 1 - (start - g) / (blend + 1) : g > e ? 1 - (g - e) / (blend + 1) : 1;
            if (w > wgt[g]) {
              wgt[g] = w;
              move[g] = (g < start ? first.clone() : g > e ? last.clone() : correction(g)).multiplyScalar(w);
            }
          }
          start = -1;
        }
      }
      return { s, move, wgt };
    });
    /** Thigh and shin turns that move the ankle A by d (two-bone IK in the knee's plane). */
    const legPin = (H: Vector3, K: Vector3, A: Vector3, d: Vector3) => {
      const r = twoBoneIK(arr(H), arr(A.clone().add(d)), arr(K), H.distanceTo(K), K.distanceTo(A));
      const q1 = swing(K.clone().sub(H), v(r.knee).sub(H));
      const shin = A.clone().sub(K).applyQuaternion(q1);
      const q2 = swing(shin, v(r.ankle).sub(v(r.knee)));
      const turn = Math.max(K.clone().sub(H).angleTo(v(r.knee).sub(H)), A.clone().sub(K).angleTo(v(r.ankle).sub(v(r.knee))));
      return { q1, q2, turn, reached: v(r.ankle) };
    };
    const legAt = (M: Matrix4[], s: 'l' | 'r') => ({ H: posOf(M, `${s}_hip`), K: posOf(M, `${s}_knee`), A: posOf(M, `${s}_ankle`) });
    /** The largest part t of a move (all of it where possible) that turns thigh and shin by at most
     * maxPinDeg: near a straight leg a small move of the ankle would swing the whole leg. */
    const reach = (solve: (t: number) => ReturnType<typeof legPin>) => {
      let best = solve(1);
      if (best.turn <= maxPin) return { ...best, t: 1 };
      let lo = 0;
      let hi = 1;
      best = solve(0);
      for (let it = 0; it < 10; it++) {
        const mid = (lo + hi) / 2;
        const m = solve(mid);
        if (m.turn > maxPin) hi = mid;
        else {
          lo = mid;
          best = m;
        }
      }
      return { ...best, t: lo };
    };
    // the root takes the weighted mean of the feet's horizontal moves (no limb turns for that); its
    // vertical move is, among heights between the feet's needs, the one that leaves the feet nearest
    // their targets once the legs have done what they can (a nearly straight leg can hardly reach
    // further, a bent one can); the legs make the rest
    for (let f = 0; f < frames; f++) {
      yield done(2, f);
      const active = plans.filter((p) => p.wgt[f] > 0);
      if (!active.length) continue;
      const corr = new Vector3();
      let sw = 0;
      for (const p of active) {
        corr.addScaledVector(p.move[f]!, p.wgt[f]);
        sw += p.wgt[f];
      }
      corr.divideScalar(sw);
      if (active.length > 1) {
        const { M } = pose(allDeltas[f], rootPs[f], true);
        const legs = active.map((p) => legAt(M, p.s));
        const ys = active.map((p) => p.move[f]!.y);
        const lo = Math.min(...ys);
        const hi = Math.max(...ys);
        const cost = (y: number) => Math.max(...active.map((p, k) => {
          // how far (vertically) the ankle stays from its target: what the cap leaves, or out of reach
          const d = p.move[f]!.clone().sub(new Vector3(corr.x, y, corr.z));
          const { reached } = reach((t) => legPin(legs[k].H, legs[k].K, legs[k].A, d.clone().multiplyScalar(t)));
          return p.wgt[f] * Math.abs(legs[k].A.y + d.y - reached.y); // a foot fading in/out counts less
        }));
        let best = lo;
        let bestCost = cost(best);
        // (stops once the feet are within 0.1 mm: most frames need no search)
        for (let k = 1; k <= 16 && bestCost > 1e-4 * (legs[0].H.distanceTo(legs[0].K) / 0.4); k++) {
          const y = lo + ((hi - lo) * k) / 16;
          const c = cost(y);
          if (c < bestCost - 1e-9) {
            best = y;
            bestCost = c;
          }
        }
        corr.y = best;
      }
      rootPs[f].add(corr);
      for (const p of active) p.move[f] = p.move[f]!.clone().sub(corr);
    }
    for (let f = 0; f < frames; f++) {
      yield done(3, f);
      if (!plans.some((p) => p.wgt[f] > 0)) continue;
      const { M } = pose(allDeltas[f], rootPs[f], true);
      for (const { s, move, wgt } of plans) {
        if (!(wgt[f] > 0)) continue;
        pinnedFrames++;
        const { H, K, A } = legAt(M, s);
        const best = reach((t) => legPin(H, K, A, move[f]!.clone().multiplyScalar(t)));
        const { q1, q2 } = best;
        // thigh and shin turn; every other driven bone (the ankle's too) keeps its world rotation
        const d = allDeltas[f];
        const hipSlot = S(`${s}_hip`);
        const kneeSlot = S(`${s}_knee`);
        d.set(hipSlot, q1.clone().multiply(d.get(hipSlot)!));
        d.set(kneeSlot, q2.clone().multiply(q1).multiply(d.get(kneeSlot)!));
      }
    }
  }

  // ---- tracks
  const tracked = subtree.map((_, i) => i).filter((i) => animated.has(i) || allDeltas.some((d) => d.has(i)));
  if (!tracked.includes(0)) tracked.unshift(0);
  const rotations = tracked.map(() => new Float32Array(frames * 4));
  const rootPositions = new Float32Array(frames * 3);
  const positions = detachedSlots.map(({ slot: i }) => ({ bone: subtree[i], data: new Float32Array(frames * 3) }));
  for (let f = 0; f < frames; f++) {
    const { L, P: detachedP } = pose(allDeltas[f], rootPs[f], false);
    detachedP.forEach((p, k) => positions[k].data.set([p.x, p.y, p.z], f * 3));
    tracked.forEach((i, t) => {
      const q = L[i];
      const o = f * 4;
      const r = rotations[t];
      const flip = f > 0 && r[o - 4] * q.x + r[o - 3] * q.y + r[o - 2] * q.z + r[o - 1] * q.w < 0 ? -1 : 1;
      r.set([q.x * flip, q.y * flip, q.z * flip, q.w * flip], o);
    });
    const lp = rootPs[f].clone().applyMatrix4(pelvisParentInv);
    rootPositions.set([lp.x, lp.y, lp.z], f * 3);
    yield done(4, f);
  }
  for (const r of rotations) for (let i = 0; i < r.length; i++) if (!Number.isFinite(r[i])) throw new Error('retargetMotion: a bone rotation came out non-finite (degenerate rest pose?)');

  const bones = tracked.map((i) => subtree[i]);
  const names = new Map<string, number>();
  root.traverse((o) => names.set(o.name, (names.get(o.name) ?? 0) + 1));
  const target = (o: Object3D) => (o.name && names.get(o.name) === 1 && PropertyBinding.sanitizeNodeName(o.name) === o.name ? o.name : o.uuid);
  const times = Array.from({ length: frames }, (_, f) => f / fps);
  const tracks = [new VectorKeyframeTrack(`${target(pelvisBone)}.position`, times, Array.from(rootPositions))];
  bones.forEach((o, t) => tracks.push(new QuaternionKeyframeTrack(`${target(o)}.quaternion`, times, Array.from(rotations[t]))));
  for (const p of positions) tracks.push(new VectorKeyframeTrack(`${target(p.bone)}.position`, times, Array.from(p.data)));
  const clip = new AnimationClip(opts.name ?? 'emdm', (frames - 1) / fps, tracks);
  return { clip, frames, fps, bones, rotations, rootPositions, positions, scale, yaw, pinnedFrames };
}

function skeletonParent(j: JointName): JointName | null {
  const p = PARENTS[JOINT_NAMES.indexOf(j)];
  return p >= 0 ? JOINT_NAMES[p] : null;
}
