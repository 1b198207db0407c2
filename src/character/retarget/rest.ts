/**
 * The character's side of the retargeting (retarget.ts): its rest pose read from the scene once, in the frame
 * of `root`, and the posing of one frame from world delta rotations (retarget.ts's steps 3–5).
 *
 * ```ts
 * const rig = readRest(root, mapping, bonesOf(root).objects);   // before anything is posed
 * const { L, M } = poseFrame(rig, deltas, rootWorldPosition, true);
 * ```
 */
import { Matrix4, type Object3D, Quaternion, Vector3 } from 'three';
import type { JointName } from '../../skeleton';
import type { BoneMapping } from './mapping';

/** A bone whose parent's world matrix does not move (the pelvis bone; a foot rigged outside its tree). */
interface FixedParent {
  m: Matrix4;
  inv: Matrix4;
  q: Quaternion;
}

export interface RestRig {
  pelvisBone: Object3D;
  /** the animated part of the scene, parents before children: the pelvis bone's tree, then detached feet's */
  subtree: Object3D[];
  /** feet rigged as IK targets outside the pelvis's tree, with their slot in `subtree` */
  detachedSlots: { s: 'l' | 'r'; slot: number }[];
  parentSlot: number[];
  fixedParent: Map<number, FixedParent>;
  restLocalQ: Quaternion[];
  restLocalP: Vector3[];
  restLocalS: Vector3[];
  restWorldQ: Quaternion[];
  restWorldP: Vector3[];
  pelvisParentInv: Matrix4;
  /** the bone a joint is mapped to */
  bone(j: JointName): Object3D | undefined;
  mapped(j: JointName): boolean;
  /** a mapped joint's slot in `subtree` */
  S(j: JointName): number;
  /** a mapped joint's rest position in the frame of `root` */
  restPos(j: JointName): Vector3;
}

/** The character's rest pose under `root` (which must be at rest), for a validated `mapping` onto `objects` (its bones). */
export function readRest(root: Object3D, mapping: BoneMapping, objects: Object3D[]): RestRig {
  const byName = new Map<string, Object3D>();
  objects.forEach((o) => {
    if (!byName.has(o.name)) byName.set(o.name, o);
  });
  const bone = (j: JointName): Object3D | undefined => (mapping[j] !== undefined ? byName.get(mapping[j]!) : undefined);
  const mapped = (j: JointName) => mapping[j] !== undefined;
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
  const fixedParent = new Map(chainRoots.map((o) => {
    const m = o.parent ? relWorld(o.parent) : new Matrix4();
    return [slot.get(o)!, { m, inv: m.clone().invert(), q: new Quaternion().setFromRotationMatrix(new Matrix4().extractRotation(m)) }];
  }));
  const restWorldM = subtree.map((o) => relWorld(o));
  const restWorldP = restWorldM.map((m) => new Vector3().setFromMatrixPosition(m));
  const pelvisParentM = pelvisBone.parent ? relWorld(pelvisBone.parent) : new Matrix4();
  const S = (j: JointName): number => slot.get(bone(j)!)!;
  return {
    pelvisBone, subtree, parentSlot, fixedParent,
    detachedSlots: detached.map((s) => ({ s, slot: slot.get(bone(`${s}_ankle`)!)! })),
    restLocalQ: subtree.map((o) => o.quaternion.clone()),
    restLocalP: subtree.map((o) => o.position.clone()),
    restLocalS: subtree.map((o) => o.scale.clone()),
    restWorldQ: restWorldM.map((m) => new Quaternion().setFromRotationMatrix(new Matrix4().extractRotation(m))),
    restWorldP,
    pelvisParentInv: pelvisParentM.clone().invert(),
    bone, mapped, S,
    restPos: (j) => restWorldP[S(j)],
  };
}

/** Where a detached ankle goes: the end of the shin (knee + its rest offset turned with the knee). */
function detachedAt(rig: RestRig, s: 'l' | 'r', M: Matrix4[], delta: Map<number, Quaternion>): Vector3 {
  const { S, restPos } = rig;
  return new Vector3().setFromMatrixPosition(M[S(`${s}_knee`)]).add(restPos(`${s}_ankle`).clone().sub(restPos(`${s}_knee`)).applyQuaternion(delta.get(S(`${s}_knee`)) ?? new Quaternion()));
}

/** Local rotations of the subtree (and world matrices, detached ankle positions when `withPositions`) for one
 * frame: `delta` holds the world delta rotation of each driven slot, `rootP` the pelvis bone's position. */
export function poseFrame(rig: RestRig, delta: Map<number, Quaternion>, rootP: Vector3, withPositions: boolean) {
  const { subtree, fixedParent, parentSlot, restWorldQ, restLocalQ, restLocalP, restLocalS, detachedSlots } = rig;
  const n = subtree.length;
  const W: Quaternion[] = new Array(n);
  const L: Quaternion[] = new Array(n);
  const M: Matrix4[] = new Array(n);
  const P: Vector3[] = [];
  withPositions ||= detachedSlots.length > 0;
  for (let i = 0; i < n; i++) {
    const cp = fixedParent.get(i);
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
      if (i === 0) pos = rootP.clone().applyMatrix4(rig.pelvisParentInv);
      else if (cp) {
        const at = detachedAt(rig, detachedSlots.find((d) => d.slot === i)!.s, M, delta);
        pos = at.applyMatrix4(cp.inv);
        P.push(pos);
      }
      const local = new Matrix4().compose(pos, L[i], restLocalS[i]);
      M[i] = new Matrix4().multiplyMatrices(cp ? cp.m : M[parentSlot[i]], local);
    }
  }
  return { L, M, P };
}

/** A mapped joint's world position in a posed frame's matrices. */
export const posOf = (rig: RestRig, M: Matrix4[], j: JointName) => new Vector3().setFromMatrixPosition(M[rig.S(j)]);
