/**
 * BVH export of a motion on the reference skeleton.
 *
 * - Hierarchy: the manifest skeleton (22 SMPL-order joints, rest T-pose offsets; the children of
 *   pelvis and spine3 at the motion's own mean offsets, see solveIK). Root OFFSET is 0 0 0 and its
 *   position channels carry the pelvis's world position, so readers that add or ignore the root offset agree.
 * - Units (`units`): metres by default — Blender's importer (scale 1.0) and three's BVHLoader take the
 *   numbers as scene units, i.e. metres, so the pelvis stands ~0.9 high — or centimetres (the older BVH
 *   habit; MotionBuilder-style tools). Lengths get 6 decimals in metres, 4 in centimetres (1 µm either
 *   way). BVH has no comment syntax both readers skip (three's BVHLoader and Blender's importer both
 *   want `HIERARCHY` first and read every later line as data), so the unit goes in the file name:
 *   `bvhFileName`.
 * - Rotations: local joint rotations from `solveIK` (twist from body planes), written as Euler
 *   angles in degrees with the rotation order declared per joint: `Zrotation Xrotation Yrotation`,
 *   i.e. R = Rz·Rx·Ry. Leaf joints (feet, head, wrists) get an `End Site` continuing their bone.
 * - Frame rate: the motion's own (20 fps), or resampled to 30/60 fps (root: linear; rotations:
 *   slerp), keeping the duration: n_out = floor((n − 1)·fps_out/fps_in) + 1.
 */
import { solveIK } from '../motion/ik';
import { type M3, type Q4, matFromQuat, slerp } from '../motion/math3';
import type { Motion } from '../motion/types';
import { childrenOf, type SkeletonLike } from '../skeleton';

/** Length unit of a BVH file: metres (the default: Blender at import scale 1.0) or centimetres. */
export type BvhUnits = 'm' | 'cm';
const UNIT: Record<BvhUnits, { scale: number; digits: number; word: string }> = {
  m: { scale: 1, digits: 6, word: 'metres' },
  cm: { scale: 100, digits: 4, word: 'centimetres' },
};

/** `stem` + the unit + `.bvh`: 'emdm-walk-seed7' → 'emdm-walk-seed7-metres.bvh' (or '-centimetres.bvh'). */
export function bvhFileName(stem: string, units: BvhUnits = 'm'): string {
  return `${stem}-${unitOf(units).word}.bvh`;
}

function unitOf(units: unknown) {
  if (units !== 'm' && units !== 'cm') throw new RangeError(`writeBVH: units must be 'm' or 'cm', got ${String(units)}`);
  return UNIT[units];
}

const DEG = 180 / Math.PI;

/** Euler angles (radians) [z, x, y] with R = Rz(z)·Rx(x)·Ry(y). */
export function eulerZXY(m: M3): [number, number, number] {
  const r21 = Math.max(-1, Math.min(1, m[7]));
  const x = Math.asin(r21);
  if (Math.abs(r21) < 0.9999999) {
    return [Math.atan2(-m[1], m[4]), x, Math.atan2(-m[6], m[8])];
  }
  return [Math.atan2(m[3], m[0]), x, 0]; // gimbal lock: put everything into z
}

function resample(rootPos: Float32Array, quats: Float32Array, frames: number, J: number, fpsIn: number, fpsOut: number) {
  if (fpsOut === fpsIn) return { rootPos, quats, frames };
  const n = Math.floor(((frames - 1) * fpsOut) / fpsIn + 1e-9) + 1;
  const rp = new Float32Array(n * 3);
  const qs = new Float32Array(n * J * 4);
  for (let i = 0; i < n; i++) {
    const tau = (i * fpsIn) / fpsOut;
    const a = Math.min(Math.floor(tau + 1e-9), frames - 1);
    const b = Math.min(a + 1, frames - 1);
    const w = Math.min(1, Math.max(0, tau - a));
    for (let c = 0; c < 3; c++) rp[i * 3 + c] = rootPos[a * 3 + c] * (1 - w) + rootPos[b * 3 + c] * w;
    for (let j = 0; j < J; j++) {
      const qa = Array.from(quats.subarray((a * J + j) * 4, (a * J + j) * 4 + 4)) as Q4;
      const qb = Array.from(quats.subarray((b * J + j) * 4, (b * J + j) * 4 + 4)) as Q4;
      qs.set(w === 0 ? qa : slerp(qa, qb, w), (i * J + j) * 4);
    }
  }
  return { rootPos: rp, quats: qs, frames: n };
}

const num = (v: number, digits: number) => {
  const s = v.toFixed(digits);
  return s === `-${(0).toFixed(digits)}` ? (0).toFixed(digits) : s;
};

export function writeBVH(motion: Motion, skeleton: SkeletonLike, opts: { fps?: 20 | 30 | 60; units?: BvhUnits } = {}): string {
  const J = skeleton.joints.length;
  const { scale, digits } = unitOf(opts.units ?? 'm');
  const fpsIn = motion.fps;
  const fpsOut = opts.fps ?? fpsIn;
  if (![20, 30, 60].includes(fpsOut)) throw new RangeError(`writeBVH: fps must be 20, 30 or 60, got ${fpsOut}`);
  if (motion.frames < 1) throw new RangeError('writeBVH: the motion has no frames');
  const ik = solveIK(motion.joints, motion.frames, skeleton);
  const { rootPos, quats, frames } = resample(ik.rootPos, ik.quats, motion.frames, J, fpsIn, fpsOut);

  const children = childrenOf(skeleton);
  const root = skeleton.parents.indexOf(-1);
  if (root < 0) throw new Error('writeBVH: skeleton has no root joint (parent −1)');

  const order: number[] = [];
  const lines: string[] = ['HIERARCHY'];
  const walk = (j: number, depth: number) => {
    order.push(j);
    const ind = '  '.repeat(depth);
    const o = j === root ? [0, 0, 0] : ik.offsets[j];
    lines.push(`${ind}${j === root ? 'ROOT' : 'JOINT'} ${skeleton.joints[j]}`, `${ind}{`);
    lines.push(`${ind}  OFFSET ${o.map((v) => num(v * scale, digits)).join(' ')}`);
    lines.push(`${ind}  CHANNELS ${j === root ? '6 Xposition Yposition Zposition ' : '3 '}Zrotation Xrotation Yrotation`);
    if (children[j].length === 0) {
      const ob = skeleton.offsets[j];
      const len = Math.hypot(ob[0], ob[1], ob[2]) || 1;
      const end = ob.map((v) => (v / len) * 0.05 * scale); // 5 cm along the bone
      lines.push(`${ind}  End Site`, `${ind}  {`, `${ind}    OFFSET ${end.map((v) => num(v, digits)).join(' ')}`, `${ind}  }`);
    }
    for (const c of children[j]) walk(c, depth + 1);
    lines.push(`${ind}}`);
  };
  walk(root, 0);

  lines.push('MOTION', `Frames: ${frames}`, `Frame Time: ${(1 / fpsOut).toFixed(7)}`);
  for (let f = 0; f < frames; f++) {
    const vals: string[] = [];
    for (const j of order) {
      if (j === root) for (let c = 0; c < 3; c++) vals.push(num(rootPos[f * 3 + c] * scale, digits));
      const [z, x, y] = eulerZXY(matFromQuat(quats, (f * J + j) * 4));
      vals.push(num(z * DEG, 4), num(x * DEG, 4), num(y * DEG, 4));
    }
    lines.push(vals.join(' '));
  }
  return lines.join('\n') + '\n';
}
