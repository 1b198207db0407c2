/** Small float64 3-D helpers: vectors [x,y,z], row-major 3×3 matrices (9 numbers), quaternions [x,y,z,w]. */
export type V3 = [number, number, number];
export type M3 = number[]; // length 9, row-major
export type Q4 = [number, number, number, number];

export const sub = (a: V3, b: V3): V3 => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
export const add = (a: V3, b: V3): V3 => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
export const scale = (a: V3, s: number): V3 => [a[0] * s, a[1] * s, a[2] * s];
export const dot = (a: V3, b: V3): number => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
export const cross = (a: V3, b: V3): V3 => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
export const norm = (a: V3): number => Math.hypot(a[0], a[1], a[2]);
export function normalize(a: V3, fallback: V3 = [0, 1, 0]): V3 {
  const n = norm(a);
  return n > 1e-12 ? [a[0] / n, a[1] / n, a[2] / n] : [...fallback];
}

export const IDENTITY: M3 = [1, 0, 0, 0, 1, 0, 0, 0, 1];

export function mulMM(a: M3, b: M3): M3 {
  const o = new Array<number>(9);
  for (let r = 0; r < 3; r++)
    for (let c = 0; c < 3; c++) o[3 * r + c] = a[3 * r] * b[c] + a[3 * r + 1] * b[3 + c] + a[3 * r + 2] * b[6 + c];
  return o;
}
/** aᵀ·b */
export function mulTM(a: M3, b: M3): M3 {
  const o = new Array<number>(9);
  for (let r = 0; r < 3; r++)
    for (let c = 0; c < 3; c++) o[3 * r + c] = a[r] * b[c] + a[3 + r] * b[3 + c] + a[6 + r] * b[6 + c];
  return o;
}
export const mulMV = (m: M3, v: V3): V3 => [
  m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
  m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
  m[6] * v[0] + m[7] * v[1] + m[8] * v[2],
];
/** mᵀ·v */
export const mulTV = (m: M3, v: V3): V3 => [
  m[0] * v[0] + m[3] * v[1] + m[6] * v[2],
  m[1] * v[0] + m[4] * v[1] + m[7] * v[2],
  m[2] * v[0] + m[5] * v[1] + m[8] * v[2],
];

/**
 * Orthonormal frame [e1 e2 e3] (as matrix columns) from a primary direction (exact) and a
 * secondary direction (only its part orthogonal to the primary is used). When the secondary is
 * (nearly) parallel to the primary, `spare` is used instead.
 */
export function frame(primary: V3, secondary: V3, spare: V3 = [0, 0, 1]): M3 {
  const e1 = normalize(primary);
  let s = sub(secondary, scale(e1, dot(secondary, e1)));
  if (norm(s) < 1e-6 * Math.max(1, norm(secondary))) {
    s = sub(spare, scale(e1, dot(spare, e1)));
    if (norm(s) < 1e-6) s = sub([1, 0, 0], scale(e1, e1[0]));
  }
  const e2 = normalize(s);
  const e3 = cross(e1, e2);
  return [e1[0], e2[0], e3[0], e1[1], e2[1], e3[1], e1[2], e2[2], e3[2]];
}

/** The rotation taking the rest frame (primary0, secondary0) onto (primary, secondary): F·F0ᵀ. */
export function alignFrames(primary0: V3, secondary0: V3, primary: V3, secondary: V3, spare?: V3): M3 {
  const f0 = frame(primary0, secondary0);
  const f = frame(primary, secondary, spare);
  // f · f0ᵀ
  const o = new Array<number>(9);
  for (let r = 0; r < 3; r++)
    for (let c = 0; c < 3; c++) o[3 * r + c] = f[3 * r] * f0[3 * c] + f[3 * r + 1] * f0[3 * c + 1] + f[3 * r + 2] * f0[3 * c + 2];
  return o;
}

/** Unit quaternion [x,y,z,w] of a rotation matrix (Shepperd's method). */
export function quatFromMat(m: M3): Q4 {
  const [m00, m01, m02, m10, m11, m12, m20, m21, m22] = m;
  const tr = m00 + m11 + m22;
  let q: Q4;
  if (tr > 0) {
    const s = Math.sqrt(tr + 1) * 2;
    q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s];
  } else if (m00 > m11 && m00 > m22) {
    const s = Math.sqrt(1 + m00 - m11 - m22) * 2;
    q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s];
  } else if (m11 > m22) {
    const s = Math.sqrt(1 + m11 - m00 - m22) * 2;
    q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s];
  } else {
    const s = Math.sqrt(1 + m22 - m00 - m11) * 2;
    q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s];
  }
  const n = Math.hypot(q[0], q[1], q[2], q[3]);
  return [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
}

export function matFromQuat(q: ArrayLike<number>, o = 0): M3 {
  const x = q[o], y = q[o + 1], z = q[o + 2], w = q[o + 3];
  return [
    1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
    2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
    2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
  ];
}

/** Spherical interpolation between unit quaternions a and b (shortest arc). */
export function slerp(a: Q4, b: Q4, t: number): Q4 {
  let [bx, by, bz, bw] = b;
  let d = a[0] * bx + a[1] * by + a[2] * bz + a[3] * bw;
  if (d < 0) {
    d = -d;
    bx = -bx; by = -by; bz = -bz; bw = -bw;
  }
  let wa: number;
  let wb: number;
  if (d > 0.9995) {
    wa = 1 - t;
    wb = t;
  } else {
    const th = Math.acos(d);
    const s = Math.sin(th);
    wa = Math.sin((1 - t) * th) / s;
    wb = Math.sin(t * th) / s;
  }
  const q: Q4 = [wa * a[0] + wb * bx, wa * a[1] + wb * by, wa * a[2] + wb * bz, wa * a[3] + wb * bw];
  const n = Math.hypot(q[0], q[1], q[2], q[3]);
  return [q[0] / n, q[1] / n, q[2] / n, q[3] / n];
}

/**
 * Two-bone IK: the middle joint for a root `a` reaching `target` with bone lengths l1, l2, bending
 * towards the pole `pole` (e.g. the observed knee). When the target is out of reach (too far or
 * too near) the chain reaches as far as it can along the same direction; `end` is where it ends.
 */
export function twoBoneIK(a: V3, target: V3, pole: V3, l1: number, l2: number): { knee: V3; ankle: V3 } {
  const v = sub(target, a);
  const d0 = norm(v);
  const dir = normalize(v, [0, -1, 0]);
  const d = Math.min(Math.max(d0, Math.abs(l1 - l2), 1e-9), l1 + l2); // out of reach: straight
  const x = (l1 * l1 - l2 * l2 + d * d) / (2 * d);
  const h = Math.sqrt(Math.max(0, l1 * l1 - x * x));
  const kp = sub(pole, a);
  let side = sub(kp, scale(dir, dot(kp, dir)));
  if (norm(side) < 1e-9) side = Math.abs(dir[2]) < 0.9 ? [0, 0, 1] : [1, 0, 0];
  side = sub(side, scale(dir, dot(side, dir)));
  const knee = add(add(a, scale(dir, x)), scale(normalize(side), h));
  return { knee, ankle: add(a, scale(dir, d)) };
}
