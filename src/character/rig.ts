// The reference skeleton as three.js bones: one Bone per joint, named after the joint, placed at its
// rest T-pose offset from the parent (Y up, metres, facing +Z, left side at +X). The pelvis bone's
// position is the root translation; every bone's quaternion is its LOCAL rotation, which is exactly
// what solveIK returns, so a pose is applied by copying numbers, with no retargeting.
import { Bone, Vector3 } from 'three';

/** The part of the manifest's skeleton the character needs (structurally a subset of it). */
export interface RigSkeleton {
  joints: string[];
  parents: number[];
  offsets: number[][];
}

export class SkeletonFormatError extends Error {
  constructor(field: string, message: string) {
    super(`manifest skeleton.${field}: ${message}`);
    this.name = 'SkeletonFormatError';
  }
}

/** Validate the skeleton block (names the bad field) and return the joint count. */
export function checkSkeleton(s: RigSkeleton): number {
  const n = Array.isArray(s?.joints) ? s.joints.length : 0;
  if (n < 2) throw new SkeletonFormatError('joints', 'expected a list of joint names');
  if (!Array.isArray(s.parents) || s.parents.length !== n) {
    throw new SkeletonFormatError('parents', `expected ${n} entries, one per joint`);
  }
  if (!Array.isArray(s.offsets) || s.offsets.length !== n) {
    throw new SkeletonFormatError('offsets', `expected ${n} [x, y, z] rows, one per joint`);
  }
  s.parents.forEach((p, j) => {
    if (!(Number.isInteger(p) && p < j && (p >= 0 || (j === 0 && p === -1)))) {
      throw new SkeletonFormatError(`parents[${j}]`, `${p} is not an earlier joint (the root alone has -1)`);
    }
  });
  s.offsets.forEach((o, j) => {
    if (!Array.isArray(o) || o.length !== 3 || !o.every(Number.isFinite)) {
      throw new SkeletonFormatError(`offsets[${j}]`, 'expected three finite numbers');
    }
  });
  return n;
}

/** World positions of the joints in the rest pose (n × Vector3). */
export function restPositions(s: RigSkeleton): Vector3[] {
  checkSkeleton(s);
  const out: Vector3[] = [];
  s.parents.forEach((p, j) => {
    const o = new Vector3().fromArray(s.offsets[j]);
    out.push(p < 0 ? o : o.add(out[p]));
  });
  return out;
}

/** One Bone per joint, parented as in the skeleton; bones[0] is the root (pelvis). */
export function buildBones(s: RigSkeleton): Bone[] {
  checkSkeleton(s);
  const bones = s.joints.map((name, j) => {
    const b = new Bone();
    b.name = name;
    b.position.fromArray(s.offsets[j]);
    return b;
  });
  s.parents.forEach((p, j) => {
    if (p >= 0) bones[p].add(bones[j]);
  });
  return bones;
}

/** Children of each joint (index lists). */
export function childrenOf(s: RigSkeleton): number[][] {
  const kids: number[][] = s.joints.map(() => []);
  s.parents.forEach((p, j) => {
    if (p >= 0) kids[p].push(j);
  });
  return kids;
}
