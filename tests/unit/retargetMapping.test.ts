// Bone mapping (src/character/retarget/mapping.ts): the naming conventions users' rigs come with map
// onto our 22 joints; wrong maps are refused with a message naming the joint and bone.
import { describe, expect, it } from 'vitest';
import { type BoneInfo, MappingError, autoMap, mappingFromJSON, mappingToJSON, parseBoneName, validateMapping } from '../../src/character/retarget/mapping';
import { JOINT_NAMES, PARENTS } from '../../src/skeleton';

/** A hierarchy from "child<parent" lines (parent by name; first line is the root). */
function tree(spec: string): BoneInfo[] {
  const out: BoneInfo[] = [];
  const idx = new Map<string, number>();
  for (const line of spec.trim().split('\n')) {
    const [name, parent] = line.trim().split('<');
    idx.set(name, out.length);
    out.push({ name, parent: parent ? idx.get(parent)! : -1 });
  }
  return out;
}

/** Legs and arms under given parents, named by `n(side, part)`. */
function limbs(n: (s: 'l' | 'r', part: string) => string, pelvis: string, chest: string, parts: string[], fingers = false): string {
  const lines: string[] = [];
  for (const s of ['l', 'r'] as const) {
    const [hip, knee, ankle, toe, collar, sh, el, wr] = parts.map((p) => n(s, p));
    lines.push(`${hip}<${pelvis}`, `${knee}<${hip}`, `${ankle}<${knee}`, `${toe}<${ankle}`, `${collar}<${chest}`, `${sh}<${collar}`, `${el}<${sh}`, `${wr}<${el}`);
    if (fingers) lines.push(`${n(s, 'Index1')}<${wr}`, `${n(s, 'Index2')}<${n(s, 'Index1')}`);
  }
  return lines.join('\n');
}

const CASES: { label: string; bones: BoneInfo[]; expect: Record<string, string> }[] = [
  {
    label: 'Mixamo (mixamorig: prefix)',
    bones: tree(`mixamorig:Hips\nmixamorig:Spine<mixamorig:Hips\nmixamorig:Spine1<mixamorig:Spine\nmixamorig:Spine2<mixamorig:Spine1\nmixamorig:Neck<mixamorig:Spine2\nmixamorig:Head<mixamorig:Neck\nmixamorig:HeadTop_End<mixamorig:Head\n`
      + limbs((s, p) => `mixamorig:${s === 'l' ? 'Left' : 'Right'}${p}`, 'mixamorig:Hips', 'mixamorig:Spine2', ['UpLeg', 'Leg', 'Foot', 'ToeBase', 'Shoulder', 'Arm', 'ForeArm', 'Hand'], true)),
    expect: { pelvis: 'mixamorig:Hips', spine1: 'mixamorig:Spine', spine2: 'mixamorig:Spine1', spine3: 'mixamorig:Spine2', l_knee: 'mixamorig:LeftLeg', r_foot: 'mixamorig:RightToeBase', l_collar: 'mixamorig:LeftShoulder', l_shoulder: 'mixamorig:LeftArm', r_elbow: 'mixamorig:RightForeArm', head: 'mixamorig:Head' },
  },
  {
    label: "Mixamo as three's loader names it (mixamorig1Hips)",
    bones: tree(`mixamorig1Hips\nmixamorig1Spine<mixamorig1Hips\nmixamorig1Spine1<mixamorig1Spine\nmixamorig1Spine2<mixamorig1Spine1\nmixamorig1Neck<mixamorig1Spine2\nmixamorig1Head<mixamorig1Neck\n`
      + limbs((s, p) => `mixamorig1${s === 'l' ? 'Left' : 'Right'}${p}`, 'mixamorig1Hips', 'mixamorig1Spine2', ['UpLeg', 'Leg', 'Foot', 'ToeBase', 'Shoulder', 'Arm', 'ForeArm', 'Hand'], true)),
    expect: { pelvis: 'mixamorig1Hips', l_hip: 'mixamorig1LeftUpLeg', r_wrist: 'mixamorig1RightHand', neck: 'mixamorig1Neck' },
  },
  {
    label: 'common names (no prefix)',
    bones: tree(`Hips\nSpine<Hips\nSpine1<Spine\nSpine2<Spine1\nNeck<Spine2\nHead<Neck\n`
      + limbs((s, p) => `${s === 'l' ? 'Left' : 'Right'}${p}`, 'Hips', 'Spine2', ['UpLeg', 'Leg', 'Foot', 'ToeBase', 'Shoulder', 'Arm', 'ForeArm', 'Hand'])),
    expect: { pelvis: 'Hips', l_ankle: 'LeftFoot', l_foot: 'LeftToeBase', r_collar: 'RightShoulder', r_shoulder: 'RightArm' },
  },
  {
    label: 'Unreal (UE4: root, spine_01..03, twist bones)',
    bones: tree(`root\npelvis<root\nspine_01<pelvis\nspine_02<spine_01\nspine_03<spine_02\nneck_01<spine_03\nhead<neck_01\n`
      + limbs((s, p) => `${p}_${s}`, 'pelvis', 'spine_03', ['thigh', 'calf', 'foot', 'ball', 'clavicle', 'upperarm', 'lowerarm', 'hand'])
      + '\nthigh_twist_01_l<thigh_l\nupperarm_twist_01_r<upperarm_r\nik_foot_root<root\nik_foot_l<ik_foot_root'),
    expect: { pelvis: 'pelvis', spine1: 'spine_01', spine2: 'spine_02', spine3: 'spine_03', neck: 'neck_01', l_hip: 'thigh_l', l_knee: 'calf_l', l_foot: 'ball_l', r_collar: 'clavicle_r', r_shoulder: 'upperarm_r', r_elbow: 'lowerarm_r' },
  },
  {
    label: 'Unreal 5 (spine_01..05, neck_01/02)',
    bones: tree(`root\npelvis<root\nspine_01<pelvis\nspine_02<spine_01\nspine_03<spine_02\nspine_04<spine_03\nspine_05<spine_04\nneck_01<spine_05\nneck_02<neck_01\nhead<neck_02\n`
      + limbs((s, p) => `${p}_${s}`, 'pelvis', 'spine_05', ['thigh', 'calf', 'foot', 'ball', 'clavicle', 'upperarm', 'lowerarm', 'hand'])),
    expect: { spine1: 'spine_01', spine2: 'spine_03', spine3: 'spine_05', neck: 'neck_01', head: 'head' },
  },
  {
    label: 'Blender Rigify (DEF-, no neck/head names, .001 segments)',
    bones: tree(`DEF-spine\nDEF-spine.001<DEF-spine\nDEF-spine.002<DEF-spine.001\nDEF-spine.003<DEF-spine.002\nDEF-spine.004<DEF-spine.003\nDEF-spine.005<DEF-spine.004\nDEF-spine.006<DEF-spine.005\nDEF-pelvis.L<DEF-spine\nDEF-breast.L<DEF-spine.003\n`
      + limbs((s, p) => `DEF-${p}.${s.toUpperCase()}`, 'DEF-spine', 'DEF-spine.003', ['thigh', 'shin', 'foot', 'toe', 'shoulder', 'upper_arm', 'forearm', 'hand'])
      + '\nDEF-thigh.L.001<DEF-thigh.L'),
    expect: { pelvis: 'DEF-spine', spine1: 'DEF-spine.001', spine2: 'DEF-spine.002', spine3: 'DEF-spine.003', neck: 'DEF-spine.004', head: 'DEF-spine.006', l_hip: 'DEF-thigh.L', l_knee: 'DEF-shin.L', l_shoulder: 'DEF-upper_arm.L', l_collar: 'DEF-shoulder.L' },
  },
  {
    label: 'Blender metarig (no prefix)',
    bones: tree(`spine\nspine.001<spine\nspine.002<spine.001\nspine.003<spine.002\nspine.004<spine.003\nspine.005<spine.004\nspine.006<spine.005\n`
      + limbs((s, p) => `${p}.${s.toUpperCase()}`, 'spine', 'spine.003', ['thigh', 'shin', 'foot', 'toe', 'shoulder', 'upper_arm', 'forearm', 'hand'])),
    expect: { pelvis: 'spine', neck: 'spine.004', head: 'spine.006', r_knee: 'shin.R', r_wrist: 'hand.R' },
  },
  {
    label: 'Reallusion CC (CC_Base_*, the CMU BVH rig of our data)',
    bones: tree(`CC_Base_BoneRoot\nCC_Base_Hip<CC_Base_BoneRoot\nCC_Base_Pelvis<CC_Base_Hip\nCC_Base_Waist<CC_Base_Hip\nCC_Base_Spine01<CC_Base_Waist\nCC_Base_Spine02<CC_Base_Spine01\nCC_Base_NeckTwist01<CC_Base_Spine02\nCC_Base_NeckTwist02<CC_Base_NeckTwist01\nCC_Base_Head<CC_Base_NeckTwist02\n`
      + limbs((s, p) => `CC_Base_${s.toUpperCase()}_${p}`, 'CC_Base_Pelvis', 'CC_Base_Spine02', ['Thigh', 'Calf', 'Foot', 'ToeBase', 'Clavicle', 'Upperarm', 'Forearm', 'Hand'])),
    expect: { pelvis: 'CC_Base_Hip', spine1: 'CC_Base_Waist', spine2: 'CC_Base_Spine01', spine3: 'CC_Base_Spine02', neck: 'CC_Base_NeckTwist01', head: 'CC_Base_Head', l_hip: 'CC_Base_L_Thigh', r_elbow: 'CC_Base_R_Forearm' },
  },
  {
    label: 'VRoid (J_Bip_C_/J_Bip_L_ names)',
    bones: tree(`J_Bip_C_Hips\nJ_Bip_C_Spine<J_Bip_C_Hips\nJ_Bip_C_Chest<J_Bip_C_Spine\nJ_Bip_C_UpperChest<J_Bip_C_Chest\nJ_Bip_C_Neck<J_Bip_C_UpperChest\nJ_Bip_C_Head<J_Bip_C_Neck\n`
      + limbs((s, p) => `J_Bip_${s.toUpperCase()}_${p}`, 'J_Bip_C_Hips', 'J_Bip_C_UpperChest', ['UpperLeg', 'LowerLeg', 'Foot', 'ToeBase', 'Shoulder', 'UpperArm', 'LowerArm', 'Hand'])),
    expect: { pelvis: 'J_Bip_C_Hips', spine3: 'J_Bip_C_UpperChest', l_hip: 'J_Bip_L_UpperLeg', l_elbow: 'J_Bip_L_LowerArm' },
  },
];

describe('automatic bone mapping', () => {
  for (const c of CASES) {
    it(`maps all 22 joints: ${c.label}`, () => {
      const r = autoMap(c.bones);
      expect(r.unmapped).toEqual([]);
      expect(r.mapping).toMatchObject(c.expect);
      expect(() => validateMapping(r.mapping, c.bones)).not.toThrow();
    });
  }

  // The page's own GLB/BVH (bones named after our joints, SMPL's order) dropped back on the page as "your
  // character", and SMPL rigs (L_Shoulder is the upper arm, L_Collar the clavicle; L_Foot below L_Ankle).
  for (const [label, name] of [
    ['our own joint names (the page\'s GLB export)', (j: string) => j],
    ['SMPL names (Pelvis, L_Hip, L_Collar, L_Shoulder, …)', (j: string) => j.replace(/^([lr])_/, (_, s: string) => `${s.toUpperCase()}_`).replace(/(^|_)([a-z])/g, (_, a: string, c: string) => a + c.toUpperCase())],
  ] as const) {
    it(`maps every joint onto itself: ${label}`, () => {
      const bones: BoneInfo[] = JOINT_NAMES.map((j, i) => ({ name: name(j), parent: PARENTS[i] }));
      const r = autoMap(bones);
      expect(r.unmapped).toEqual([]);
      expect(r.mapping).toEqual(Object.fromEntries(JOINT_NAMES.map((j) => [j, name(j)])));
      expect(() => validateMapping(r.mapping, bones)).not.toThrow();
    });
  }

  it('a VRM humanoid maps by its own bone names, whatever the node names', () => {
    const bones = tree('a\nb<a\nc<b\nd<c\ne<d\nf<a\ng<f\nh<g\ni<a\nj<i\nk<j\nl<c\nm<l\nn<m\no<c\np<o\nq<p');
    const vrm = { hips: 'a', spine: 'b', chest: 'c', neck: 'd', head: 'e', leftUpperLeg: 'f', leftLowerLeg: 'g', leftFoot: 'h', rightUpperLeg: 'i', rightLowerLeg: 'j', rightFoot: 'k', leftUpperArm: 'l', leftLowerArm: 'm', leftHand: 'n', rightUpperArm: 'o', rightLowerArm: 'p', rightHand: 'q' };
    const r = autoMap(bones, vrm);
    expect(r.source).toBe('vrm');
    // no upperChest: the chest (where the arms hang) plays spine3
    expect(r.mapping).toMatchObject({ pelvis: 'a', spine1: 'b', spine3: 'c', l_shoulder: 'l', r_wrist: 'q' });
    expect(r.unmapped.sort()).toEqual(['l_collar', 'l_foot', 'r_collar', 'r_foot', 'spine2']);
    expect(() => validateMapping(r.mapping, bones)).not.toThrow();
  });

  it('a snake or a prop is not a humanoid: the missing joints are listed', () => {
    const bones = tree('Bone\nBone.001<Bone\nBone.002<Bone.001\nBone.003<Bone.002');
    const r = autoMap(bones);
    expect(r.unmapped.length).toBe(22);
    expect(() => validateMapping(r.mapping, bones)).toThrow(/pelvis, l_hip, r_hip.*not mapped; a humanoid needs/);
  });

  it('parses side, key and segment number from the usual spellings', () => {
    expect(parseBoneName('mixamorig:LeftUpLeg')).toEqual({ side: 'l', key: 'upleg', num: null });
    expect(parseBoneName('thigh_r')).toEqual({ side: 'r', key: 'thigh', num: null });
    expect(parseBoneName('DEF-upper_arm.L.001')).toEqual({ side: 'l', key: 'upperarm', num: 1 });
    expect(parseBoneName('LThigh')).toEqual({ side: 'l', key: 'thigh', num: null });
    expect(parseBoneName('upperarm_twist_01_l')).toBeNull();
    expect(parseBoneName('ORG-thigh.L')).toBeNull();
    expect(parseBoneName('J_Bip_C_Hips')).toEqual({ side: null, key: 'hips', num: null });
  });
});

describe('mapping validation and JSON', () => {
  const bones = CASES[2].bones;
  const good = autoMap(bones).mapping;

  it('refuses a bone used twice, a bone that does not exist, a child above its parent, an unknown joint', () => {
    expect(() => validateMapping({ ...good, r_knee: 'LeftLeg' }, bones)).toThrow(MappingError);
    expect(() => validateMapping({ ...good, r_knee: 'LeftLeg' }, bones)).toThrow(/bone 'LeftLeg' is used twice \(l_knee and r_knee\)/);
    expect(() => validateMapping({ ...good, head: 'Skull' }, bones)).toThrow(/head → 'Skull': the character has no bone of that name/);
    expect(() => validateMapping({ ...good, l_knee: 'LeftUpLeg', l_hip: 'LeftLeg' }, bones)).toThrow(/l_knee → 'LeftUpLeg' is not below l_hip → 'LeftLeg'/);
    expect(() => validateMapping({ ...good, tail: 'Hips' } as never, bones)).toThrow(/'tail' is not one of our joints/);
    const partial = { pelvis: 'Hips', l_hip: 'LeftUpLeg' };
    expect(() => validateMapping(partial, bones, { requireHumanoid: false })).not.toThrow();
    expect(() => validateMapping(partial, bones)).toThrow(/r_hip.*not mapped/);
  });

  it('round-trips through JSON and refuses malformed documents', () => {
    const text = mappingToJSON(good);
    expect(JSON.parse(text).format).toBe('emdm-bone-map/1');
    expect(mappingFromJSON(text)).toEqual(good);
    expect(Object.keys(mappingFromJSON(text))).toEqual(JOINT_NAMES.filter((j) => j in good));
    expect(mappingFromJSON('{"pelvis": "Hips"}')).toEqual({ pelvis: 'Hips' });
    expect(() => mappingFromJSON('nope')).toThrow(/not JSON/);
    expect(() => mappingFromJSON('{"joints": {"pelvis": 3}}')).toThrow(/pelvis must name a bone/);
    expect(() => mappingFromJSON('{"joints": {"hand": "x"}}')).toThrow(/'hand' is not one of our joints/);
  });
});
