/**
 * The 22-joint SMPL-order skeleton (Python: `emdm.skeleton`): joint names, parents, kinematic
 * chains, the skeleton type the manifest carries, and its check.
 *
 * ```ts
 * const manifest = await loadManifest('/models/');
 * checkSkeleton(manifest.skeleton);                 // throws SkeletonFormatError naming the field
 * const I = standardJoints(manifest.skeleton, 'my rig');
 * const leftWrist = I('l_wrist');                   // index into joints / parents / offsets
 * ```
 *
 * The numbers of the reference skeleton (offsets, fps, …) come from `public/models/manifest.json`,
 * which `emdm.manifest` writes from `emdm.skeleton`; the constants here are the STRUCTURE the IK and
 * the character are written for, and tests/unit/coreSkeleton.test.ts checks them against that manifest
 * (tests/python/test_skeleton.py checks the manifest against Python).
 */

/** Joint names in SMPL order (the manifest's `skeleton.joints`). */
export const JOINT_NAMES = [
  'pelvis', 'l_hip', 'r_hip', 'spine1', 'l_knee', 'r_knee', 'spine2', 'l_ankle', 'r_ankle', 'spine3', 'l_foot',
  'r_foot', 'neck', 'l_collar', 'r_collar', 'head', 'l_shoulder', 'r_shoulder', 'l_elbow', 'r_elbow', 'l_wrist', 'r_wrist',
] as const;
export type JointName = (typeof JOINT_NAMES)[number];

/** PARENTS[j]: the parent of joint j in SMPL order (−1 for the pelvis). */
export const PARENTS: readonly number[] = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19];

/** Right leg, left leg, spine to head, right arm, left arm (joint indices in SMPL order). */
export const KINEMATIC_CHAINS: readonly (readonly number[])[] = [
  [0, 2, 5, 8, 11], [0, 1, 4, 7, 10], [0, 3, 6, 9, 12, 15], [9, 14, 17, 19, 21], [9, 13, 16, 18, 20],
];

/** The joints of the four foot-contact channels (features [259:263]), in that order. */
export const FOOT_JOINT_NAMES: readonly JointName[] = ['l_ankle', 'l_foot', 'r_ankle', 'r_foot'];

/** What a rig needs: joint names, parents (earlier joints; the root −1) and rest offsets (metres). */
export interface SkeletonLike {
  joints: string[];
  parents: number[];
  /** offset of each joint from its parent in the rest T-pose (the root: its position) */
  offsets: number[][];
}

/** The manifest's `skeleton` block (docs/MANIFEST.md): the rig plus the motion format. */
export interface Skeleton extends SkeletonLike {
  offsets: [number, number, number][];
  chains: number[][];
  /** [l_ankle, l_foot, r_ankle, r_foot] joint indices, the order of the four contact channels */
  footJoints: number[];
  fps: number;
  maxFrames: number;
  featureDim: number;
}

export class SkeletonFormatError extends Error {
  constructor(field: string, message: string) {
    super(`manifest skeleton.${field}: ${message}`);
    this.name = 'SkeletonFormatError';
  }
}

/** Validate a rig's structure (names the bad field) and return the joint count. */
export function checkSkeleton(s: SkeletonLike): number {
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

/**
 * Check that `s` has the 22 SMPL-order joints by name, each under its SMPL parent (in any order, with
 * extra joints allowed), and return name → index. `who` names the caller in the error.
 */
export function standardJoints(s: SkeletonLike, who: string): (n: JointName) => number {
  checkSkeleton(s);
  const index = new Map(s.joints.map((n, i) => [n, i]));
  const missing = JOINT_NAMES.filter((n) => !index.has(n));
  if (missing.length) {
    throw new SkeletonFormatError('joints', `lacks ${missing.map((n) => `'${n}'`).join(', ')}: ${who} needs the 22 SMPL-order joints (${JOINT_NAMES.join(', ')})`);
  }
  JOINT_NAMES.forEach((name, j) => {
    const i = index.get(name)!;
    const want = PARENTS[j] < 0 ? undefined : JOINT_NAMES[PARENTS[j]];
    const got = s.parents[i] < 0 ? undefined : s.joints[s.parents[i]];
    if (got !== want) {
      throw new SkeletonFormatError(`parents[${i}]`, `'${name}' hangs under ${got ? `'${got}'` : 'nothing'}; ${who} needs it under ${want ? `'${want}'` : 'nothing (the root)'}`);
    }
  });
  return (n) => index.get(n)!;
}

/** Children of each joint (index lists). */
export function childrenOf(s: Pick<SkeletonLike, 'parents'>): number[][] {
  const kids: number[][] = s.parents.map(() => []);
  s.parents.forEach((p, j) => {
    if (p >= 0) kids[p].push(j);
  });
  return kids;
}
