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
import type { CharacterLoadReason } from './load';

/** The glTF JSON read (text .gltf, or a GLB's JSON chunk); embedded data: URIs count. Larger: refused before decoding. */
export const MAX_JSON_BYTES = 16 * 1024 * 1024;
/** Nodes of a document (a detailed VRM has ~1 000). */
export const MAX_NODES = 5000;
/** Skin joints, all skins together (a humanoid with fingers and face bones has a few hundred). */
export const MAX_BONES = 2000;
/** Entries of any other top-level list (meshes, accessors, materials, …). */
export const MAX_ENTRIES = 20000;
/** The largest absolute value of a node's translation, rotation, scale or matrix entry (millimetre rigs stay far below). */
export const MAX_TRANSFORM = 1e6;
/** The farthest a bone may lie from the origin at rest, in the file's units (after every parent's transform). */
export const MAX_REST_EXTENT = 1e7;

/** The error loadCharacter throws (passed in: this module does not import load.ts's values, so no import cycle). */
export type Refuse = (reason: CharacterLoadReason, message: string) => Error;

export function checkJsonSize(bytes: number, refuse: Refuse): void {
  if (bytes > MAX_JSON_BYTES) {
    throw refuse('too-large', `its glTF JSON is ${(bytes / 1048576).toFixed(1)} MB; up to ${MAX_JSON_BYTES / 1048576} MB is read (embedded data: URIs count): export it as .glb, or as .gltf with its .bin beside it`);
  }
}

const FIELDS: [string, number][] = [['translation', 3], ['rotation', 4], ['scale', 3], ['matrix', 16]];

/** Counts and node transforms of a parsed glTF JSON (throws refuse(...) naming the list, node and field). */
export function checkDocument(json: Record<string, unknown>, refuse: Refuse): void {
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
