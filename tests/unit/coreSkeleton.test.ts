// The skeleton module (src/skeleton.ts) against the manifest emdm.manifest writes from emdm.skeleton.
import { describe, expect, it } from 'vitest';
import { bodyParts } from '../../src/character/body';
import { solveIK } from '../../src/motion/ik';
import {
  FOOT_JOINT_NAMES, JOINT_NAMES, KINEMATIC_CHAINS, PARENTS, SkeletonFormatError, checkSkeleton, childrenOf, standardJoints,
} from '../../src/skeleton';
import { manifestSkeleton } from './coreFixtures';

const sk = manifestSkeleton() as ReturnType<typeof manifestSkeleton> & { chains: number[][] };

describe('skeleton module', () => {
  it('names, parents, chains and foot joints equal the manifest written from emdm.skeleton', () => {
    expect(sk.joints).toEqual([...JOINT_NAMES]);
    expect(sk.parents).toEqual([...PARENTS]);
    expect(sk.chains).toEqual(KINEMATIC_CHAINS.map((c) => [...c]));
    expect(sk.footJoints.map((j) => sk.joints[j])).toEqual([...FOOT_JOINT_NAMES]);
    expect(checkSkeleton(sk)).toBe(22);
    for (const chain of KINEMATIC_CHAINS) for (let i = 1; i < chain.length; i++) expect(PARENTS[chain[i]]).toBe(chain[i - 1]);
  });

  it('checkSkeleton names the bad field', () => {
    expect(() => checkSkeleton({ ...sk, parents: sk.parents.slice(1) })).toThrow(/manifest skeleton\.parents: expected 22 entries/);
    expect(() => checkSkeleton({ ...sk, parents: [-1, 2, ...sk.parents.slice(2)] })).toThrow(/skeleton\.parents\[1\]: 2 is not an earlier joint/);
    const offsets = sk.offsets.map((o) => [...o]);
    offsets[5][1] = Number.NaN;
    expect(() => checkSkeleton({ ...sk, offsets })).toThrow(SkeletonFormatError);
    expect(() => checkSkeleton({ ...sk, offsets })).toThrow(/skeleton\.offsets\[5\]: expected three finite numbers/);
  });

  it('standardJoints finds the joints by name in any order and refuses a missing or re-parented one', () => {
    // the same rig with the two legs' joints listed in another order
    const order = [0, 2, 1, 3, 5, 4, ...Array.from({ length: 16 }, (_, i) => i + 6)];
    const inv = order.map((_, i) => order.indexOf(i));
    const shuffled = { joints: order.map((j) => sk.joints[j]), parents: order.map((j) => (sk.parents[j] < 0 ? -1 : inv[sk.parents[j]])), offsets: order.map((j) => sk.offsets[j]) };
    const I = standardJoints(shuffled, 'test');
    expect(I('l_hip')).toBe(2);
    expect(I('r_knee')).toBe(4);
    const renamed = { ...sk, joints: sk.joints.map((n) => (n === 'l_elbow' ? 'left_elbow' : n)) };
    expect(() => solveIK(new Float32Array(22 * 3), 1, renamed)).toThrow(/skeleton\.joints: lacks 'l_elbow': solveIK needs the 22 SMPL-order joints/);
    expect(() => bodyParts(renamed)).toThrow(/lacks 'l_elbow': the character needs/);
    const reparented = { ...sk, parents: sk.parents.map((p, j) => (j === 20 ? 16 : p)) }; // l_wrist under l_shoulder
    expect(() => standardJoints(reparented, 'the character')).toThrow(/skeleton\.parents\[20\]: 'l_wrist' hangs under 'l_shoulder'; the character needs it under 'l_elbow'/);
  });

  it('childrenOf lists each joint\'s children', () => {
    const kids = childrenOf(sk);
    expect(kids[0]).toEqual([1, 2, 3]);
    expect(kids[9]).toEqual([12, 13, 14]);
    expect(kids.flatMap((k, j) => (k.length ? [] : [sk.joints[j]]))).toEqual(['l_foot', 'r_foot', 'head', 'l_wrist', 'r_wrist']);
  });
});
