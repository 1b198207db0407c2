// Skinned humanoid rigs of other conventions, built in code as binary glTF (what a user would drop):
// our reference proportions changed (size, leg length), T- or A-pose, facing +Z or −Z, bone axes
// along +Y (Mixamo/Blender), along ±X (Unreal) or world-aligned (VRM), with rolls, an Armature node
// (Z-up → Y-up rotation, 0.01 scale as Blender's FBX exports have), extra spine, twist and finger
// bones, and the VRM humanoid extension (0.x and 1.0). One tiny tetrahedron per bone is the mesh.
import { Matrix4, Object3D, Quaternion, Vector3 } from 'three';
import { readGlb } from '../../src/character/retarget/load';
import { writeGlb } from '../../src/export/glb';
import { restPositions } from '../../src/character/rig';
import type { JointName, SkeletonLike } from '../../src/skeleton';

export interface RigSpec {
  label: string;
  /** our joint → bone name; joints left out are not built (unless spine bones replace them) */
  names: Partial<Record<JointName, string>>;
  /** spine bones between pelvis and neck (names); spine3 is the last */
  spine: string[];
  scale?: number;
  legScale?: number;
  /** degrees the arms hang below horizontal (A-pose) */
  apose?: number;
  facing?: 1 | -1;
  axes: 'y-along' | 'x-along' | 'identity';
  /** armature node above the bones: Blender FBX style (−90° about X, 0.01 scale) */
  armature?: boolean;
  /** a root bone above the pelvis (Unreal 'root') */
  rootBone?: string;
  fingers?: (side: 'l' | 'r', finger: string, k: number) => string;
  twist?: (side: 'l' | 'r', limb: 'upperarm' | 'thigh') => string;
  ends?: boolean;
  vrm?: '0.x' | '1.0';
}

interface Built {
  name: string;
  parent: number;
  pos: Vector3;
  joint?: JointName;
}

const VRM_NAME: Partial<Record<JointName, string>> = {
  pelvis: 'hips', neck: 'neck', head: 'head', l_hip: 'leftUpperLeg', l_knee: 'leftLowerLeg', l_ankle: 'leftFoot', l_foot: 'leftToes',
  r_hip: 'rightUpperLeg', r_knee: 'rightLowerLeg', r_ankle: 'rightFoot', r_foot: 'rightToes', l_collar: 'leftShoulder', l_shoulder: 'leftUpperArm',
  l_elbow: 'leftLowerArm', l_wrist: 'leftHand', r_collar: 'rightShoulder', r_shoulder: 'rightUpperArm', r_elbow: 'rightLowerArm', r_wrist: 'rightHand',
};

/** World rest positions of the rig's bones (Y up, metres). */
function layout(sk: SkeletonLike, spec: RigSpec): Built[] {
  const rest = restPositions(sk);
  const P = (j: JointName) => rest[sk.joints.indexOf(j)].clone();
  const out: Built[] = [];
  const idx = new Map<string, number>();
  const add = (name: string, parent: string | null, pos: Vector3, joint?: JointName) => {
    idx.set(name, out.length);
    out.push({ name, parent: parent === null ? -1 : idx.get(parent)!, pos, joint });
    return name;
  };
  const N = (j: JointName) => spec.names[j]!;
  const legScale = spec.legScale ?? 1;
  const top = spec.rootBone ? add(spec.rootBone, null, new Vector3(0, 0, 0)) : null;
  const pelvis = add(N('pelvis'), top, P('pelvis'), 'pelvis');
  // legs (scaled about the hip)
  for (const s of ['l', 'r'] as const) {
    const hip = P(`${s}_hip`);
    const leg = (j: JointName) => P(j).sub(hip).multiplyScalar(legScale).add(hip);
    let parent = add(N(`${s}_hip`), pelvis, hip, `${s}_hip`);
    if (spec.twist) add(spec.twist(s, 'thigh'), parent, hip.clone().lerp(leg(`${s}_knee`), 0.5));
    parent = add(N(`${s}_knee`), parent, leg(`${s}_knee`), `${s}_knee`);
    parent = add(N(`${s}_ankle`), parent, leg(`${s}_ankle`), `${s}_ankle`);
    if (spec.names[`${s}_foot`]) {
      const toe = add(N(`${s}_foot`), parent, leg(`${s}_foot`), `${s}_foot`);
      if (spec.ends) add(`${N(`${s}_foot`)}_End`, toe, leg(`${s}_foot`).add(new Vector3(0, 0, 0.06)));
    }
  }
  // spine: the bones spread from pelvis to spine3's height; our spine1..3 positions when there are three
  const sp = [P('spine1'), P('spine2'), P('spine3')];
  let parent = pelvis;
  spec.spine.forEach((name, i) => {
    const n = spec.spine.length;
    const t = n === 1 ? 2 : (i * 2) / (n - 1);
    const a = Math.floor(Math.min(t, 1.999));
    const pos = sp[a].clone().lerp(sp[a + 1] ?? sp[a], t - a);
    parent = add(name, parent, pos, i === n - 1 ? 'spine3' : undefined);
  });
  const chest = parent;
  const neck = add(N('neck'), chest, P('neck'), 'neck');
  const head = add(N('head'), neck, P('head'), 'head');
  if (spec.ends) add(`${N('head')}Top_End`, head, P('head').add(new Vector3(0, 0.18, 0)));
  for (const s of ['l', 'r'] as const) {
    const sgn = s === 'l' ? 1 : -1;
    const sh = P(`${s}_shoulder`);
    const a = ((spec.apose ?? 0) * Math.PI) / 180;
    const arm = (p: Vector3) => p.sub(sh).applyAxisAngle(new Vector3(0, 0, 1), -sgn * a).add(sh);
    let p = spec.names[`${s}_collar`] ? add(N(`${s}_collar`), chest, P(`${s}_collar`), `${s}_collar`) : chest;
    p = add(N(`${s}_shoulder`), p, sh, `${s}_shoulder`);
    if (spec.twist) add(spec.twist(s, 'upperarm'), p, arm(sh.clone().lerp(P(`${s}_elbow`), 0.5)));
    p = add(N(`${s}_elbow`), p, arm(P(`${s}_elbow`)), `${s}_elbow`);
    const wrist = arm(P(`${s}_wrist`));
    const hand = add(N(`${s}_wrist`), p, wrist, `${s}_wrist`);
    if (spec.fingers) {
      const dir = wrist.clone().sub(arm(P(`${s}_elbow`))).normalize();
      ['Thumb', 'Index', 'Middle', 'Ring', 'Pinky'].forEach((f, fi) => {
        let q = hand;
        for (let k = 1; k <= 3; k++) {
          const pos = wrist.clone().addScaledVector(dir, 0.04 + 0.03 * k).add(new Vector3(0, 0, 0.02 * (fi - 2)));
          q = add(spec.fingers!(s, f, k), q, pos);
        }
      });
    }
  }
  // size and facing
  const scale = spec.scale ?? 1;
  const minY = Math.min(...out.filter((b) => /ankle/.test(b.joint ?? '')).map((b) => b.pos.y));
  const ankleH = rest[sk.joints.indexOf('l_ankle')].y;
  for (const b of out) {
    if (b.name === spec.rootBone) continue;
    b.pos.y += ankleH - minY; // ankles at our ankle height after the leg change
    b.pos.multiplyScalar(scale);
    if (spec.facing === -1) b.pos.set(-b.pos.x, b.pos.y, -b.pos.z);
  }
  return out;
}

/** A deterministic roll (radians) per bone. */
const roll = (i: number) => ((i * 2654435761) % 1000) / 1000 * 2 * Math.PI;

/** The rig as a binary glTF (skinned; one tetrahedron per bone). */
export function buildRigGlb(sk: SkeletonLike, spec: RigSpec): Uint8Array {
  const bones = layout(sk, spec);
  const kids = bones.map((_, i) => bones.findIndex((b) => b.parent === i));
  // world rotations by convention
  const worldQ = bones.map((b, i) => {
    if (spec.axes === 'identity') return new Quaternion();
    const c = kids[i];
    const along = c >= 0 ? bones[c].pos.clone().sub(b.pos) : b.parent >= 0 ? b.pos.clone().sub(bones[b.parent].pos) : new Vector3(0, 1, 0);
    if (along.lengthSq() < 1e-12) along.set(0, 1, 0);
    const axis = spec.axes === 'y-along' ? new Vector3(0, 1, 0) : new Vector3(b.pos.x < -1e-6 ? -1 : 1, 0, 0);
    const q = new Quaternion().setFromUnitVectors(axis, along.normalize());
    return new Quaternion().setFromAxisAngle(along, roll(i)).multiply(q);
  });
  const armature = new Matrix4();
  if (spec.armature) armature.compose(new Vector3(), new Quaternion().setFromAxisAngle(new Vector3(1, 0, 0), -Math.PI / 2), new Vector3(0.01, 0.01, 0.01));
  const armScale = spec.armature ? 0.01 : 1;
  // node world matrices: the armature's rotation is undone by the bones' own (the world rest pose is as laid out)
  const world = bones.map((b, i) => new Matrix4().compose(b.pos, worldQ[i], new Vector3(armScale, armScale, armScale)));
  const nodes: Record<string, unknown>[] = [];
  const boneNode = (i: number) => i + (spec.armature ? 1 : 0);
  if (spec.armature) {
    const t = new Vector3();
    const q = new Quaternion();
    const s = new Vector3();
    armature.decompose(t, q, s);
    nodes.push({ name: 'Armature', rotation: q.toArray(), scale: s.toArray(), children: bones.map((b, i) => (b.parent < 0 ? boneNode(i) : -1)).filter((x) => x >= 0) });
  }
  bones.forEach((b, i) => {
    const parentWorld = b.parent >= 0 ? world[b.parent] : armature;
    const local = new Matrix4().multiplyMatrices(parentWorld.clone().invert(), world[i]);
    const t = new Vector3();
    const q = new Quaternion();
    const s = new Vector3();
    local.decompose(t, q, s);
    const node: Record<string, unknown> = { name: b.name, translation: t.toArray(), rotation: q.toArray() };
    if (Math.abs(s.x - 1) > 1e-6) node.scale = s.toArray();
    const ch = bones.map((c, k) => (c.parent === i ? boneNode(k) : -1)).filter((x) => x >= 0);
    if (ch.length) node.children = ch;
    nodes.push(node);
  });
  // mesh: a tetrahedron at each bone, skinned to it
  const pos: number[] = [];
  const jnt: number[] = [];
  const wgt: number[] = [];
  const ind: number[] = [];
  bones.forEach((b, i) => {
    const o = pos.length / 3;
    for (const d of [[0.01, 0, 0], [-0.01, 0, 0.01], [0, 0.01, -0.01], [0, -0.01, 0]]) {
      pos.push(b.pos.x + d[0], b.pos.y + d[1], b.pos.z + d[2]);
      jnt.push(i, 0, 0, 0);
      wgt.push(1, 0, 0, 0);
    }
    ind.push(o, o + 1, o + 2, o, o + 2, o + 3, o, o + 3, o + 1, o + 1, o + 3, o + 2);
  });
  const ibm: number[] = [];
  world.forEach((m) => ibm.push(...m.clone().invert().elements));
  const arrays: [Float32Array | Uint16Array, number][] = [
    [new Float32Array(pos), 34962], [new Uint16Array(jnt), 34962], [new Float32Array(wgt), 34962], [new Uint16Array(ind), 34963], [new Float32Array(ibm), 0],
  ];
  const chunks: Uint8Array[] = [];
  let len = 0;
  const bufferViews = arrays.map(([a, target]) => {
    const view: Record<string, unknown> = { buffer: 0, byteOffset: len, byteLength: a.byteLength };
    if (target) view.target = target;
    chunks.push(new Uint8Array(a.buffer, a.byteOffset, a.byteLength));
    len += a.byteLength;
    const pad = (4 - (len % 4)) % 4;
    if (pad) {
      chunks.push(new Uint8Array(pad));
      len += pad;
    }
    return view;
  });
  const bin = new Uint8Array(len);
  let o = 0;
  for (const c of chunks) {
    bin.set(c, o);
    o += c.byteLength;
  }
  const n = bones.length * 4;
  const mn = [0, 1, 2].map((c) => Math.min(...pos.filter((_, k) => k % 3 === c)));
  const mx = [0, 1, 2].map((c) => Math.max(...pos.filter((_, k) => k % 3 === c)));
  const meshNode = nodes.length;
  nodes.push({ name: 'Body', mesh: 0, skin: 0 });
  const json: Record<string, unknown> = {
    asset: { version: '2.0', generator: 'emdm tests/unit/retargetRigs.ts' },
    scene: 0,
    scenes: [{ nodes: [...(spec.armature ? [0] : bones.map((b, i) => (b.parent < 0 ? boneNode(i) : -1)).filter((x) => x >= 0)), meshNode] }],
    nodes,
    meshes: [{ name: 'Body', primitives: [{ attributes: { POSITION: 0, JOINTS_0: 1, WEIGHTS_0: 2 }, indices: 3, material: 0 }] }],
    materials: [{ name: 'Skin', pbrMetallicRoughness: { baseColorFactor: [0.9, 0.7, 0.6, 1], metallicFactor: 0 } }],
    skins: [{ joints: bones.map((_, i) => boneNode(i)), inverseBindMatrices: 4 }],
    accessors: [
      { bufferView: 0, componentType: 5126, count: n, type: 'VEC3', min: mn, max: mx },
      { bufferView: 1, componentType: 5123, count: n, type: 'VEC4' },
      { bufferView: 2, componentType: 5126, count: n, type: 'VEC4' },
      { bufferView: 3, componentType: 5123, count: ind.length, type: 'SCALAR' },
      { bufferView: 4, componentType: 5126, count: bones.length, type: 'MAT4' },
    ],
    bufferViews,
    buffers: [{ byteLength: len }],
  };
  if (spec.vrm) {
    const human: [string, number][] = [];
    bones.forEach((b, i) => {
      const vn = b.joint === 'spine3' ? (spec.spine.length >= 3 ? 'upperChest' : 'chest') : b.joint ? VRM_NAME[b.joint] : undefined;
      if (vn) human.push([vn, boneNode(i)]);
    });
    spec.spine.slice(0, -1).forEach((name, i) => human.push([i === 0 ? 'spine' : 'chest', boneNode(bones.findIndex((b) => b.name === name))]));
    json.extensionsUsed = [spec.vrm === '1.0' ? 'VRMC_vrm' : 'VRM'];
    json.extensions = spec.vrm === '1.0'
      ? { VRMC_vrm: { specVersion: '1.0', meta: { name: spec.label, authors: ['emdm tests'], licenseUrl: 'https://vrm.dev/licenses/1.0/' }, humanoid: { humanBones: Object.fromEntries(human.map(([k, n]) => [k, { node: n }])) } } }
      : { VRM: { specVersion: '0.0', meta: { title: spec.label }, humanoid: { humanBones: human.map(([bone, node]) => ({ bone, node })) } } };
  }
  return writeGlb(json, bin);
}

/** Object3D helper for tests that need a plain three scene. */
export const emptyRoot = () => new Object3D();

const side = (s: 'l' | 'r', L: string, R: string) => (s === 'l' ? L : R);

export const RIGS: RigSpec[] = [
  {
    label: 'Mixamo names, A-pose 45°, Y-along axes with rolls, Armature (Z-up, 0.01), fingers, 0.85 scale',
    names: {
      pelvis: 'mixamorig:Hips', neck: 'mixamorig:Neck', head: 'mixamorig:Head',
      ...Object.fromEntries((['l', 'r'] as const).flatMap((s) => {
        const S = side(s, 'Left', 'Right');
        return [[`${s}_hip`, `mixamorig:${S}UpLeg`], [`${s}_knee`, `mixamorig:${S}Leg`], [`${s}_ankle`, `mixamorig:${S}Foot`], [`${s}_foot`, `mixamorig:${S}ToeBase`],
          [`${s}_collar`, `mixamorig:${S}Shoulder`], [`${s}_shoulder`, `mixamorig:${S}Arm`], [`${s}_elbow`, `mixamorig:${S}ForeArm`], [`${s}_wrist`, `mixamorig:${S}Hand`]];
      })),
    },
    spine: ['mixamorig:Spine', 'mixamorig:Spine1', 'mixamorig:Spine2'],
    scale: 0.85, legScale: 0.9, apose: 45, axes: 'y-along', armature: true, ends: true,
    fingers: (s, f, k) => `mixamorig:${side(s, 'Left', 'Right')}Hand${f}${k}`,
  },
  {
    label: 'Unreal names (UE5: 5 spine bones, root, twist bones), X-along axes with rolls, facing −Z, tall legs, 1.1 scale',
    names: {
      pelvis: 'pelvis', neck: 'neck_01', head: 'head',
      ...Object.fromEntries((['l', 'r'] as const).flatMap((s) => [[`${s}_hip`, `thigh_${s}`], [`${s}_knee`, `calf_${s}`], [`${s}_ankle`, `foot_${s}`], [`${s}_foot`, `ball_${s}`],
        [`${s}_collar`, `clavicle_${s}`], [`${s}_shoulder`, `upperarm_${s}`], [`${s}_elbow`, `lowerarm_${s}`], [`${s}_wrist`, `hand_${s}`]])),
    },
    spine: ['spine_01', 'spine_02', 'spine_03', 'spine_04', 'spine_05'],
    scale: 1.1, legScale: 1.15, axes: 'x-along', facing: -1, rootBone: 'root',
    twist: (s, limb) => `${limb}_twist_01_${s}`,
    fingers: (s, f, k) => `${f.toLowerCase()}_0${k}_${s}`,
  },
  {
    label: 'VRM 1.0 humanoid extension, meaningless node names, no upperChest, identity axes, 0.75 scale',
    names: {
      pelvis: 'Bone.000', neck: 'Bone.010', head: 'Bone.011',
      ...Object.fromEntries((['l', 'r'] as const).flatMap((s, k) => ['hip', 'knee', 'ankle', 'foot', 'collar', 'shoulder', 'elbow', 'wrist'].map((j, i) => [`${s}_${j}`, `Bone.${String(20 + 10 * k + i).padStart(3, '0')}`]))),
    },
    spine: ['Bone.001', 'Bone.002'],
    scale: 0.75, legScale: 0.8, apose: 30, axes: 'identity', vrm: '1.0',
  },
  {
    label: 'VRM 0.x humanoid extension, VRoid J_Bip names, facing −Z, A-pose 35°',
    names: {
      pelvis: 'J_Bip_C_Hips', neck: 'J_Bip_C_Neck', head: 'J_Bip_C_Head',
      ...Object.fromEntries((['l', 'r'] as const).flatMap((s) => {
        const S = s.toUpperCase();
        return [[`${s}_hip`, `J_Bip_${S}_UpperLeg`], [`${s}_knee`, `J_Bip_${S}_LowerLeg`], [`${s}_ankle`, `J_Bip_${S}_Foot`], [`${s}_foot`, `J_Bip_${S}_ToeBase`],
          [`${s}_collar`, `J_Bip_${S}_Shoulder`], [`${s}_shoulder`, `J_Bip_${S}_UpperArm`], [`${s}_elbow`, `J_Bip_${S}_LowerArm`], [`${s}_wrist`, `J_Bip_${S}_Hand`]];
      })),
    },
    spine: ['J_Bip_C_Spine', 'J_Bip_C_Chest', 'J_Bip_C_UpperChest'],
    apose: 35, axes: 'identity', facing: -1, vrm: '0.x',
    fingers: (s, f, k) => `J_Bip_${s.toUpperCase()}_${f}${k}`,
  },
  {
    label: 'Blender Rigify DEF bones, Y-along axes with rolls, thigh twist segments, A-pose 20°',
    names: {
      pelvis: 'DEF-spine', neck: 'DEF-spine.004', head: 'DEF-spine.006',
      ...Object.fromEntries((['l', 'r'] as const).flatMap((s) => {
        const S = s.toUpperCase();
        return [[`${s}_hip`, `DEF-thigh.${S}`], [`${s}_knee`, `DEF-shin.${S}`], [`${s}_ankle`, `DEF-foot.${S}`], [`${s}_foot`, `DEF-toe.${S}`],
          [`${s}_collar`, `DEF-shoulder.${S}`], [`${s}_shoulder`, `DEF-upper_arm.${S}`], [`${s}_elbow`, `DEF-forearm.${S}`], [`${s}_wrist`, `DEF-hand.${S}`]];
      })),
    },
    spine: ['DEF-spine.001', 'DEF-spine.002', 'DEF-spine.003'],
    apose: 20, axes: 'y-along', legScale: 1.05,
    twist: (s, limb) => (limb === 'thigh' ? `DEF-thigh.${s.toUpperCase()}.001` : `DEF-upper_arm.${s.toUpperCase()}.001`),
  },
];

/**
 * A real file's armature made into a skinned character: a tiny tetrahedron at each node under `root`
 * (a node index; default: the first scene's roots), skinned rigidly to that node, is added as one
 * skinned mesh; everything else in the document (nodes, extensions, meshes, materials) is unchanged.
 * For real VRM files that ship a humanoid armature with unskinned meshes (VRM feature samples).
 */
export function withSkin(glb: Uint8Array, file: string, root?: number): Uint8Array {
  const { json, bin } = readGlb(glb, file);
  const nodes: Record<string, any>[] = json.nodes;
  const parent = new Map<number, number>();
  nodes.forEach((n, i) => (n.children ?? []).forEach((c: number) => parent.set(c, i)));
  const local = (n: Record<string, any>) => new Matrix4().compose(
    new Vector3(...((n.translation ?? [0, 0, 0]) as [number, number, number])),
    new Quaternion(...((n.rotation ?? [0, 0, 0, 1]) as [number, number, number, number])),
    new Vector3(...((n.scale ?? [1, 1, 1]) as [number, number, number])),
  );
  const world = (i: number): Matrix4 => (parent.has(i) ? world(parent.get(i)!).multiply(local(nodes[i])) : local(nodes[i]));
  const joints: number[] = [];
  const walk = (i: number) => {
    if (nodes[i].mesh === undefined) joints.push(i);
    (nodes[i].children ?? []).forEach(walk);
  };
  (root !== undefined ? [root] : json.scenes[json.scene ?? 0].nodes).forEach(walk);
  const pos: number[] = [];
  const jnt: number[] = [];
  const wgt: number[] = [];
  const ind: number[] = [];
  const ibm: number[] = [];
  joints.forEach((n, k) => {
    const W = world(n);
    const p = new Vector3().setFromMatrixPosition(W);
    const o = pos.length / 3;
    for (const d of [[0.01, 0, 0], [-0.01, 0, 0.01], [0, 0.01, -0.01], [0, -0.01, 0]]) {
      pos.push(p.x + d[0], p.y + d[1], p.z + d[2]);
      jnt.push(k, 0, 0, 0);
      wgt.push(1, 0, 0, 0);
    }
    ind.push(o, o + 1, o + 2, o, o + 2, o + 3, o, o + 3, o + 1, o + 1, o + 3, o + 2);
    ibm.push(...W.clone().invert().elements);
  });
  const chunks: Uint8Array[] = [bin ?? new Uint8Array(0)];
  let len = chunks[0].byteLength;
  const view = (a: Float32Array | Uint16Array, target?: number) => {
    const pad = (4 - (len % 4)) % 4;
    chunks.push(new Uint8Array(pad));
    len += pad;
    const v: Record<string, unknown> = { buffer: 0, byteOffset: len, byteLength: a.byteLength };
    if (target) v.target = target;
    chunks.push(new Uint8Array(a.buffer, a.byteOffset, a.byteLength));
    len += a.byteLength;
    return json.bufferViews.push(v) - 1;
  };
  const acc = (a: Record<string, unknown>) => json.accessors.push(a) - 1;
  const n = pos.length / 3;
  const mn = [0, 1, 2].map((c) => Math.min(...pos.filter((_, k) => k % 3 === c)));
  const mx = [0, 1, 2].map((c) => Math.max(...pos.filter((_, k) => k % 3 === c)));
  const P = acc({ bufferView: view(new Float32Array(pos), 34962), componentType: 5126, count: n, type: 'VEC3', min: mn, max: mx });
  const Jt = acc({ bufferView: view(new Uint16Array(jnt), 34962), componentType: 5123, count: n, type: 'VEC4' });
  const Wt = acc({ bufferView: view(new Float32Array(wgt), 34962), componentType: 5126, count: n, type: 'VEC4' });
  const I = acc({ bufferView: view(new Uint16Array(ind), 34963), componentType: 5123, count: ind.length, type: 'SCALAR' });
  const B = acc({ bufferView: view(new Float32Array(ibm)), componentType: 5126, count: joints.length, type: 'MAT4' });
  json.materials = json.materials ?? [];
  const material = json.materials.push({ name: 'Skin', pbrMetallicRoughness: { baseColorFactor: [0.9, 0.7, 0.6, 1], metallicFactor: 0 } }) - 1;
  json.meshes = json.meshes ?? [];
  const mesh = json.meshes.push({ name: 'Body', primitives: [{ attributes: { POSITION: P, JOINTS_0: Jt, WEIGHTS_0: Wt }, indices: I, material }] }) - 1;
  json.skins = json.skins ?? [];
  const skin = json.skins.push({ joints, inverseBindMatrices: B }) - 1;
  const node = nodes.push({ name: 'Body', mesh, skin }) - 1;
  json.scenes[json.scene ?? 0].nodes.push(node);
  const out = new Uint8Array(chunks.reduce((s, c) => s + c.byteLength, 0));
  let o = 0;
  for (const c of chunks) {
    out.set(c, o);
    o += c.byteLength;
  }
  json.buffers = [{ byteLength: out.byteLength }];
  return writeGlb(json, out);
}
