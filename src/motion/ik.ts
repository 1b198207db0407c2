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
 * to the parent, in the rest frame of `skeleton.offsets` (rest = T-pose, all rotations identity).
 * `forwardKinematics(solveIK(j))` reproduces j to within the bone-length differences between j and
 * the skeleton (see tests/unit/coreIk.test.ts for the measured error).
 */
import {
  type M3, type Q4, type V3, IDENTITY, add, alignFrames, cross, dot, matFromQuat, mulMM, mulMV, mulTM, mulTV, norm,
  normalize, quatFromMat, scale, sub,
} from './math3';

export interface SkeletonLike {
  joints: string[];
  parents: number[];
  offsets: number[][];
}

const NAMES = [
  'pelvis', 'l_hip', 'r_hip', 'spine1', 'l_knee', 'r_knee', 'spine2', 'l_ankle', 'r_ankle', 'spine3', 'l_foot',
  'r_foot', 'neck', 'l_collar', 'r_collar', 'head', 'l_shoulder', 'r_shoulder', 'l_elbow', 'r_elbow', 'l_wrist', 'r_wrist',
] as const;
type Name = (typeof NAMES)[number];

export interface IKResult {
  rootPos: Float32Array; // frames × 3
  quats: Float32Array; // frames × 22 × 4 (x, y, z, w), local
}

function indexer(skeleton: SkeletonLike): (n: Name) => number {
  const idx = new Map(skeleton.joints.map((n, i) => [n, i]));
  const missing = NAMES.filter((n) => !idx.has(n));
  if (missing.length) throw new Error(`solveIK: skeleton.joints lacks ${missing.join(', ')} (the 22-joint SMPL-order rig is required)`);
  if (skeleton.parents.length !== skeleton.joints.length || skeleton.offsets.length !== skeleton.joints.length) {
    throw new Error(`solveIK: skeleton has ${skeleton.joints.length} joints but ${skeleton.parents.length} parents and ${skeleton.offsets.length} offsets`);
  }
  return (n) => idx.get(n)!;
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

export function solveIK(joints: Float32Array, frames: number, skeleton: SkeletonLike): IKResult {
  const J = skeleton.joints.length;
  if (joints.length !== frames * J * 3) throw new RangeError(`solveIK: joints has ${joints.length} values, expected frames (${frames}) × ${J} × 3`);
  const I = indexer(skeleton);
  const par = skeleton.parents;
  const off = skeleton.offsets.map((o) => v3(o));
  const X: V3 = [1, 0, 0];
  const Y: V3 = [0, 1, 0];
  const restAcrossHip = sub(off[I('l_hip')], off[I('r_hip')]);
  // Rest flexion axes: the rest limb's own bend normal when it is visibly bent, else the
  // anatomical default (knees flex about +X; elbows about −Y (left) / +Y (right) in the T-pose).
  const restAxis = (a: Name, b: Name, dflt: V3): V3 => {
    const n = cross(off[I(a)], off[I(b)]);
    const sin = norm(n) / Math.max(norm(off[I(a)]) * norm(off[I(b)]), 1e-12);
    if (sin < 0.03) return dflt;
    const nh = normalize(n);
    return dot(nh, dflt) < 0 ? scale(nh, -1) : nh;
  };
  const legAxisRest = { l: restAxis('l_knee', 'l_ankle', X), r: restAxis('r_knee', 'r_ankle', X) };
  const armAxisRest = { l: restAxis('l_elbow', 'l_wrist', [0, -1, 0]), r: restAxis('r_elbow', 'r_wrist', [0, 1, 0]) };
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
    const restChestAcross = sub(off[I('l_collar')], off[I('r_collar')]);

    const limbAxis = (key: string, parent: number, a: number, b: number, c: number, rest: V3): V3 => {
      const prev = prevAxisLocal.get(key);
      const ref = prev ? mulMV(G[parent], prev) : mulMV(G[parent], rest);
      const axis = bendAxis(P(a), P(b), P(c), ref);
      prevAxisLocal.set(key, mulTV(G[parent], axis));
      return axis;
    };

    for (let j = 0; j < J; j++) {
      Q[j] = fkPos(j);
      const name = skeleton.joints[j] as Name;
      const p = par[j];
      const Gp = p < 0 ? IDENTITY : G[p];
      const toChild = (c: Name) => sub(P(I(c)), Q[j]);
      switch (name) {
        case 'pelvis':
          set(j, alignFrames(restAcrossHip, off[I('spine1')], hipAcross, sub(P(I('spine1')), Q[j])));
          break;
        case 'spine1':
          set(j, alignFrames(off[I('spine2')], X, toChild('spine2'), mix(hipAcross, chestAcross, 2 / 3)));
          break;
        case 'spine2':
          set(j, alignFrames(off[I('spine3')], X, toChild('spine3'), mix(hipAcross, chestAcross, 1 / 3)));
          break;
        case 'spine3':
          set(j, alignFrames(off[I('neck')], restChestAcross, toChild('neck'), chestAcross));
          break;
        case 'neck':
          set(j, alignFrames(off[I('head')], X, toChild('head'), mulMV(Gp, X)));
          break;
        case 'l_collar':
        case 'r_collar': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(off[I(`${s}_shoulder`)], Y, toChild(`${s}_shoulder`), mulMV(Gp, Y)));
          break;
        }
        case 'l_hip':
        case 'r_hip': {
          const s = name[0] as 'l' | 'r';
          const axis = limbAxis(`${s}_leg`, p, j, I(`${s}_knee`), I(`${s}_ankle`), legAxisRest[s]);
          set(j, alignFrames(off[I(`${s}_knee`)], legAxisRest[s], toChild(`${s}_knee`), axis));
          break;
        }
        case 'l_knee':
        case 'r_knee': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(off[I(`${s}_ankle`)], legAxisRest[s], toChild(`${s}_ankle`), mulMV(Gp, legAxisRest[s])));
          break;
        }
        case 'l_ankle':
        case 'r_ankle': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(off[I(`${s}_foot`)], legAxisRest[s], toChild(`${s}_foot`), mulMV(Gp, legAxisRest[s])));
          break;
        }
        case 'l_shoulder':
        case 'r_shoulder': {
          const s = name[0] as 'l' | 'r';
          const axis = limbAxis(`${s}_arm`, p, j, I(`${s}_elbow`), I(`${s}_wrist`), armAxisRest[s]);
          set(j, alignFrames(off[I(`${s}_elbow`)], armAxisRest[s], toChild(`${s}_elbow`), axis));
          break;
        }
        case 'l_elbow':
        case 'r_elbow': {
          const s = name[0] as 'l' | 'r';
          set(j, alignFrames(off[I(`${s}_wrist`)], armAxisRest[s], toChild(`${s}_wrist`), mulMV(Gp, armAxisRest[s])));
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
  }
  return { rootPos, quats };
}

/** Joint world positions (frames × J × 3) from root positions and local rotations on `skeleton`. */
export function forwardKinematics(rootPos: Float32Array, quats: Float32Array, frames: number, skeleton: SkeletonLike): Float32Array {
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
        Q[j] = add(Q[p], mulMV(G[p], v3(skeleton.offsets[j])));
        G[j] = mulMM(G[p], R);
      }
      out.set(Q[j], (f * J + j) * 3);
    }
  }
  return out;
}
