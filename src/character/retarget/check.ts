/**
 * What a dropped character file may make the page do, checked before the costly steps of loadCharacter
 * (src/character/retarget/load.ts): a bounded glTF JSON, bounded counts of nodes and bones, node transforms
 * that are finite and of sane size, and (once loaded) bones at finite, sane rest positions. A hostile file
 * (100 000 bones, 1e308 translations) is refused with one line naming what was wrong and where, before three.js
 * builds it or the page offers its bones, instead of freezing the page or leaving a character that never moves.
 *
 * ```ts
 * checkJsonSize(chunk.byteLength, file);   // before decoding the JSON text
 * checkDocument(json, file);               // after JSON.parse, before packing and three.js
 * checkRestPose(bones, mappedNames, file); // after three.js built the scene (world positions at rest)
 * ```
 */
import type { Object3D } from 'three';
import { Vector3 } from 'three';

/** The glTF JSON read (text .gltf, or a GLB's JSON chunk); embedded data: URIs count. Larger: refused before decoding. */
export const MAX_JSON_BYTES = 16 * 1024 * 1024;
/** Nodes of a document (a detailed VRM has ~1 000). */
export const MAX_NODES = 5000;
/** Skin joints, all skins together (a humanoid with fingers and face bones has a few hundred). */
export const MAX_BONES = 2000;
/** Entries of any other top-level list (meshes, accessors, materials, …). */
export const MAX_ENTRIES = 20000;
/** Nesting of the JSON (a glTF is ~10 deep; JSON.stringify and any recursive walk overflow the stack at a few thousand). */
export const MAX_DEPTH = 100;
/** The largest absolute value of a node's translation, rotation, scale or matrix entry (millimetre rigs stay far below). */
export const MAX_TRANSFORM = 1e6;
/** The farthest a bone may lie from the origin at rest, in the file's units (after every parent's transform). */
export const MAX_REST_EXTENT = 1e7;

/** Why loadCharacter refused a file (CharacterLoadError.reason; declared here, where most are decided, so that
 * load.ts imports this module and not the other way round). */
export type CharacterLoadReason = 'no-file' | 'too-large' | 'too-complex' | 'corrupt' | 'unsupported' | 'external-resource' | 'no-skin' | 'bad-rig' | 'not-humanoid';

/** The error loadCharacter throws (passed in: this module does not import load.ts, so no import cycle). */
export type Refuse = (reason: CharacterLoadReason, message: string) => Error;

export function checkJsonSize(bytes: number, refuse: Refuse): void {
  if (bytes > MAX_JSON_BYTES) {
    throw refuse('too-large', `its glTF JSON is ${(bytes / 1048576).toFixed(1)} MB; up to ${MAX_JSON_BYTES / 1048576} MB is read (embedded data: URIs count): export it as .glb, or as .gltf with its .bin beside it`);
  }
}

const FIELDS: [string, number][] = [['translation', 3], ['rotation', 4], ['scale', 3], ['matrix', 16]];

/** Counts and node transforms of a parsed glTF JSON (throws refuse(...) naming the list, node and field). */
export function checkDocument(json: Record<string, unknown>, refuse: Refuse): void {
  const depth = nesting(json, MAX_DEPTH);
  if (depth > MAX_DEPTH) throw refuse('corrupt', `its glTF JSON nests more than ${MAX_DEPTH} levels deep; a glTF needs about 10`);
  checkShapes(json, refuse);
  const nodes = Array.isArray(json.nodes) ? json.nodes : [];
  if (nodes.length > MAX_NODES) throw refuse('too-complex', `it has ${nodes.length} nodes; characters of up to ${MAX_NODES} nodes are read`);
  const skins = Array.isArray(json.skins) ? json.skins : [];
  const bones = skins.reduce((a: number, s) => a + (Array.isArray((s as { joints?: unknown })?.joints) ? (s as { joints: unknown[] }).joints.length : 0), 0);
  if (bones > MAX_BONES) throw refuse('too-complex', `its skins have ${bones} bones; characters of up to ${MAX_BONES} bones are read`);
  for (const [key, list] of Object.entries(json)) {
    if (Array.isArray(list) && list.length > MAX_ENTRIES) throw refuse('too-complex', `its '${key}' list has ${list.length} entries; up to ${MAX_ENTRIES} are read`);
  }
  nodes.forEach((n, i) => {
    if (!n || typeof n !== 'object') return;
    for (const [field, len] of FIELDS) {
      const v = (n as Record<string, unknown>)[field];
      if (v === undefined) continue;
      const where = `node ${i}${typeof (n as { name?: unknown }).name === 'string' ? ` ('${((n as { name: string }).name).slice(0, 40)}')` : ''} ${field}`;
      if (!Array.isArray(v) || v.length !== len) throw refuse('bad-rig', `${where} must be a list of ${len} numbers`);
      const bad = v.find((x) => typeof x !== 'number' || !Number.isFinite(x) || Math.abs(x) > MAX_TRANSFORM);
      if (bad !== undefined) throw refuse('bad-rig', `${where} holds ${String(bad)}; every value must be a finite number within ±${MAX_TRANSFORM.toExponential(0)}`);
    }
  });
}

const LISTS = ['accessors', 'animations', 'buffers', 'bufferViews', 'cameras', 'images', 'materials', 'meshes', 'nodes', 'samplers', 'scenes', 'skins', 'textures'];
const COMPONENT_TYPES = new Set([5120, 5121, 5122, 5123, 5125, 5126]);
const ACCESSOR_TYPES = new Set(['SCALAR', 'VEC2', 'VEC3', 'VEC4', 'MAT2', 'MAT3', 'MAT4']);
/** The most elements of an accessor (a character's largest mesh has well under a million vertices). */
export const MAX_ACCESSOR_COUNT = 1 << 24;
/** References three.js's GLTFLoader follows: [list, field, list it points into, whether the field is a list of them]. */
const REFS: [string, string, string, boolean][] = [
  ['nodes', 'children', 'nodes', true], ['nodes', 'mesh', 'meshes', false], ['nodes', 'skin', 'skins', false], ['nodes', 'camera', 'cameras', false],
  ['skins', 'joints', 'nodes', true], ['skins', 'skeleton', 'nodes', false], ['skins', 'inverseBindMatrices', 'accessors', false],
  ['scenes', 'nodes', 'nodes', true], ['accessors', 'bufferView', 'bufferViews', false], ['bufferViews', 'buffer', 'buffers', false],
  ['images', 'bufferView', 'bufferViews', false], ['textures', 'source', 'images', false], ['textures', 'sampler', 'samplers', false],
];

/**
 * The document's shape where three.js's GLTFLoader trusts it: its lists are lists of objects with string names,
 * references are indices into their lists, accessors have a known type and a bounded count, the nodes form trees
 * (one parent each, no cycle). A file that breaks one gets a message, not a TypeError from inside the loader, an
 * endless walk or a huge allocation.
 */
function checkShapes(json: Record<string, unknown>, refuse: Refuse): void {
  const bad = (what: string) => refuse('corrupt', `not a valid glTF: ${what}`);
  const list = (k: string): Record<string, unknown>[] => (Array.isArray(json[k]) ? (json[k] as Record<string, unknown>[]) : []);
  const isIndex = (v: unknown, into: string) => Number.isInteger(v) && (v as number) >= 0 && (v as number) < list(into).length;
  for (const k of LISTS) {
    if (json[k] === undefined) continue;
    if (!Array.isArray(json[k])) throw bad(`'${k}' is not a list`);
    list(k).forEach((e, i) => {
      if (!e || typeof e !== 'object' || Array.isArray(e)) throw bad(`${k}[${i}] is not an object`);
      if (e.name !== undefined && typeof e.name !== 'string') throw bad(`${k}[${i}].name is not a string`);
    });
  }
  for (const [from, field, into, many] of REFS) {
    list(from).forEach((e, i) => {
      const v = e[field];
      if (v === undefined) return;
      if (many ? !Array.isArray(v) || !v.every((x) => isIndex(x, into)) : !isIndex(v, into)) throw bad(`${from}[${i}].${field} does not point into '${into}'`);
    });
  }
  list('accessors').forEach((a, i) => {
    if (!COMPONENT_TYPES.has(a.componentType as number)) throw bad(`accessors[${i}].componentType ${String(a.componentType).slice(0, 20)} is not a glTF component type`);
    if (!ACCESSOR_TYPES.has(a.type as string)) throw bad(`accessors[${i}].type ${String(a.type).slice(0, 20)} is not a glTF accessor type`);
    if (!(Number.isInteger(a.count) && (a.count as number) >= 0 && (a.count as number) <= MAX_ACCESSOR_COUNT)) throw bad(`accessors[${i}].count ${String(a.count).slice(0, 20)} is not a count of up to ${MAX_ACCESSOR_COUNT}`);
    if (a.byteOffset !== undefined && !(Number.isInteger(a.byteOffset) && (a.byteOffset as number) >= 0)) throw bad(`accessors[${i}].byteOffset is not a byte offset`);
  });
  list('meshes').forEach((m, i) => {
    if (!Array.isArray(m.primitives) || !m.primitives.every((p: unknown) => p && typeof p === 'object' && !Array.isArray(p))) throw bad(`meshes[${i}].primitives is not a list of objects`);
    (m.primitives as Record<string, unknown>[]).forEach((p, j) => {
      const attrs = p.attributes;
      if (!attrs || typeof attrs !== 'object' || !Object.values(attrs).every((x) => isIndex(x, 'accessors'))) throw bad(`meshes[${i}].primitives[${j}].attributes do not point into 'accessors'`);
      if (p.indices !== undefined && !isIndex(p.indices, 'accessors')) throw bad(`meshes[${i}].primitives[${j}].indices does not point into 'accessors'`);
    });
  });
  // the nodes form trees: one parent each and no cycle (a loop of children would be walked without end)
  const parent = new Int32Array(list('nodes').length).fill(-1);
  list('nodes').forEach((n, i) => {
    for (const c of (n.children as number[] | undefined) ?? []) {
      if (parent[c] !== -1 || c === i) throw bad(`node ${c} has more than one parent (or is its own child)`);
      parent[c] = i;
    }
  });
  parent.forEach((_, i) => {
    for (let p = parent[i], steps = 0; p !== -1; p = parent[p]) if (++steps > parent.length) throw bad(`node ${i} is its own ancestor (the children lists form a cycle)`);
  });
}

/** How deep `v` nests (lists and objects), counted without recursion; stops counting past `limit`. */
function nesting(v: unknown, limit: number): number {
  let deepest = 0;
  const todo: [unknown, number][] = [[v, 1]];
  while (todo.length) {
    const [x, d] = todo.pop()!;
    if (x === null || typeof x !== 'object') continue;
    if (d > deepest) deepest = d;
    if (deepest > limit) return deepest;
    for (const y of Array.isArray(x) ? x : Object.values(x)) if (y !== null && typeof y === 'object') todo.push([y, d + 1]);
  }
  return deepest;
}

/**
 * The bones at rest (their world positions, as three.js placed them): finite, within MAX_REST_EXTENT of the
 * origin, and the mapped ones not all at one point (a rig scaled to nothing gives no direction to turn a bone to).
 */
export function checkRestPose(root: Object3D, bones: readonly Object3D[], mapped: readonly string[], refuse: Refuse): void {
  root.updateMatrixWorld(true);
  const p = new Vector3();
  const at = new Map<string, Vector3>();
  for (const b of bones) {
    p.setFromMatrixPosition(b.matrixWorld);
    if (![p.x, p.y, p.z].every((x) => Number.isFinite(x) && Math.abs(x) <= MAX_REST_EXTENT)) {
      throw refuse('bad-rig', `bone '${b.name}' lies at (${[p.x, p.y, p.z].map((x) => x.toPrecision(3)).join(', ')}) at rest; its transforms (or its parents') must keep it finite and within ${MAX_REST_EXTENT.toExponential(0)} of the origin`);
    }
    at.set(b.name, p.clone());
  }
  const pts = mapped.map((n) => at.get(n)).filter((v): v is Vector3 => !!v);
  let extent = 0;
  for (const a of pts) extent = Math.max(extent, a.distanceTo(pts[0]));
  if (pts.length > 1 && !(extent > 1e-6)) throw refuse('bad-rig', `its ${pts.length} mapped bones all lie at one point at rest (a scale of 0?); the rig has no shape to move`);
}
