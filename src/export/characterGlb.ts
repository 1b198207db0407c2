/**
 * Downloads on a user's character (src/character/retarget): the character with the retargeted clip as
 * one binary glTF, and the clip alone as BVH on that skeleton's bone names.
 *
 * The GLB is the character's own document (as packed by loadCharacter: every buffer and image in one
 * BIN chunk) with ONE animation appended: a LINEAR sampler per animated node (rotation; translation
 * of the pelvis bone and of feet rigged as IK targets), keyed at the motion's frame times. Nodes, skins, meshes, materials, textures,
 * extensions (VRM included) and the character's own animations are written back byte for byte, so
 * nothing is lost in a round trip through three's scene graph (which is why this does not go through
 * GLTFExporter as the built-in character's download does: that would re-encode textures and drop the
 * extensions it does not know).
 */
import { Matrix4, type Object3D, Quaternion, Vector3 } from 'three';
import type { LoadedCharacter } from '../character/retarget/load';
import type { RetargetResult } from '../character/retarget/retarget';
import { matFromQuat } from '../motion/math3';
import { type BvhUnits, eulerZXY } from './bvh';
import { type GltfJson, writeGlb } from './glb';

const FLOAT = 5126;

/** The character with `result`'s clip added as an animation named `name` (default: the clip's). */
export function characterToGLB(ch: Pick<LoadedCharacter, 'json' | 'bin' | 'nodeIndex'>, result: RetargetResult, name = result.clip.name): Uint8Array {
  const json: GltfJson = JSON.parse(JSON.stringify(ch.json));
  const parts: Uint8Array[] = [ch.bin];
  let length = ch.bin.byteLength;
  const pad = () => {
    const p = (4 - (length % 4)) % 4;
    if (p) {
      parts.push(new Uint8Array(p));
      length += p;
    }
  };
  pad();
  json.bufferViews = json.bufferViews ?? [];
  json.accessors = json.accessors ?? [];
  const accessor = (data: Float32Array, type: 'SCALAR' | 'VEC3' | 'VEC4', minmax = false): number => {
    const view = json.bufferViews.push({ buffer: 0, byteOffset: length, byteLength: data.byteLength }) - 1;
    parts.push(new Uint8Array(data.buffer, data.byteOffset, data.byteLength));
    length += data.byteLength;
    pad();
    const acc: GltfJson = { bufferView: view, componentType: FLOAT, count: data.length / { SCALAR: 1, VEC3: 3, VEC4: 4 }[type], type };
    if (minmax) {
      acc.min = [Math.min(...data)];
      acc.max = [Math.max(...data)];
    }
    return json.accessors.push(acc) - 1;
  };
  const node = (o: Object3D): number => {
    const n = ch.nodeIndex.get(o);
    if (n === undefined) throw new Error(`characterToGLB: bone '${o.name}' did not come from a node of this character's file`);
    return n;
  };
  const times = Float32Array.from({ length: result.frames }, (_, f) => f / result.fps);
  const input = accessor(times, 'SCALAR', true);
  const samplers: GltfJson[] = [];
  const channels: GltfJson[] = [];
  const add = (target: number, path: 'rotation' | 'translation', data: Float32Array, type: 'VEC3' | 'VEC4') => {
    samplers.push({ input, output: accessor(data, type), interpolation: 'LINEAR' });
    channels.push({ sampler: samplers.length - 1, target: { node: target, path } });
  };
  add(node(result.bones[0]), 'translation', result.rootPositions, 'VEC3');
  result.bones.forEach((b, i) => add(node(b), 'rotation', result.rotations[i], 'VEC4'));
  for (const p of result.positions) add(node(p.bone), 'translation', p.data, 'VEC3');
  json.animations = [...(json.animations ?? []), { name, samplers, channels }];

  const bin = new Uint8Array(length);
  let o = 0;
  for (const p of parts) {
    bin.set(p, o);
    o += p.byteLength;
  }
  json.buffers = [{ byteLength: length }];
  return writeGlb(json, bin);
}

/** The name each bone has in the character's file (its glTF node's; three may rename duplicates), for characterToBVH. */
export function fileBoneNames(ch: Pick<LoadedCharacter, 'json' | 'nodeIndex'>): (o: Object3D) => string {
  return (o) => ch.json.nodes?.[ch.nodeIndex.get(o) ?? -1]?.name ?? o.name;
}

const DEG = 180 / Math.PI;
/** length scale and digits per unit, as writeBVH writes them */
const UNITS: Record<BvhUnits, [number, number]> = { m: [1, 6], cm: [100, 4] };
const fmt = (digits: number) => (v: number) => {
  const s = v.toFixed(digits);
  return /^-0\.0*$/.test(s) ? s.slice(1) : s;
};

/**
 * The clip as BVH on the character's skeleton: the bones under (and including) the pelvis bone, named
 * as in the file (`names`, e.g. the glTF node names; spaces become '_'), offsets in metres (or
 * centimetres: `units`, as writeBVH) in the parent bone's rest frame, channels `Zrotation Xrotation Yrotation` (R = Rz·Rx·Ry, as writeBVH) holding
 * each bone's rotation relative to its parent bone, and the root's position and rotation in the frame
 * of `root` (any node above the pelvis bone baked in). Poses `root` frame by frame and restores its
 * rest pose afterwards.
 */
export function characterToBVH(root: Object3D, result: RetargetResult, names: (o: Object3D) => string = (o) => o.name, units: BvhUnits = 'm'): string {
  if (!(units in UNITS)) throw new RangeError(`characterToBVH: units must be 'm' or 'cm', got ${String(units)}`);
  const [CM, digits] = UNITS[units];
  const num = fmt(digits);
  const end = 0.05 * CM; // End Site: 5 cm along the bone
  const pelvis = result.bones[0];
  const bones: Object3D[] = [];
  const parentOf = new Map<Object3D, Object3D | null>();
  const walk = (o: Object3D, parentBone: Object3D | null) => {
    const isBone = (o as { isBone?: boolean }).isBone || o === pelvis;
    if (isBone) {
      bones.push(o);
      parentOf.set(o, parentBone);
    }
    for (const c of o.children) walk(c, isBone ? o : parentBone);
  };
  walk(pelvis, null);
  const kids = new Map<Object3D, Object3D[]>(bones.map((b) => [b, []]));
  for (const b of bones) if (parentOf.get(b)) kids.get(parentOf.get(b)!)!.push(b);

  const saved = bones.map((b) => [b.position.clone(), b.quaternion.clone()] as const);
  const rootInv = () => root.matrixWorld.clone().invert();
  const world = (o: Object3D, inv: Matrix4) => {
    const m = new Matrix4().multiplyMatrices(inv, o.matrixWorld);
    const p = new Vector3();
    const q = new Quaternion();
    m.decompose(p, q, new Vector3());
    return { p, q };
  };
  root.updateMatrixWorld(true);
  let inv = rootInv();
  const rest = new Map(bones.map((b) => [b, world(b, inv)]));

  const used = new Map<string, number>();
  const label = (o: Object3D) => {
    const base = (names(o) || 'bone').replace(/\s+/g, '_');
    const n = (used.get(base) ?? 0) + 1;
    used.set(base, n);
    return n > 1 ? `${base}_${n}` : base;
  };
  const lines = ['HIERARCHY'];
  const order: Object3D[] = [];
  const emit = (b: Object3D, depth: number) => {
    order.push(b);
    const ind = '  '.repeat(depth);
    const pb = parentOf.get(b);
    const off = pb ? rest.get(b)!.p.clone().sub(rest.get(pb)!.p).applyQuaternion(rest.get(pb)!.q.clone().invert()) : new Vector3();
    lines.push(`${ind}${pb ? 'JOINT' : 'ROOT'} ${label(b)}`, `${ind}{`, `${ind}  OFFSET ${[off.x, off.y, off.z].map((x) => num(x * CM)).join(' ')}`);
    lines.push(`${ind}  CHANNELS ${pb ? '3' : '6 Xposition Yposition Zposition'} Zrotation Xrotation Yrotation`);
    const cs = kids.get(b)!;
    if (!cs.length) {
      const dir = pb ? off.clone().normalize().multiplyScalar(end) : new Vector3(0, end, 0);
      lines.push(`${ind}  End Site`, `${ind}  {`, `${ind}    OFFSET ${[dir.x, dir.y, dir.z].map(num).join(' ')}`, `${ind}  }`);
    }
    for (const c of cs) emit(c, depth + 1);
    lines.push(`${ind}}`);
  };
  emit(pelvis, 0);
  lines.push('MOTION', `Frames: ${result.frames}`, `Frame Time: ${(1 / result.fps).toFixed(7)}`);
  try {
    for (let f = 0; f < result.frames; f++) {
      result.bones.forEach((b, i) => b.quaternion.fromArray(result.rotations[i], f * 4));
      pelvis.position.fromArray(result.rootPositions, f * 3);
      root.updateMatrixWorld(true);
      inv = rootInv();
      const W = new Map(order.map((b) => [b, world(b, inv)]));
      const vals: string[] = [];
      for (const b of order) {
        const pb = parentOf.get(b);
        const w = W.get(b)!;
        if (!pb) vals.push(...[w.p.x, w.p.y, w.p.z].map((x) => num(x * CM)));
        const local = pb ? W.get(pb)!.q.clone().invert().multiply(w.q) : w.q;
        const [z, x, y] = eulerZXY(matFromQuat([local.x, local.y, local.z, local.w]));
        vals.push(num(z * DEG), num(x * DEG), num(y * DEG));
      }
      lines.push(vals.join(' '));
    }
  } finally {
    bones.forEach((b, i) => {
      b.position.copy(saved[i][0]);
      b.quaternion.copy(saved[i][1]);
    });
    root.updateMatrixWorld(true);
  }
  return lines.join('\n') + '\n';
}
