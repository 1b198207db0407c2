// The character's body, built in code around the reference skeleton's rest pose: one tapered capsule
// per body part (hips, belly, chest, neck, head, collars, arms, hands, legs, feet), each driven by one
// joint and blended smoothly into its neighbours across the joints (skin weights fall off with a
// smoothstep over a band around the joint), merged into ONE indexed geometry with position, normal,
// color, skinIndex and skinWeight attributes. Pure geometry: no scene, no renderer.
import { BufferAttribute, BufferGeometry, Vector3 } from 'three';
import { type JointName, type SkeletonLike, standardJoints } from '../skeleton';
import { restPositions } from './rig';

/** A body part: a capsule from a to b (rest world coordinates) with an elliptic cross-section. */
export interface BodyPart {
  name: string;
  a: Vector3;                // axis start
  b: Vector3;                // axis end
  r0: number;                // radius at a
  r1: number;                // radius at b
  /** optional radius profile: (t along a→b in 0..1, radius) control points, linear in between */
  profile?: Array<[number, number]>;
  side: Vector3;             // first cross-section axis (made orthogonal to the axis)
  sx: number;                // cross-section scale along `side`
  sz: number;                // cross-section scale across (axis × side)
  /** joints whose rotations move the part, in order along the axis: bones[0] up to joints[0], ... */
  bones: number[];
  /** where each next bone takes over (bones.length − 1 points, projected onto the axis) */
  joints: Vector3[];
  blend: number;             // half-width of the blend band around each joint, metres
  color: number;             // sRGB hex
}

const SHIRT = 0x3f6fd8;
const PANTS = 0x2b3242;
const SKIN = 0xe3c4a8;
const SHOE = 0xf1f1ee;
const EYES = 0x1a2030;
/** Forward pitch of the head geometry about the neck joint, radians (see bodyParts). */
export const HEAD_PITCH = (20 * Math.PI) / 180;

/** The body parts for a skeleton with the 22 SMPL-order joints by name (any order). */
export function bodyParts(s: SkeletonLike): BodyPart[] {
  const J = standardJoints(s, 'the character');
  const rest = restPositions(s);
  const P = (n: JointName): Vector3 => rest[J(n)].clone();
  const X = new Vector3(1, 0, 0);
  const Y = new Vector3(0, 1, 0);
  const Z = new Vector3(0, 0, 1);
  const parts: BodyPart[] = [];
  const add = (p: Omit<BodyPart, 'blend'> & { blend?: number }) => parts.push({ blend: 0.05, ...p });
  const limb = (parent: number, self: number, child: number | null, a: Vector3, b: Vector3) =>
    child === null ? { bones: [parent, self], joints: [a] } : { bones: [parent, self, child], joints: [a, b] };

  // Hips: across the hip joints, blending into each thigh.
  add({ name: 'hips', a: P('r_hip'), b: P('l_hip'), r0: 0.105, r1: 0.105, side: Z, sx: 0.86, sz: 1.0,
    bones: [J('r_hip'), J('pelvis'), J('l_hip')], joints: [P('r_hip'), P('l_hip')], blend: 0.035, color: PANTS });
  // Trunk: one smooth capsule from the pelvis to the base of the neck, bending at each spine joint.
  const trunkTop = P('neck').add(new Vector3(0, -0.075, 0));
  add({ name: 'trunk', a: P('pelvis').add(new Vector3(0, -0.03, 0)), b: trunkTop, r0: 0.12, r1: 0.11,
    profile: [[0, 0.12], [0.3, 0.112], [0.55, 0.118], [0.8, 0.13], [1, 0.112]],
    side: X, sx: 1.22, sz: 0.78, bones: [J('pelvis'), J('spine1'), J('spine2'), J('spine3')],
    joints: [P('spine1'), P('spine2'), P('spine3')], blend: 0.05, color: SHIRT });
  add({ name: 'neck', a: P('neck').add(new Vector3(0, -0.03, 0)), b: P('head'), r0: 0.05, r1: 0.045, side: X, sx: 1, sz: 1,
    bones: [J('spine3'), J('neck'), J('head')], joints: [P('neck'), P('head')], blend: 0.025, color: SKIN });
  // The head is modelled pitched forward by HEAD_PITCH about the neck joint. The training data place
  // the head joint 10–20° further back than the reference offset (neck→head leans 9° forward in the
  // Bandai clips, 12° HDM05, 19° CMU, vs 33° in the reference skeleton), so IK tilts the neck back by
  // about that much in every generated motion; with this pitch the face looks level in them.
  const pivot = P('neck');
  const pitch = (v: Vector3) => v.sub(pivot).applyAxisAngle(X, HEAD_PITCH).add(pivot);
  const skull = P('head');
  add({ name: 'head', a: pitch(skull.clone().add(new Vector3(0, 0.045, 0.005))), b: pitch(skull.clone().add(new Vector3(0, 0.115, -0.005))),
    r0: 0.095, r1: 0.095, side: X, sx: 0.86, sz: 1.05, bones: [J('head')], joints: [], color: SKIN });
  for (const sx of [-1, 1]) {
    add({ name: sx < 0 ? 'r-eye' : 'l-eye', a: pitch(skull.clone().add(new Vector3(0.034 * sx, 0.088, 0.083))),
      b: pitch(skull.clone().add(new Vector3(0.034 * sx, 0.07, 0.083))), r0: 0.013, r1: 0.013, side: X, sx: 1, sz: 0.6,
      bones: [J('head')], joints: [], color: EYES });
  }

  for (const side of ['l', 'r'] as const) {
    const n = (base: string) => `${side}_${base}` as JointName;
    const sgn = side === 'l' ? 1 : -1;
    add({ name: `${side}-collar`, a: P(n('collar')).add(new Vector3(-0.04 * sgn, -0.02, 0)), b: P(n('shoulder')),
      r0: 0.065, r1: 0.06, side: Z, sx: 0.9, sz: 0.95,
      ...limb(J('spine3'), J(n('collar')), J(n('shoulder')), P(n('collar')), P(n('shoulder'))), blend: 0.04, color: SHIRT });
    add({ name: `${side}-upper-arm`, a: P(n('shoulder')), b: P(n('elbow')), r0: 0.056, r1: 0.043, side: Z, sx: 1, sz: 1,
      ...limb(J(n('collar')), J(n('shoulder')), J(n('elbow')), P(n('shoulder')), P(n('elbow'))), blend: 0.045, color: SHIRT });
    add({ name: `${side}-forearm`, a: P(n('elbow')), b: P(n('wrist')), r0: 0.042, r1: 0.031, side: Z, sx: 1.05, sz: 0.9,
      ...limb(J(n('shoulder')), J(n('elbow')), J(n('wrist')), P(n('elbow')), P(n('wrist'))), blend: 0.04, color: SKIN });
    const armDir = P(n('wrist')).sub(P(n('elbow'))).normalize();
    add({ name: `${side}-hand`, a: P(n('wrist')).addScaledVector(armDir, 0.035), b: P(n('wrist')).addScaledVector(armDir, 0.13),
      r0: 0.038, r1: 0.034, side: Z, sx: 1.15, sz: 0.5, ...limb(J(n('elbow')), J(n('wrist')), null, P(n('wrist')), P(n('wrist'))),
      blend: 0.025, color: SKIN });
    add({ name: `${side}-thigh`, a: P(n('hip')), b: P(n('knee')), r0: 0.085, r1: 0.058, side: X, sx: 1, sz: 1.05,
      ...limb(J('pelvis'), J(n('hip')), J(n('knee')), P(n('hip')), P(n('knee'))), blend: 0.05, color: PANTS });
    add({ name: `${side}-shin`, a: P(n('knee')), b: P(n('ankle')), r0: 0.056, r1: 0.04, side: X, sx: 1, sz: 1.05,
      ...limb(J(n('hip')), J(n('knee')), J(n('ankle')), P(n('knee')), P(n('ankle'))), blend: 0.045, color: PANTS });
    const ankle = P(n('ankle'));
    const ball = P(n('foot'));
    add({ name: `${side}-foot`, a: new Vector3(ankle.x, 0.047, ankle.z - 0.05), b: new Vector3(ball.x, 0.032, ball.z + 0.055),
      r0: 0.046, r1: 0.036, side: X, sx: 1.0, sz: 0.72, ...limb(J(n('knee')), J(n('ankle')), J(n('foot')), ankle, ball),
      blend: 0.03, color: SHOE });
  }
  return parts;
}

function smoothstep(e0: number, e1: number, x: number): number {
  const t = Math.min(1, Math.max(0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
}

/**
 * Skin weights of a point at coordinate u along a part's axis, given where each next bone takes over
 * (`at`, increasing, one fewer than bones): bone i weighs S_i(u) − S_{i+1}(u), where S_i rises from 0 to
 * 1 by a smoothstep over ±h around at[i−1] (S_0 = 1, S_n+1 = 0). The weights are ≥ 0, sum to 1, equal
 * 0.5/0.5 at each joint and are exactly one bone's away from the joints. Returns (bone, weight) pairs
 * with positive weights.
 */
export function chainWeights(bones: number[], at: number[], blend: number, u: number): Array<[number, number]> {
  if (at.length !== bones.length - 1) throw new Error(`chainWeights: ${bones.length} bones need ${bones.length - 1} joints, got ${at.length}`);
  const S = (i: number): number => {
    if (i <= 0) return 1;
    if (i > at.length) return 0;
    const gapL = i > 1 ? at[i - 1] - at[i - 2] : Infinity;
    const gapR = i < at.length ? at[i] - at[i - 1] : Infinity;
    const h = Math.max(1e-4, Math.min(blend, gapL / 2, gapR / 2));
    return smoothstep(at[i - 1] - h, at[i - 1] + h, u);
  };
  const out: Array<[number, number]> = [];
  for (let i = 0; i < bones.length; i++) {
    const w = S(i) - S(i + 1);
    if (w > 1e-6) out.push([bones[i], w]);
  }
  const sum = out.reduce((acc, [, w]) => acc + w, 0);
  return out.map(([b, w]) => [b, w / sum]);
}

/** Radius of a part at t ∈ [0, 1] along its axis. */
export function partRadius(part: BodyPart, t: number): number {
  const p = part.profile;
  if (!p || p.length === 0) return part.r0 + (part.r1 - part.r0) * t;
  if (t <= p[0][0]) return p[0][1];
  for (let i = 1; i < p.length; i++) {
    if (t <= p[i][0]) {
      const [t0, r0] = p[i - 1];
      const [t1, r1] = p[i];
      return r0 + ((r1 - r0) * (t - t0)) / (t1 - t0);
    }
  }
  return p[p.length - 1][1];
}

export interface BodyGeometryOptions {
  radial?: number;       // vertices around each ring
  capRings?: number;     // rings per hemispherical cap
  ringSpacing?: number;  // metres between rings along the axis
}

/** One indexed BufferGeometry for all parts, with skinIndex/skinWeight (4 influences) and colours. */
export function buildBodyGeometry(s: SkeletonLike, parts: BodyPart[] = bodyParts(s), opts: BodyGeometryOptions = {}): BufferGeometry {
  const radial = opts.radial ?? 20;
  const capRings = opts.capRings ?? 6;
  const spacing = opts.ringSpacing ?? 0.025;
  const pos: number[] = [];
  const col: number[] = [];
  const skinIndex: number[] = [];
  const skinWeight: number[] = [];
  const index: number[] = [];
  const c = { r: 0, g: 0, b: 0 };

  for (const part of parts) {
    const axis = part.b.clone().sub(part.a);
    const L = axis.length();
    if (!(L > 1e-6)) throw new Error(`body part '${part.name}': its two ends coincide`);
    const dir = axis.clone().divideScalar(L);
    const side = part.side.clone().addScaledVector(dir, -part.side.dot(dir));
    if (side.lengthSq() < 1e-8) throw new Error(`body part '${part.name}': side vector is parallel to its axis`);
    side.normalize();
    const across = new Vector3().crossVectors(dir, side);
    const at = part.joints.map((j) => j.clone().sub(part.a).dot(dir));
    const r0 = partRadius(part, 0);
    const r1 = partRadius(part, 1);
    hexToLinear(part.color, c);

    // Rings: (axial u, radius) from the start pole to the end pole.
    const rings: Array<[number, number]> = [];
    for (let i = 1; i < capRings; i++) {
      const phi = -Math.PI / 2 + (i / capRings) * (Math.PI / 2);
      rings.push([r0 * Math.sin(phi), r0 * Math.cos(phi)]);
    }
    const bodyRings = Math.max(2, Math.ceil(L / spacing));
    for (let i = 0; i <= bodyRings; i++) {
      const t = i / bodyRings;
      rings.push([t * L, partRadius(part, t)]);
    }
    for (let i = 1; i < capRings; i++) {
      const phi = (i / capRings) * (Math.PI / 2);
      rings.push([L + r1 * Math.sin(phi), r1 * Math.cos(phi)]);
    }

    const base = pos.length / 3;
    const emit = (u: number, x: number, z: number) => {
      const p = part.a.clone().addScaledVector(dir, u).addScaledVector(side, x * part.sx).addScaledVector(across, z * part.sz);
      pos.push(p.x, p.y, p.z);
      col.push(c.r, c.g, c.b);
      const w = chainWeights(part.bones, at, part.blend, u);
      for (let k = 0; k < 4; k++) {
        skinIndex.push(k < w.length ? w[k][0] : 0);
        skinWeight.push(k < w.length ? w[k][1] : 0);
      }
    };
    emit(-r0, 0, 0); // start pole
    for (const [u, r] of rings) {
      for (let k = 0; k < radial; k++) {
        const th = (k / radial) * Math.PI * 2;
        emit(u, r * Math.cos(th), r * Math.sin(th));
      }
    }
    emit(L + r1, 0, 0); // end pole
    const ring0 = base + 1;
    const endPole = base + 1 + rings.length * radial;
    for (let k = 0; k < radial; k++) {
      const k1 = (k + 1) % radial;
      index.push(base, ring0 + k1, ring0 + k);
    }
    for (let i = 0; i + 1 < rings.length; i++) {
      const r0 = ring0 + i * radial;
      const r1 = r0 + radial;
      for (let k = 0; k < radial; k++) {
        const k1 = (k + 1) % radial;
        index.push(r0 + k, r0 + k1, r1 + k, r0 + k1, r1 + k1, r1 + k);
      }
    }
    const last = ring0 + (rings.length - 1) * radial;
    for (let k = 0; k < radial; k++) {
      const k1 = (k + 1) % radial;
      index.push(endPole, last + k, last + k1);
    }
  }

  const g = new BufferGeometry();
  g.setAttribute('position', new BufferAttribute(new Float32Array(pos), 3));
  g.setAttribute('color', new BufferAttribute(new Float32Array(col), 3));
  g.setAttribute('skinIndex', new BufferAttribute(new Uint16Array(skinIndex), 4));
  g.setAttribute('skinWeight', new BufferAttribute(new Float32Array(skinWeight), 4));
  g.setIndex(index);
  g.computeVertexNormals();
  g.computeBoundingBox();
  g.computeBoundingSphere();
  return g;
}

/** sRGB hex → linear RGB (three.js's working colour space; vertex colours are linear). */
function hexToLinear(hex: number, out: { r: number; g: number; b: number }): void {
  const f = (v: number) => {
    const x = v / 255;
    return x <= 0.04045 ? x / 12.92 : Math.pow((x + 0.055) / 1.055, 2.4);
  };
  out.r = f((hex >> 16) & 255);
  out.g = f((hex >> 8) & 255);
  out.b = f(hex & 255);
}
