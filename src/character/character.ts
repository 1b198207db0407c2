// The skinned humanoid: the reference skeleton's bones + the body geometry in ONE SkinnedMesh, bound in
// the rest T-pose. Poses are applied with applyPose (root translation + local joint quaternions).
import { Group, MeshStandardMaterial, Skeleton, SkinnedMesh, type Bone } from 'three';
import { buildBodyGeometry } from './body';
import { checkSkeleton, type SkeletonLike } from '../skeleton';
import { buildBones } from './rig';

export interface Character {
  /** Add this to the scene. */
  object: Group;
  mesh: SkinnedMesh;
  bones: Bone[];
  skeleton: Skeleton;
  dispose(): void;
}

export function createCharacter(s: SkeletonLike): Character {
  checkSkeleton(s);
  const bones = buildBones(s);
  const geometry = buildBodyGeometry(s);
  const material = new MeshStandardMaterial({ vertexColors: true, roughness: 0.55, metalness: 0.0 });
  const mesh = new SkinnedMesh(geometry, material);
  mesh.name = 'character';
  mesh.castShadow = true;
  mesh.receiveShadow = true;
  // Skinned vertices move far from the bind-pose bounds when the root travels: never cull.
  mesh.frustumCulled = false;
  const object = new Group();
  object.name = 'emdm-character';
  object.add(bones[0]);
  object.add(mesh);
  object.updateMatrixWorld(true);
  const skeleton = new Skeleton(bones);
  mesh.bind(skeleton);
  return {
    object,
    mesh,
    bones,
    skeleton,
    dispose() {
      geometry.dispose();
      material.dispose();
      skeleton.dispose();
    },
  };
}

/**
 * Put the bones (but the root) at the rest offsets a pose's rotations go with: solveIK's `offsets`, carried by a
 * motion's pose and its pose track (the motion's own hip and shoulder spacing and bone lengths, joints × 3), or the
 * skeleton's reference offsets when none are given. Rotations solved for one set of offsets misplace the joints on
 * bones at another: the shipped text model's walks, posed on the reference offsets, stood 5 cm into the floor.
 */
export function placeBones(bones: Bone[], skeleton: SkeletonLike, offsets?: ArrayLike<number>): void {
  if (offsets && offsets.length !== bones.length * 3) {
    throw new RangeError(`placeBones: offsets has ${offsets.length} numbers, expected joints (${bones.length}) × 3`);
  }
  for (let j = 1; j < bones.length; j++) {
    if (offsets) bones[j].position.set(offsets[j * 3], offsets[j * 3 + 1], offsets[j * 3 + 2]);
    else bones[j].position.fromArray(skeleton.offsets[j]);
  }
}

/**
 * Pose the bones: root = pelvis world position (3 numbers at rootOffset), quats = local rotations,
 * xyzw, 4 numbers per joint starting at quatOffset.
 */
export function applyPose(bones: Bone[], root: ArrayLike<number>, quats: ArrayLike<number>, rootOffset = 0, quatOffset = 0): void {
  bones[0].position.set(root[rootOffset], root[rootOffset + 1], root[rootOffset + 2]);
  for (let j = 0; j < bones.length; j++) {
    const q = quatOffset + j * 4;
    bones[j].quaternion.set(quats[q], quats[q + 1], quats[q + 2], quats[q + 3]);
  }
}
