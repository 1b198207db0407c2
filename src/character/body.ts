// The character's body, built in code around the reference skeleton's rest pose: one tapered capsule
// per body part (hips, belly, chest, neck, head, collars, arms, hands, legs, feet), each driven by one
// joint and blended smoothly into its neighbours across the joints (skin weights fall off with a
// smoothstep over a band around the joint), merged into ONE indexed geometry with position, normal,
// color, skinIndex and skinWeight attributes. Pure geometry: no scene, no renderer.
import { BufferAttribute, BufferGeometry, Vector3 } from 'three';
import { checkSkeleton, restPositions, type RigSkeleton } from './rig';

/** A body part: a capsule from a to b (rest world coordinates) with an elliptic cross-section. */
export interface BodyPart {
  name: string;
  bone: number;              // joint whose rotation moves this part
  a: Vector3;                // axis start
  b: Vector3;                // axis end
  r0: number;                // radius at a
  r1: number;                // radius at b
  side: Vector3;             // first cross-section axis (made orthogonal to the axis)
  sx: number;                // cross-section scale along `side`
  sz: number;                // cross-section scale across (axis × side)
  startBone?: number;        // neighbour blended in around startAt (usually the parent joint's bone)
  startAt?: Vector3;         // where that joint is (default a)
  endBone?: number;          // neighbour blended in around endAt (usually the child joint's bone)
  endAt?: Vector3;           // where that joint is (default b)
  blend: number;             // half-width of the blend band, metres
  color: number;             // sRGB hex
}

const SHIRT = 0x3f6fd8;
const PANTS = 0x2b3242;
const SKIN = 0xe3c4a8;
const SHOE = 0xf1f1ee;
const VISOR = 0x1a2030;

/** Standard joint names the body expects (SMPL order names used by the manifest). */
const NAMES = [
  'pelvis', 'l_hip', 'r_hip', 'spine1', 'l_knee', 'r_knee', 'spine2', 'l_ankle', 'r_ankle', 'spine3',
  'l_foot', 'r_foot', 'neck', 'l_collar', 'r_collar', 'head', 'l_shoulder', 'r_shoulder', 'l_elbow',
  'r_elbow', 'l_wrist', 'r_wrist',
] as const;
type JointName = (typeof NAMES)[number];

/** The body parts for a skeleton whose joints carry the standard names (any order). */
export function bodyParts(s: RigSkeleton): BodyPart[] {
  checkSkeleton(s);
  const index = new Map(s.joints.map((n, i) => [n, i]));
  for (const n of NAMES) {
    if (!index.has(n)) throw new Error(`manifest skeleton.joints: the character needs a joint named '${n}'`);
  }
  const J = (n: JointName): number => index.get(n)!;
  const rest = restPositions(s);
  const P = (n: JointName): Vector3 => rest[J(n)].clone();
  const X = new Vector3(1, 0, 0);
  const Y = new Vector3(0, 1, 0);
  const Z = new Vector3(0, 0, 1);
  const parts: BodyPart[] = [];
  const add = (p: Omit<BodyPart, 'blend'> & { blend?: number }) => parts.push({ blend: 0.05, ...p });

  // Hips and trunk (elliptic sections: wide along X, shallow along Z).
  add({ name: 'hips', bone: J('pelvis'), a: P('r_hip'), b: P('l_hip'), r0: 0.105, r1: 0.105, side: Z, sx: 0.86, sz: 1.0,
    startBone: J('r_hip'), endBone: J('l_hip'), blend: 0.035, color: PANTS });
  add({ name: 'belly', bone: J('pelvis'), a: P('pelvis').add(new Vector3(0, -0.02, 0)), b: P('spine1'), r0: 0.125, r1: 0.12,
    side: X, sx: 1.12, sz: 0.78, endBone: J('spine1'), blend: 0.04, color: SHIRT });
  add({ name: 'waist', bone: J('spine1'), a: P('spine1'), b: P('spine2'), r0: 0.12, r1: 0.125, side: X, sx: 1.1, sz: 0.78,
    startBone: J('pelvis'), endBone: J('spine2'), blend: 0.045, color: SHIRT });
  add({ name: 'lower-chest', bone: J('spine2'), a: P('spine2'), b: P('spine3'), r0: 0.125, r1: 0.13, side: X, sx: 1.16, sz: 0.78,
    startBone: J('spine1'), endBone: J('spine3'), blend: 0.025, color: SHIRT });
  add({ name: 'chest', bone: J('spine3'), a: P('spine3'), b: P('neck').add(new Vector3(0, -0.07, 0)), r0: 0.13, r1: 0.115,
    side: X, sx: 1.3, sz: 0.74, startBone: J('spine2'), blend: 0.03, color: SHIRT });
  add({ name: 'neck', bone: J('neck'), a: P('neck').add(new Vector3(0, -0.03, 0)), b: P('head'), r0: 0.05, r1: 0.045,
    side: X, sx: 1, sz: 1, startBone: J('spine3'), startAt: P('neck'), endBone: J('head'), blend: 0.025, color: SKIN });
  const skull = P('head');
  add({ name: 'head', bone: J('head'), a: skull.clone().add(new Vector3(0, 0.045, 0.005)), b: skull.clone().add(new Vector3(0, 0.115, -0.005)),
    r0: 0.095, r1: 0.095, side: X, sx: 0.86, sz: 1.05, color: SKIN });
  add({ name: 'visor', bone: J('head'), a: skull.clone().add(new Vector3(-0.055, 0.085, 0.072)),
    b: skull.clone().add(new Vector3(0.055, 0.085, 0.072)), r0: 0.026, r1: 0.026, side: Y, sx: 0.85, sz: 0.7, color: VISOR });

  for (const side of ['l', 'r'] as const) {
    const n = (base: string) => `${side}_${base}` as JointName;
    const sgn = side === 'l' ? 1 : -1;
    add({ name: `${side}-collar`, bone: J(n('collar')), a: P(n('collar')).add(new Vector3(-0.04 * sgn, -0.02, 0)), b: P(n('shoulder')),
      r0: 0.065, r1: 0.06, side: Z, sx: 0.9, sz: 0.95, startBone: J('spine3'), startAt: P(n('collar')),
      endBone: J(n('shoulder')), blend: 0.04, color: SHIRT });
    add({ name: `${side}-upper-arm`, bone: J(n('shoulder')), a: P(n('shoulder')), b: P(n('elbow')), r0: 0.056, r1: 0.043,
      side: Z, sx: 1, sz: 1, startBone: J(n('collar')), endBone: J(n('elbow')), blend: 0.045, color: SHIRT });
    add({ name: `${side}-forearm`, bone: J(n('elbow')), a: P(n('elbow')), b: P(n('wrist')), r0: 0.042, r1: 0.031,
      side: Z, sx: 1.05, sz: 0.9, startBone: J(n('shoulder')), endBone: J(n('wrist')), blend: 0.04, color: SKIN });
    const armDir = P(n('wrist')).sub(P(n('elbow'))).normalize();
    add({ name: `${side}-hand`, bone: J(n('wrist')), a: P(n('wrist')).addScaledVector(armDir, 0.035),
      b: P(n('wrist')).addScaledVector(armDir, 0.13), r0: 0.038, r1: 0.034, side: Z, sx: 1.15, sz: 0.5,
      startBone: J(n('elbow')), startAt: P(n('wrist')), blend: 0.025, color: SKIN });
    add({ name: `${side}-thigh`, bone: J(n('hip')), a: P(n('hip')), b: P(n('knee')), r0: 0.085, r1: 0.058,
      side: X, sx: 1, sz: 1.05, startBone: J('pelvis'), endBone: J(n('knee')), blend: 0.05, color: PANTS });
    add({ name: `${side}-shin`, bone: J(n('knee')), a: P(n('knee')), b: P(n('ankle')), r0: 0.056, r1: 0.04,
      side: X, sx: 1, sz: 1.05, startBone: J(n('hip')), endBone: J(n('ankle')), blend: 0.045, color: PANTS });
    const ankle = P(n('ankle'));
    const ball = P(n('foot'));
    add({ name: `${side}-foot`, bone: J(n('ankle')), a: new Vector3(ankle.x, 0.047, ankle.z - 0.05),
      b: new Vector3(ball.x, 0.032, ball.z + 0.055), r0: 0.046, r1: 0.036, side: X, sx: 1.0, sz: 0.72,
      startBone: J(n('knee')), startAt: ankle, endBone: J(n('foot')), endAt: ball, blend: 0.03, color: SHOE });
  }
  return parts;
}

function smoothstep(e0: number, e1: number, x: number): number {
  const t = Math.min(1, Math.max(0, (x - e0) / (e1 - e0)));
  return t * t * (3 - 2 * t);
}

/**
 * Skin weights of a point of a part, from its coordinate u along the part's axis: the part's own bone,
 * fading into startBone around uStart and into endBone around uEnd (each reaches 0.5 at its joint).
 * Returns up to three (bone, weight) pairs with positive weights summing to 1.
 */
export function partWeights(part: BodyPart, u: number, uStart: number, uEnd: number): Array<[number, number]> {
  const room = Math.max(1e-4, (uEnd - uStart) / 2);
  const h = Math.max(1e-4, Math.min(part.blend, room));
  const ws = part.startBone === undefined ? 0 : 1 - smoothstep(uStart - h, uStart + h, u);
  const we = part.endBone === undefined ? 0 : smoothstep(uEnd - h, uEnd + h, u);
  const out: Array<[number, number]> = [];
  const self = Math.max(0, 1 - ws - we);
  if (self > 0) out.push([part.bone, self]);
  if (ws > 0) out.push([part.startBone!, ws]);
  if (we > 0) out.push([part.endBone!, we]);
  const sum = out.reduce((acc, [, w]) => acc + w, 0);
  return out.map(([b, w]) => [b, w / sum]);
}

export interface BodyGeometryOptions {
  radial?: number;       // vertices around each ring
  capRings?: number;     // rings per hemispherical cap
  ringSpacing?: number;  // metres between rings along the axis
}

/** One indexed BufferGeometry for all parts, with skinIndex/skinWeight (4 influences) and colours. */
export function buildBodyGeometry(s: RigSkeleton, parts: BodyPart[] = bodyParts(s), opts: BodyGeometryOptions = {}): BufferGeometry {
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
    const uStart = (part.startAt ?? part.a).clone().sub(part.a).dot(dir);
    const uEnd = (part.endAt ?? part.b).clone().sub(part.a).dot(dir);
    hexToLinear(part.color, c);

    // Rings: (axial u, radius) from the start pole to the end pole.
    const rings: Array<[number, number]> = [];
    for (let i = 1; i < capRings; i++) {
      const phi = -Math.PI / 2 + (i / capRings) * (Math.PI / 2);
      rings.push([part.r0 * Math.sin(phi), part.r0 * Math.cos(phi)]);
    }
    const bodyRings = Math.max(2, Math.ceil(L / spacing));
    for (let i = 0; i <= bodyRings; i++) {
      const t = i / bodyRings;
      rings.push([t * L, part.r0 + (part.r1 - part.r0) * t]);
    }
    for (let i = 1; i < capRings; i++) {
      const phi = (i / capRings) * (Math.PI / 2);
      rings.push([L + part.r1 * Math.sin(phi), part.r1 * Math.cos(phi)]);
    }

    const base = pos.length / 3;
    const emit = (u: number, x: number, z: number) => {
      const p = part.a.clone().addScaledVector(dir, u).addScaledVector(side, x * part.sx).addScaledVector(across, z * part.sz);
      pos.push(p.x, p.y, p.z);
      col.push(c.r, c.g, c.b);
      const w = partWeights(part, u, uStart, uEnd);
      for (let k = 0; k < 4; k++) {
        skinIndex.push(k < w.length ? w[k][0] : 0);
        skinWeight.push(k < w.length ? w[k][1] : 0);
      }
    };
    emit(-part.r0, 0, 0); // start pole
    for (const [u, r] of rings) {
      for (let k = 0; k < radial; k++) {
        const th = (k / radial) * Math.PI * 2;
        emit(u, r * Math.cos(th), r * Math.sin(th));
      }
    }
    emit(L + part.r1, 0, 0); // end pole
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
