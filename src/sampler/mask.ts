/**
 * Which parts of a motion the sampler keeps (docs/ARCHITECTURE.md "Sampling with constraints"): frame
 * ranges × feature groups → a frames × 263 mask of 0/1, the `keep` of `sample()` / `generate()`.
 * Python twin: `emdm.motion.mask` (the `tiny-mask` parity fixture holds its group channels and mask).
 *
 * ```ts
 * // keep the first second and, on every frame, the legs (in-betweening of the legs, say)
 * const keep = keepMask(120, [{ frames: [[0, 19]] }, { groups: ['legs'] }]);
 * const same = keepMask(120, [parseKeep('frames:0-19'), parseKeep('group:legs')]);
 * ```
 *
 * Groups (channels of the 263-d layout; joint j = 1..21 owns its position [4+3(j−1), +3) and 6D rotation
 * [67+6(j−1), +6), every joint j = 0..21 its velocity [193+3j, +3)):
 * - `root`: [0:4] (angular velocity, xz velocity, height) and the pelvis velocity [193:196];
 * - `legs`: hips, knees, ankles, feet and the foot contacts [259:263];
 * - `upper`: spine1..3, neck, head, collars, shoulders, elbows, wrists.
 * They are disjoint and cover all 263 channels.
 */
import { JOINT_NAMES, type JointName } from '../skeleton';

export const FEATURE_GROUPS = ['root', 'legs', 'upper'] as const;
export type FeatureGroup = (typeof FEATURE_GROUPS)[number];

export const GROUP_JOINTS: Readonly<Record<FeatureGroup, readonly JointName[]>> = {
  root: ['pelvis'],
  legs: ['l_hip', 'r_hip', 'l_knee', 'r_knee', 'l_ankle', 'r_ankle', 'l_foot', 'r_foot'],
  upper: ['spine1', 'spine2', 'spine3', 'neck', 'head', 'l_collar', 'r_collar', 'l_shoulder', 'r_shoulder', 'l_elbow', 'r_elbow', 'l_wrist', 'r_wrist'],
};

/**
 * A motion to keep part of (generate()'s and createGenerator's `known`): its de-normalised `features`
 * (frames × 263, like `Motion.features`), the 0/1 `keep` mask (`keepMask`), and optionally `fromTime`, the
 * sampler's `keepFromTime` (the kept part imposed at the steps with t ≤ it and at the last; default 1: every step).
 */
export interface KnownMotion {
  features: Float32Array;
  keep: Float32Array;
  fromTime?: number;
}

const DIM = 263;

/** A rectangle to keep: inclusive [start, end] frame ranges (end `null` = the last frame; absent = every
 * frame) × feature groups (absent = every group). */
export interface KeepRect {
  frames?: [number, number | null][];
  groups?: FeatureGroup[];
}

export class KeepSpecError extends Error {
  constructor(message: string) {
    super(message);
    this.name = 'KeepSpecError';
  }
}

const range = (a: number, n: number) => Array.from({ length: n }, (_, i) => a + i);

/** The channels of one joint (0 = pelvis: [0:4] and its velocity). */
export function jointChannels(joint: number): number[] {
  if (!Number.isInteger(joint) || joint < 0 || joint >= JOINT_NAMES.length) throw new KeepSpecError(`joint index ${joint} outside 0…${JOINT_NAMES.length - 1}`);
  const vel = range(193 + 3 * joint, 3);
  if (joint === 0) return [0, 1, 2, 3, ...vel];
  return [...range(4 + 3 * (joint - 1), 3), ...range(67 + 6 * (joint - 1), 6), ...vel];
}

/** Sorted channel indices of a feature group. */
export function groupChannels(group: FeatureGroup): number[] {
  const joints = GROUP_JOINTS[group];
  if (!joints) throw new KeepSpecError(`unknown feature group ${JSON.stringify(group)}; groups: ${FEATURE_GROUPS.join(', ')}`);
  const ch = joints.flatMap((n) => jointChannels(JOINT_NAMES.indexOf(n)));
  if (group === 'legs') ch.push(259, 260, 261, 262);
  return ch.sort((a, b) => a - b);
}

/** frames × 263 Float32Array, 1 where some rectangle keeps the channel; a range past the motion throws. */
export function keepMask(frames: number, rects: readonly KeepRect[]): Float32Array {
  if (!Number.isInteger(frames) || frames < 1) throw new KeepSpecError(`keepMask: frames must be a positive integer, got ${frames}`);
  const mask = new Float32Array(frames * DIM);
  for (const r of rects) {
    const rows = new Uint8Array(frames);
    for (const [a, b] of r.frames ?? [[0, null]]) {
      if (!Number.isInteger(a) || a < 0 || (b !== null && (!Number.isInteger(b) || b < a))) {
        throw new KeepSpecError(`keepMask: frame range [${a}, ${b}] must be integers with 0 ≤ start ≤ end (end null: the last frame)`);
      }
      const end = b ?? frames - 1;
      if (a >= frames || end >= frames) throw new KeepSpecError(`keep: frame range ${fmtRange(a, b)} goes past the motion's last frame ${frames - 1}`);
      rows.fill(1, a, end + 1);
    }
    const cols = (r.groups ?? FEATURE_GROUPS).flatMap((g) => groupChannels(g));
    for (let f = 0; f < frames; f++) {
      if (!rows[f]) continue;
      for (const c of cols) mask[f * DIM + c] = 1;
    }
  }
  return mask;
}

const fmtRange = (a: number, b: number | null) => (b === a ? `${a}` : `${a}-${b ?? ''}`);

/** `"frames:0-19/group:legs"` → KeepRect (the grammar of `python -m emdm.sample --keep`): parts `frames:RANGES`
 * (comma-separated `A-B` inclusive, `A`, `A-`) and `group:NAMES` (comma-separated), joined by `/`. */
export function parseKeep(spec: string): KeepRect {
  if (typeof spec !== 'string' || !spec.trim()) throw new KeepSpecError('keep spec is empty; use e.g. frames:0-19, group:legs or frames:0-19/group:legs');
  const out: KeepRect = {};
  for (const part of spec.trim().split('/')) {
    const i = part.indexOf(':');
    const kind = i < 0 ? '' : part.slice(0, i).trim();
    if (kind !== 'frames' && kind !== 'group') {
      throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: part ${JSON.stringify(part)} must be frames:RANGES or group:NAMES (e.g. frames:0-19/group:legs)`);
    }
    const items = part.slice(i + 1).split(',').map((s) => s.trim());
    if (items.some((s) => !s)) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: ${kind}: has an empty entry`);
    if (kind === 'frames') {
      if (out.frames) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: frames: given twice (list ranges with commas: frames:0-9,50-59)`);
      out.frames = items.map((item) => {
        const m = /^(\d+)(?:(-)(\d*))?$/.exec(item);
        if (!m) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: frame range ${JSON.stringify(item)} must be A-B (inclusive), A or A-`);
        const a = Number(m[1]);
        const b = !m[2] ? a : m[3] ? Number(m[3]) : null;
        if (b !== null && b < a) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: frame range ${JSON.stringify(item)} ends before it starts`);
        return [a, b] as [number, number | null];
      });
    } else {
      if (out.groups) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: group: given twice (list groups with commas: group:root,legs)`);
      for (const g of items) {
        if (!(FEATURE_GROUPS as readonly string[]).includes(g)) throw new KeepSpecError(`keep spec ${JSON.stringify(spec)}: unknown group ${JSON.stringify(g)}; groups: ${FEATURE_GROUPS.join(', ')}`);
      }
      out.groups = items as FeatureGroup[];
    }
  }
  return out;
}
