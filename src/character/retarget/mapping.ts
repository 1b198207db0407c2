/**
 * Bone mapping: which bone of a user's character plays each of our 22 joints (src/skeleton.ts).
 *
 * ```ts
 * const { mapping, unmapped, source } = autoMap(bones);            // bones: { name, parent }[] (parent: index or −1)
 * validateMapping({ ...mapping, ...userEdits }, bones);          // throws MappingError saying what is wrong
 * localStorage.setItem(key, mappingToJSON(mapping));             // { format: 'emdm-bone-map/1', joints: {...} }
 * ```
 *
 * Automatic mapping reads, in this order:
 *  - a VRM humanoid (0.x `extensions.VRM.humanoid`, 1.0 `extensions.VRMC_vrm.humanoid`), passed as `vrm`
 *    (VRM bone name → our bone name; src/character/retarget/load.ts reads it from the file);
 *  - bone names of the usual conventions: Mixamo (`mixamorig:Hips`, `mixamorig1:LeftUpLeg`, three's
 *    sanitised `mixamorigHips`), Unreal (`pelvis`, `thigh_l`, `calf_l`, `foot_l`, `ball_l`, `spine_01`,
 *    `clavicle_l`, `upperarm_l`, `lowerarm_l`, `hand_l`, `neck_01`, `head`), Blender Rigify / metarig
 *    (`DEF-thigh.L`, `shin.L`, `upper_arm.L`, `spine.003`, …), VRoid (`J_Bip_L_UpperLeg`), Reallusion
 *    CC (`CC_Base_L_Thigh`, the CMU BVH rig of our data) and plain names (`Hips`, `LeftUpLeg`,
 *    `LeftLeg`, `LeftFoot`, `LeftToeBase`, `Spine1`, `LeftArm`, `LeftForeArm`, `LeftHand`, …), and rigs named
 *    after the joints (SMPL `L_Hip`, `L_Collar`, `L_Shoulder` = upper arm; our own `l_hip` … of the page's exports).
 * Limbs are found by name and must hang one below the other (a knee under its hip, …; an ankle may also
 * be a foot IK target outside the pelvis's tree, as in three.js's RobotExpressive); the pelvis is
 * the lowest common ancestor of both thighs and the neck; spine1..spine3 are taken from the bones
 * between the pelvis and the neck (spine3 = where the collars hang), so 1 to 5 spine bones all work.
 */
import { JOINT_NAMES, PARENTS, type JointName } from '../../skeleton';

/** Our joint → the character's bone name (three.js object name). Joints left out are unmapped. */
export type BoneMapping = Partial<Record<JointName, string>>;

/** A bone of the character: its name and its parent bone's index in the same list (−1: none). */
export interface BoneInfo {
  name: string;
  parent: number;
}

export class MappingError extends Error {
  constructor(message: string) {
    super(message);
    this.name = 'MappingError';
  }
}

/** Joints a character must have mapped before the motion can be put on it. */
export const REQUIRED_JOINTS: readonly JointName[] = [
  'pelvis', 'l_hip', 'r_hip', 'l_knee', 'r_knee', 'l_ankle', 'r_ankle', 'l_shoulder', 'r_shoulder', 'l_elbow', 'r_elbow',
];

/** VRM humanoid bone names (0.x and 1.0 use the same names) → our joints. */
export const VRM_BONES: Record<string, JointName> = {
  hips: 'pelvis', spine: 'spine1', chest: 'spine2', upperChest: 'spine3', neck: 'neck', head: 'head',
  leftUpperLeg: 'l_hip', leftLowerLeg: 'l_knee', leftFoot: 'l_ankle', leftToes: 'l_foot',
  rightUpperLeg: 'r_hip', rightLowerLeg: 'r_knee', rightFoot: 'r_ankle', rightToes: 'r_foot',
  leftShoulder: 'l_collar', leftUpperArm: 'l_shoulder', leftLowerArm: 'l_elbow', leftHand: 'l_wrist',
  rightShoulder: 'r_collar', rightUpperArm: 'r_shoulder', rightLowerArm: 'r_elbow', rightHand: 'r_wrist',
};

type Limb = 'hip' | 'knee' | 'ankle' | 'foot' | 'collar' | 'shoulder' | 'elbow' | 'wrist';
/** Name keys (lower case, side and separators removed) for each sided joint, by convention. */
const LIMB_KEYS: Record<Limb, string[]> = {
  hip: ['upleg', 'upperleg', 'thigh', 'hip', 'femur', 'legupper'],
  knee: ['leg', 'lowerleg', 'calf', 'shin', 'knee', 'tibia', 'leglower'],
  ankle: ['foot', 'ankle'],
  foot: ['toebase', 'toes', 'toe', 'ball', 'toe0'],
  collar: ['shoulder', 'clavicle', 'collar'],
  shoulder: ['arm', 'upperarm', 'uparm', 'humerus', 'armupper'],
  elbow: ['forearm', 'lowerarm', 'elbow', 'radius', 'armlower'],
  wrist: ['hand', 'wrist'],
};
/**
 * Rigs named after the joints (SMPL's L_Hip … L_Collar, L_Shoulder, L_Elbow, L_Wrist; our own l_hip …, as the
 * page's GLB/BVH exports; Kinect's HipLeft … ShoulderLeft): 'shoulder' is the upper arm (the collar is
 * 'collar'/'clavicle') and 'foot' hangs below 'ankle'. Recognised when both sides have hip, knee, ankle and elbow.
 */
const JOINT_NAMED_KEYS: Record<Limb, string[]> = {
  hip: ['hip', 'upleg', 'upperleg', 'thigh'],
  knee: ['knee'],
  ankle: ['ankle'],
  foot: ['foot', 'toebase', 'toes', 'toe', 'ball'],
  collar: ['collar', 'clavicle'],
  shoulder: ['shoulder', 'upperarm', 'arm'],
  elbow: ['elbow'],
  wrist: ['wrist', 'hand'],
};
const LIMB_ORDER: Limb[][] = [['hip', 'knee', 'ankle', 'foot'], ['shoulder', 'elbow', 'wrist']];
const PELVIS_KEYS = ['hips', 'hip', 'pelvis'];
const NECK_KEYS = ['neck', 'neck01', 'neck1', 'necktwist01', 'neck0'];
const HEAD_KEYS = ['head'];
/** Bones that never play a joint: helpers of other conventions (twist, IK, controls, …). */
const SKIP = /(twist|roll|ik|pole|ctrl|control|target|helper|end|nub|tip|socket|null|ORG|MCH|VIS|WGT)$/i;
const SKIP_PREFIX = /^(ORG|MCH|CTRL|VIS|WGT|IK|FK)[-_.]/i;

interface Parsed {
  side: 'l' | 'r' | null;
  key: string;
  /** a trailing number (Rigify's thigh.L.001, spine.003; Unreal's spine_02): a segment */
  num: number | null;
}

/** Split a bone name into side, key and trailing number (see the conventions above). */
export function parseBoneName(raw: string): Parsed | null {
  if (SKIP_PREFIX.test(raw)) return null;
  let s = raw.replace(/^.*[:|]/, ''); // namespaces: mixamorig:Hips, Armature|Hips
  s = s.replace(/^mixamorig\d*_?/i, '').replace(/^(DEF|CC_Base|J_Bip|Bip0?1|Bip|B)[-_ ]/i, '').replace(/^Bip0?1(?=[A-Z ])/, '');
  // tokens: split on separators and camelCase boundaries
  const tokens = s
    .replace(/([a-z])([A-Z])/g, '$1 $2')
    .replace(/([A-Z])([A-Z][a-z])/g, '$1 $2')
    .replace(/([A-Za-z])(\d)/g, '$1 $2')
    .split(/[\s_.\-]+/)
    .filter(Boolean)
    .map((t) => t.toLowerCase());
  let side: Parsed['side'] = null;
  const rest: string[] = [];
  tokens.forEach((t, i) => {
    if (i === 0 && (t === 'c' || t === 'center' || t === 'centre') && tokens.length > 1) return; // VRoid's J_Bip_C_Hips
    if (side === null && (t === 'left' || t === 'l' || (t === 'lf' && i === 0))) side = 'l';
    else if (side === null && (t === 'right' || t === 'r' || (t === 'rt' && i === 0))) side = 'r';
    else rest.push(t);
  });
  // compact forms: lThigh, Lthigh, thighL, thigh_left are covered by tokens; "LeftUpLeg" → left up leg
  let num: number | null = null;
  while (rest.length && /^\d+$/.test(rest[rest.length - 1])) num = Number(rest.pop());
  const key = rest.join('');
  if (!key || SKIP.test(key)) return null;
  return { side, key, num };
}

export interface AutoMapResult {
  mapping: BoneMapping;
  unmapped: JointName[];
  /** 'vrm' when the VRM humanoid gave the bones, else 'names' */
  source: 'vrm' | 'names';
}

/**
 * Map our joints onto `bones`. `vrm`: VRM humanoid bone name → bone name (from the file), used first.
 * Never throws: what it cannot find is listed in `unmapped` (validate before retargeting).
 */
export function autoMap(bones: BoneInfo[], vrm?: Record<string, string>): AutoMapResult {
  const index = new Map(bones.map((b, i) => [b.name, i]));
  const isAncestor = (a: number, b: number): boolean => {
    for (let p = bones[b]?.parent ?? -1; p >= 0; p = bones[p].parent) if (p === a) return true;
    return false;
  };
  const depth = (i: number): number => {
    let d = 0;
    for (let p = bones[i].parent; p >= 0; p = bones[p].parent) d++;
    return d;
  };
  const out: Partial<Record<JointName, number>> = {};

  if (vrm && Object.keys(vrm).length) {
    for (const [vb, name] of Object.entries(vrm)) {
      const j = VRM_BONES[vb];
      const i = index.get(name);
      if (j && i !== undefined) out[j] = i;
    }
    // spine joints come from the bones between hips and neck (a VRM may lack chest/upperChest)
    delete out.spine1;
    delete out.spine2;
    delete out.spine3;
    assignSpine(bones, out, isAncestor);
    return finish(bones, out, 'vrm');
  }

  const parsed = bones.map((b) => parseBoneName(b.name));
  const candidates = (keys: string[], side: 'l' | 'r' | null): number[] =>
    parsed
      .map((p, i) => [p, i] as const)
      .filter(([p]) => p && p.side === side && keys.includes(p.key))
      .sort(([pa, a], [pb, b]) => keys.indexOf(pa!.key) - keys.indexOf(pb!.key) || (pa!.num ?? -1) - (pb!.num ?? -1) || depth(a) - depth(b))
      .map(([, i]) => i);

  const jointNamed = (['l', 'r'] as const).every((side) => ['hip', 'knee', 'ankle', 'elbow'].every((k) => parsed.some((p) => p?.side === side && p.key === k)));
  const limbKeys = jointNamed ? JOINT_NAMED_KEYS : LIMB_KEYS;
  // limbs: each joint the best-named bone below the previous one of its chain
  for (const side of ['l', 'r'] as const) {
    for (const chain of LIMB_ORDER) {
      let above = -1;
      for (const limb of chain) {
        let c = candidates(limbKeys[limb], side).filter((i) => above < 0 || isAncestor(above, i));
        // a foot rigged as an IK target elsewhere in the hierarchy (not in the leg's chain)
        if (!c.length && limb === 'ankle' && above >= 0) c = candidates(limbKeys.ankle, side).filter((i) => !isAncestor(i, above) && !isAncestor(above, i));
        // among same-key bones prefer the one nearest the chain (highest), e.g. thigh.L before thigh.L.001
        const pick = c.length ? c.reduce((best, i) => (limbKeys[limb].indexOf(parsed[i]!.key) < limbKeys[limb].indexOf(parsed[best]!.key) ? i : best), c[0]) : -1;
        if (pick < 0) continue;
        out[`${side}_${limb}` as JointName] = pick;
        above = pick;
      }
    }
  }
  // collars: a collar-named bone above the upper arm
  for (const s of ['l', 'r'] as const) {
    const sh = out[`${s}_shoulder`];
    const c = candidates(limbKeys.collar, s).filter((i) => sh === undefined || isAncestor(i, sh));
    if (c.length) out[`${s}_collar`] = c[0];
  }
  const neckC = candidates(NECK_KEYS, null);
  const headC = candidates(HEAD_KEYS, null);
  if (headC.length) out.head = headC.sort((a, b) => depth(a) - depth(b))[0];
  const neck = neckC.filter((i) => out.head === undefined || isAncestor(i, out.head)).sort((a, b) => depth(a) - depth(b))[0];
  if (neck !== undefined) out.neck = neck;

  // pelvis: the lowest common ancestor of both thighs and the neck (or head / arms), else by name
  const anchors = [out.l_hip, out.r_hip, out.neck ?? out.head ?? out.l_shoulder].filter((i): i is number => i !== undefined);
  const lca = anchors.length === 3 ? commonAncestor(bones, anchors) : -1;
  if (lca >= 0) out.pelvis = lca;
  else {
    const p = candidates(PELVIS_KEYS, null)[0];
    if (p !== undefined) out.pelvis = p;
  }

  // Rigify / metarig: spine, spine.001 … spine.006 without neck/head names
  if (out.pelvis !== undefined && (out.neck === undefined || out.head === undefined)) {
    const chest = out.l_collar ?? out.l_shoulder;
    const chestParent = chest !== undefined ? bones[chest].parent : -1;
    if (chestParent >= 0) {
      // the single chain above the chest that is not an arm
      const kids = (i: number) => bones.map((b, k) => [b, k] as const).filter(([b]) => b.parent === i).map(([, k]) => k);
      const arms = new Set([out.l_collar, out.r_collar, out.l_shoulder, out.r_shoulder].filter((i) => i !== undefined));
      let cur = kids(chestParent).filter((k) => !arms.has(k) && !(parsed[k]?.side));
      if (cur.length === 1 && out.neck === undefined) out.neck = cur[0];
      let last = out.neck ?? -1;
      while (last >= 0) {
        cur = kids(last).filter((k) => !(parsed[k]?.side));
        if (cur.length !== 1) break;
        last = cur[0];
      }
      if (out.head === undefined && last >= 0 && last !== out.neck) out.head = last;
    }
  }
  assignSpine(bones, out, isAncestor);
  return finish(bones, out, 'names');
}

function commonAncestor(bones: BoneInfo[], nodes: number[]): number {
  const chain = (i: number) => {
    const c: number[] = [];
    for (let p = bones[i].parent; p >= 0; p = bones[p].parent) c.push(p);
    return c;
  };
  const first = chain(nodes[0]);
  const others = nodes.slice(1).map((n) => new Set(chain(n)));
  return first.find((a) => others.every((s) => s.has(a))) ?? -1;
}

/** spine1..3 from the bones strictly between the pelvis and the neck (spine3: where the collars hang). */
function assignSpine(bones: BoneInfo[], out: Partial<Record<JointName, number>>, isAncestor: (a: number, b: number) => boolean): void {
  const top = out.neck ?? out.head;
  if (out.pelvis === undefined || top === undefined || !isAncestor(out.pelvis, top)) return;
  const path: number[] = [];
  for (let p = bones[top].parent; p >= 0 && p !== out.pelvis; p = bones[p].parent) path.unshift(p);
  if (!path.length) return;
  const arm = out.l_collar ?? out.l_shoulder;
  let chest = path.length - 1;
  if (arm !== undefined) {
    const k = path.indexOf(bones[arm].parent);
    if (k >= 0) chest = k;
  }
  out.spine3 = path[chest];
  if (chest >= 1) out.spine1 = path[0];
  if (chest >= 2) out.spine2 = path[Math.round(chest / 2)];
}

function finish(bones: BoneInfo[], out: Partial<Record<JointName, number>>, source: AutoMapResult['source']): AutoMapResult {
  const mapping: BoneMapping = {};
  const used = new Set<number>();
  for (const j of JOINT_NAMES) {
    const i = out[j];
    if (i === undefined || used.has(i)) continue;
    used.add(i);
    mapping[j] = bones[i].name;
  }
  return { mapping, unmapped: JOINT_NAMES.filter((j) => !(j in mapping)), source };
}

/**
 * Check a mapping against the character's bones: every name exists and is used once, every mapped
 * joint hangs below its nearest mapped ancestor joint, and the REQUIRED_JOINTS are there (pass
 * `{ requireHumanoid: false }` to check a partial mapping while it is being edited).
 */
export function validateMapping(mapping: BoneMapping, bones: BoneInfo[], opts: { requireHumanoid?: boolean } = {}): void {
  const index = new Map<string, number>();
  bones.forEach((b, i) => {
    if (!index.has(b.name)) index.set(b.name, i);
  });
  const seen = new Map<string, JointName>();
  for (const [joint, name] of Object.entries(mapping) as [string, unknown][]) {
    if (!(JOINT_NAMES as readonly string[]).includes(joint)) {
      throw new MappingError(`bone map: '${joint}' is not one of our joints (${JOINT_NAMES.join(', ')})`);
    }
    if (typeof name !== 'string' || !index.has(name)) {
      throw new MappingError(`bone map: ${joint} → '${String(name)}': the character has no bone of that name`);
    }
    const prev = seen.get(name);
    if (prev) throw new MappingError(`bone map: bone '${name}' is used twice (${prev} and ${joint}); each bone can play one joint`);
    seen.set(name, joint as JointName);
  }
  const isAncestor = (a: number, b: number): boolean => {
    for (let p = bones[b].parent; p >= 0; p = bones[p].parent) if (p === a) return true;
    return false;
  };
  JOINT_NAMES.forEach((joint, j) => {
    const name = mapping[joint];
    if (name === undefined) return;
    let a = PARENTS[j];
    while (a >= 0 && mapping[JOINT_NAMES[a]] === undefined) a = PARENTS[a];
    if (a < 0) return;
    const above = JOINT_NAMES[a];
    const i = index.get(name)!;
    // an ankle may be a foot IK target outside the pelvis's tree (retargetMotion places it at the shin's end)
    const pelvis = mapping.pelvis !== undefined ? index.get(mapping.pelvis) : undefined;
    const detachedFoot = (joint === 'l_ankle' || joint === 'r_ankle') && pelvis !== undefined && !isAncestor(pelvis, i) && !isAncestor(i, pelvis) && i !== pelvis;
    if (!detachedFoot && !isAncestor(index.get(mapping[above]!)!, i)) {
      throw new MappingError(`bone map: ${joint} → '${name}' is not below ${above} → '${mapping[above]}' in the character's hierarchy; map ${joint} to a bone under '${mapping[above]}'`);
    }
  });
  if (opts.requireHumanoid !== false) {
    const missing = REQUIRED_JOINTS.filter((j) => mapping[j] === undefined);
    if (missing.length) {
      throw new MappingError(`bone map: ${missing.join(', ')} ${missing.length > 1 ? 'are' : 'is'} not mapped; a humanoid needs at least ${REQUIRED_JOINTS.join(', ')}`);
    }
  }
}

/** A mapping as JSON (the file the page exports and keeps in localStorage). */
export function mappingToJSON(mapping: BoneMapping): string {
  const joints: Record<string, string> = {};
  for (const j of JOINT_NAMES) if (mapping[j] !== undefined) joints[j] = mapping[j]!;
  return JSON.stringify({ format: 'emdm-bone-map/1', joints }, null, 1);
}

/** Read a mapping written by mappingToJSON (or a plain { joint: bone } object); throws MappingError. */
export function mappingFromJSON(text: string): BoneMapping {
  let doc: unknown;
  try {
    doc = JSON.parse(text);
  } catch (e) {
    throw new MappingError(`bone map: not JSON (${(e as Error).message})`);
  }
  const obj = (doc && typeof doc === 'object' && 'joints' in doc ? (doc as { joints: unknown }).joints : doc) as Record<string, unknown> | null;
  if (!obj || typeof obj !== 'object' || Array.isArray(obj)) throw new MappingError('bone map: expected {"format": "emdm-bone-map/1", "joints": {"pelvis": "Hips", …}}');
  const out: BoneMapping = {};
  for (const [k, v] of Object.entries(obj)) {
    if (!(JOINT_NAMES as readonly string[]).includes(k)) throw new MappingError(`bone map: '${k}' is not one of our joints (${JOINT_NAMES.join(', ')})`);
    if (typeof v !== 'string' || !v) throw new MappingError(`bone map: ${k} must name a bone (a non-empty string)`);
    out[k as JointName] = v;
  }
  return out;
}
