/**
 * Inverse kinematics for the 22-joint SMPL-order rig: joint positions → root translation + local
 * joint rotations, with bone TWIST taken from body planes so a skinned mesh does not candy-wrap.
 *
 * Each non-leaf joint's global rotation G_j maps its rest frame onto a frame built from
 *   primary   = direction to its (main) child, measured from the joint's FK position (so bone
 *               length differences never accumulate down a chain),
 *   secondary = a twist reference:
 *     pelvis       hips across (l_hip − r_hip) is primary, spine up is secondary ("pelvis from the hips")
 *     spine1/2     across vector blended 2/3:1/3 and 1/3:2/3 between hips and chest
 *     spine3       neck up (primary), chest across = l_collar − r_collar (secondary; the collars
 *                  are rigid with the chest, the shoulders are not)
 *     neck         chest across (the head has no child joint: its twist follows the chest)
 *     collars      chest up
 *     hips, knees  the leg's bend-plane normal (hip→knee × knee→ankle), so the knee is a hinge
 *     ankles       the knee axis
 *     shoulders, elbows  the arm's bend-plane normal, so the elbow is a hinge
 *   When a limb is nearly straight its bend normal is undefined: it is blended towards the
 *   previous frame's axis (carried in the parent's frame), which keeps the twist continuous.
 * Leaves (feet, head, wrists) keep the parent's rotation (local identity).
 *
 * Output: rootPos = world position of joint 0 per frame; quats = local rotations (x,y,z,w) relative
 * to the parent, in the rest frame of `skeleton.offsets` (rest = T-pose, all rotations identity);
 * offsets = the rest offsets that go with the rotations: the children of the two multi-child
 * joints (pelvis: hips + spine1; spine3: neck + collars) get the motion's own mean offset in the
 * parent's frame, every other bone its reference direction at the motion's mean bone length. Our retargeted data keep each bone's direction from the source skeleton, so the pelvis and
 * chest "triangles" differ from the reference rest pose by a few centimetres (6.8 cm at the hips on
 * a Bandai clip); with the adapted offsets `forwardKinematics(rootPos, quats, offsets)` reproduces
 * the joints (measured in tests/unit/coreIk.test.ts). A rig should place its bones at `offsets`.
 * Pass `{ adaptOffsets: false }` to keep the reference skeleton exactly.
 *
 * Python's `emdm.motion.ik.solve_ik` is the same algorithm (the BVH files of `emdm.sample` and of the
 * page carry the same angles): tests/fixtures/parity/ik.* holds its numbers, checked by both languages.
 */
import {
  type M3, type Q4, type V3, IDENTITY, add, alignFrames, cross, dot, matFromQuat, mulMM, mulMV, mulTM, mulTV, norm,
  normalize, quatFromMat, scale, sub,
} from './math3';
import { type JointName, type SkeletonLike, standardJoints } from '../skeleton';

export interface IKResult {
  rootPos: Float32Array; // frames × 3
  quats: Float32Array; // frames × 22 × 4 (x, y, z, w), local
  /** per-joint offsets from the parent (rest pose) that go with these rotations, metres */
  offsets: number[][];
}

const v3 = (a: ArrayLike<number>, o = 0): V3 => [a[o], a[o + 1], a[o + 2]];
const mix = (a: V3, b: V3, wa: number): V3 => add(scale(normalize(a), wa), scale(normalize(b), 1 - wa));

/** Bend-plane normal of a limb a→b→c, sign-aligned with and blended towards `ref` when straight. */
function bendAxis(a: V3, b: V3, c: V3, ref: V3): V3 {
  const u = sub(b, a);
  const w = sub(c, b);
  const n = cross(u, w);
  const sin = norm(n) / Math.max(norm(u) * norm(w), 1e-12);
  let nh = normalize(n, ref);
  if (dot(nh, ref) < 0) nh = scale(nh, -1); // never flip the hinge: a reversed bend is hyperextension
  const wgt = Math.min(1, Math.max(0, (sin - 0.03) / (0.2 - 0.03)));
  return normalize(add(scale(nh, wgt), scale(normalize(ref), 1 - wgt)), ref);
}

/** Mean offsets, in the parent's frame, of the children of pelvis and spine3 (see solveIK). */
function adaptedOffsets(joints: Float32Array, frames: number, skeleton: SkeletonLike, I: (n: JointName) => number): V3[] {
  const J = skeleton.joints.length;
  const off = skeleton.offsets.map((o) => v3(o));
  const out = off.map((o) => [...o] as V3);
  const groups: [JointName, JointName, JointName, JointName, JointName, JointName[]][] = [
    // parent, frame primary a→b, frame secondary c−d, children to adapt
    ['pelvis', 'r_hip', 'l_hip', 'spine1', 'pelvis', ['l_hip', 'r_hip', 'spine1']],
    ['spine3', 'spine3', 'neck', 'l_collar', 'r_collar', ['neck', 'l_collar', 'r_collar']],
  ];
  for (const [parent, a, b, c, d, kids] of groups) {
    const sums = kids.map(() => [0, 0, 0] as V3);
    const P = (f: number, n: JointName): V3 => v3(joints, (f * J + I(n)) * 3);
    for (let f = 0; f < frames; f++) {
      const G = parent === 'pelvis'
        ? alignFrames(sub(off[I('l_hip')], off[I('r_hip')]), off[I('spine1')], sub(P(f, b), P(f, a)), sub(P(f, c), P(f, d)))
        : alignFrames(off[I('neck')], sub(off[I('l_collar')], off[I('r_collar')]), sub(P(f, b), P(f, a)), sub(P(f, c), P(f, d)));
      kids.forEach((k, i) => (sums[i] = add(sums[i], mulTV(G, sub(P(f, k), P(f, parent))))));
    }
    kids.forEach((k, i) => {
      const m = scale(sums[i], 1 / frames);
      if (m.every(Number.isFinite) && norm(m) > 1e-6) out[I(k)] = m;
    });
  }
  // every other bone keeps its reference direction at the motion's mean length
  const adapted = new Set(groups.flatMap((g) => g[5].map((n) => I(n))));
  skeleton.parents.forEach((p, j) => {
    if (p < 0 || adapted.has(j)) return;
    let sum = 0;
    for (let f = 0; f < frames; f++) sum += norm(sub(v3(joints, (f * J + j) * 3), v3(joints, (f * J + p) * 3)));
    const len = sum / frames;
    const ref = norm(off[j]);
    if (Number.isFinite(len) && len > 1e-6 && ref > 1e-9) out[j] = scale(off[j], len / ref);
  });
  return out;
}

export function solveIK(joints: Float32Array, frames: number, skeleton: SkeletonLike, opts: { adaptOffsets?: boolean } = {}): IKResult {
  const steps = solveIKSteps(joints, frames, skeleton, opts);
  for (;;) {
    const r = steps.next();
    if (r.done) return r.value;
  }
}

const X: V3 = [1, 0, 0];
const Y: V3 = [0, 1, 0];

/** Rest flexion axes of legs and arms: the rest limb's own bend normal when it is visibly bent, else the
 * anatomical default (knees flex about +X; elbows about −Y (left) / +Y (right) in the T-pose). */
function restBendAxes(rest: V3[], I: (j: JointName) => number) {
  const restAxis = (a: JointName, b: JointName, dflt: V3): V3 => {
    const n = cross(rest[I(a)], rest[I(b)]);
    const sin = norm(n) / Math.max(norm(rest[I(a)]) * norm(rest[I(b)]), 1e-12);
    if (sin < 0.03) return dflt;
    const nh = normalize(n);
    return dot(nh, dflt) < 0 ? scale(nh, -1) : nh;
  };
  return {
    legAxisRest: { l: restAxis('l_knee', 'l_ankle', X), r: restAxis('r_knee', 'r_ankle', X) },
    armAxisRest: { l: restAxis('l_elbow', 'l_wrist', [0, -1, 0]), r: restAxis('r_elbow', 'r_wrist', [0, 1, 0]) },
  };
}

/** A motion's pose as results carry it: the root's position and every joint's local rotation, and the ms the solve took. */
export interface MotionPose {
  rootPos: Float32Array; // frames × 3
  quats: Float32Array; // frames × 22 × 4, xyzw
  /** the rest offsets the rotations go with (solveIK's `offsets`), 22 × 3: a rig puts its bones there (placeBones) */
  offsets: Float32Array;
  ikMs: number;
}

/**
 * The pose of frames × 22 × 3 joints (solveIK): the one place a generated motion's joints become bone rotations —
 * the generation host's results in the worker and in-process alike (GenerationHost.pose) and a motion without a
 * pose played by src/three.ts.
 */
export function solvePose(joints: Float32Array, frames: number, skeleton: SkeletonLike): MotionPose {
  const t0 = performance.now();
  const ik = solveIK(joints, frames, skeleton);
  return { rootPos: ik.rootPos, quats: ik.quats, offsets: new Float32Array(ik.offsets.flat()), ikMs: performance.now() - t0 };
}

/** solveIK as a generator that yields (the share of frames solved) after each frame, so a caller can run it in slices (src/character/retarget). */
export function* solveIKSteps(joints: Float32Array, frames: number, skeleton: SkeletonLike, opts: { adaptOffsets?: boolean } = {}): Generator<number, IKResult, void> {
  const J = skeleton.joints.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`solveIK: joints has ${joints.length} values, expected frames (${frames}) × ${J} × 3`);
  const I = standardJoints(skeleton, 'solveIK');
  const par = skeleton.parents;
  const rest = skeleton.offsets.map((o) => v3(o)); // defines the rest frames (rotation = identity)
  const off = opts.adaptOffsets === false || frames === 0 ? rest : adaptedOffsets(joints, frames, skeleton, I); // FK offsets
  const restAcrossHip = sub(rest[I('l_hip')], rest[I('r_hip')]);
  const { legAxisRest, armAxisRest } = restBendAxes(rest, I);
  const rootPos = new Float32Array(frames * 3);
  const quats = new Float32Array(frames * J * 4);
  // previous frame's bend axes in the parent's frame (continuity when a limb is straight)
  const prevAxisLocal = new Map<string, V3>();
  const prevQ: (Q4 | null)[] = new Array(J).fill(null);

  for (let f = 0; f < frames; f++) {
    const P = (j: number): V3 => v3(joints, (f * J + j) * 3);
    const G: M3[] = new Array(J);
    const Q: V3[] = new Array(J);
    const set = (j: number, g: M3) => {
      G[j] = g;
    };
    const fkPos = (j: number): V3 => (par[j] < 0 ? P(j) : add(Q[par[j]], mulMV(G[par[j]], off[j])));

    const hipAcross = sub(P(I('l_hip')), P(I('r_hip')));
    // collars are rigid with the chest (shoulders are not: they move with the collar rotation)
    const chestAcross = sub(P(I('l_collar')), P(I('r_collar')));
    const restChestAcross = sub(rest[I('l_collar')], rest[I('r_collar')]);

    const limbAxis = (key: string, parent: number, a: number, b: number, c: number, rest: V3): V3 => {
      const prev = prevAxisLocal.get(key);
      const ref = prev ? mulMV(G[parent], prev) : mulMV(G[parent], rest);
      const axis = bendAxis(P(a), P(b), P(c), ref);
      prevAxisLocal.set(key, mulTV(G[parent], axis));
      return axis;
    };

    for (let j = 0; j < J; j++) {
      Q[j] = fkPos(j);
      const name = skeleton.joints[j] as JointName;
      const p = par[j];
      const Gp = p < 0 ? IDENTITY : G[p];
      const toChild = (c: JointName) => sub(P(I(c)), Q[j]);
      switch (name) {
        case 'pelvis':
          set(j, alignFrames(restAcrossHip, rest[I('spine1')], hipAcross, sub(P(I('spine1')), Q[j])));
          break;
        case 'spine1':
          set(j, alignFrames(rest[I('spine2')], X, toChild('spine2'), mix(hipAcross, chestAcross, 2 / 3)));
          break;
        case 'spine2':
          set(j, alignFrames(rest[I('spine3')], X, toChild('spine3'), mix(hipAcross, chestAcross, 1 / 3)));
          break;
        case 'spine3':
          set(j, alignFrames(rest[I('neck')], restChestAcross, toChild('neck'), chestAcross));
          break;
        case 'neck':
          set(j, alignFrames(rest[I('head')], X, toChild('head'), mulMV(Gp, X)));
          break;
        case 'l_collar':
        case 'r_collar': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(rest[I(`${s}_shoulder`)], Y, toChild(`${s}_shoulder`), mulMV(Gp, Y)));
          break;
        }
        case 'l_hip':
        case 'r_hip': {
          const s = name[0] as 'l' | 'r';
          const axis = limbAxis(`${s}_leg`, p, j, I(`${s}_knee`), I(`${s}_ankle`), legAxisRest[s]);
          set(j, alignFrames(rest[I(`${s}_knee`)], legAxisRest[s], toChild(`${s}_knee`), axis));
          break;
        }
        case 'l_knee':
        case 'r_knee': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(rest[I(`${s}_ankle`)], legAxisRest[s], toChild(`${s}_ankle`), mulMV(Gp, legAxisRest[s])));
          break;
        }
        case 'l_ankle':
        case 'r_ankle': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(rest[I(`${s}_foot`)], legAxisRest[s], toChild(`${s}_foot`), mulMV(Gp, legAxisRest[s])));
          break;
        }
        case 'l_shoulder':
        case 'r_shoulder': {
          const s = name[0] as 'l' | 'r';
          const axis = limbAxis(`${s}_arm`, p, j, I(`${s}_elbow`), I(`${s}_wrist`), armAxisRest[s]);
          set(j, alignFrames(rest[I(`${s}_elbow`)], armAxisRest[s], toChild(`${s}_elbow`), axis));
          break;
        }
        case 'l_elbow':
        case 'r_elbow': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(rest[I(`${s}_wrist`)], armAxisRest[s], toChild(`${s}_wrist`), mulMV(Gp, armAxisRest[s])));
          break;
        }
        default: // leaves: feet, head, wrists
          set(j, Gp);
      }
      const local = p < 0 ? G[j] : mulTM(Gp, G[j]);
      let q = quatFromMat(local);
      const pq = prevQ[j];
      if (pq && pq[0] * q[0] + pq[1] * q[1] + pq[2] * q[2] + pq[3] * q[3] < 0) q = [-q[0], -q[1], -q[2], -q[3]];
      prevQ[j] = q;
      quats.set(q, (f * J + j) * 4);
    }
    rootPos.set(P(0), f * 3);
    yield (f + 1) / frames;
  }
  return { rootPos, quats, offsets: off.map((o) => [...o]) };
}

/** Joint world positions (frames × J × 3) from root positions and local rotations on `skeleton`. */
export function forwardKinematics(rootPos: Float32Array, quats: Float32Array, frames: number, skeleton: SkeletonLike, offsets: number[][] = skeleton.offsets): Float32Array {
  const J = skeleton.joints.length;
  if (rootPos.length !== frames * 3 || quats.length !== frames * J * 4) {
    throw new RangeError(`forwardKinematics: expected rootPos ${frames}×3 and quats ${frames}×${J}×4, got ${rootPos.length} and ${quats.length}`);
  }
  const out = new Float32Array(frames * J * 3);
  const G: M3[] = new Array(J);
  const Q: V3[] = new Array(J);
  for (let f = 0; f < frames; f++) {
    for (let j = 0; j < J; j++) {
      const p = skeleton.parents[j];
      const R = matFromQuat(quats, (f * J + j) * 4);
      if (p < 0) {
        Q[j] = v3(rootPos, f * 3);
        G[j] = R;
      } else {
        Q[j] = add(Q[p], mulMV(G[p], v3(offsets[j])));
        G[j] = mulMM(G[p], R);
      }
      out.set(Q[j], (f * J + j) * 3);
    }
  }
  return out;
}
