/**
 * What turns each mapped bone of a character (retarget.ts's step 3): per mapped joint a Drive, chosen once
 * from the rest poses, and per frame the world delta rotation Δ of every driven bone from our IK's global
 * rotations and our joints' directions.
 *
 * ```ts
 * const drives = drivesFor(rig, mapping, ours, I, C);          // once
 * const delta = frameDeltas(drives, rig, I, C, G, (a, b) => …); // per frame: slot → Δ
 * ```
 */
import { Quaternion, Vector3 } from 'three';
import { type V3, alignFrames, quatFromMat } from '../../motion/math3';
import { JOINT_NAMES, PARENTS, type JointName } from '../../skeleton';
import { type BoneMapping, MappingError } from './mapping';
import type { RestRig } from './rest';

export const v = (a: V3) => new Vector3(a[0], a[1], a[2]);
export const arr = (a: Vector3): V3 => [a.x, a.y, a.z];
/** The smallest rotation taking direction a onto direction b. */
export const swing = (a: Vector3, b: Vector3) => new Quaternion().setFromUnitVectors(a.clone().normalize(), b.clone().normalize());
const quatOfM3 = (m: number[]) => {
  const q = quatFromMat(m);
  return new Quaternion(q[0], q[1], q[2], q[3]);
};

/** Our joint → the next joint down its chain whose direction drives it (PRIMARY child). */
const PRIMARY: Partial<Record<JointName, JointName>> = {
  pelvis: 'spine1', spine1: 'spine2', spine2: 'spine3', spine3: 'neck', neck: 'head',
  l_hip: 'l_knee', l_knee: 'l_ankle', l_ankle: 'l_foot', r_hip: 'r_knee', r_knee: 'r_ankle', r_ankle: 'r_foot',
  l_collar: 'l_shoulder', l_shoulder: 'l_elbow', l_elbow: 'l_wrist', r_collar: 'r_shoulder', r_shoulder: 'r_elbow', r_elbow: 'r_wrist',
};

/** frame: two directions (pelvis, chest); limb: towards the next mapped joint down; turn: with our rotation only. */
export type Drive =
  | { kind: 'frame'; j: JointName; a: [JointName, JointName]; b: [JointName, JointName] }
  | { kind: 'limb'; j: JointName; k: JointName; S: Quaternion }
  | { kind: 'turn'; j: JointName; S: Quaternion };

/** The drive of every mapped joint that moves (our leaves keep their rest local rotation). `ours`: our rest
 * positions; `I`: our joint's index; `C`: the facing turn. Throws MappingError where the map cannot drive a bone. */
export function drivesFor(rig: RestRig, mapping: BoneMapping, ours: Vector3[], I: (j: JointName) => number, C: Quaternion): Drive[] {
  const { mapped, restPos } = rig;
  const descendant = (j: JointName): JointName | null => {
    for (let k = PRIMARY[j]; k; k = PRIMARY[k]) if (mapped(k)) return k;
    return null;
  };
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
  return drives;
}

/** One frame's Δ (world delta rotation) of every driven slot: `G` our IK's global rotations of the frame,
 * `dir(a, b)` our joints' direction a → b in the frame, turned by C. */
export function frameDeltas(drives: Drive[], rig: RestRig, I: (j: JointName) => number, C: Quaternion, G: Quaternion[], dir: (a: JointName, b: JointName) => Vector3): Map<number, Quaternion> {
  const Cinv = C.clone().invert();
  const out = new Map<number, Quaternion>();
  const rdir = (a: JointName, b: JointName) => rig.restPos(b).clone().sub(rig.restPos(a));
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
    out.set(rig.S(d.j), D);
  }
  return out;
}

function skeletonParent(j: JointName): JointName | null {
  const p = PARENTS[JOINT_NAMES.indexOf(j)];
  return p >= 0 ? JOINT_NAMES[p] : null;
}
