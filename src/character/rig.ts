// The reference skeleton as three.js bones: one Bone per joint, named after the joint, placed at its
// rest T-pose offset from the parent (Y up, metres, facing +Z, left side at +X). The pelvis bone's
// position is the root translation; every bone's quaternion is its LOCAL rotation, which is exactly
// what solveIK returns, so a pose is applied by copying numbers, with no retargeting.
import { Bone, Vector3 } from 'three';
import { checkSkeleton, type SkeletonLike } from '../skeleton';

/** World positions of the joints in the rest pose (n × Vector3). */
export function restPositions(s: SkeletonLike): Vector3[] {
  checkSkeleton(s);
  const out: Vector3[] = [];
  s.parents.forEach((p, j) => {
    const o = new Vector3().fromArray(s.offsets[j]);
    out.push(p < 0 ? o : o.add(out[p]));
  });
  return out;
}

/** One Bone per joint, parented as in the skeleton; bones[0] is the root (pelvis). */
export function buildBones(s: SkeletonLike): Bone[] {
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
