/**
 * Loading a user's character (.glb, .vrm, or .gltf with its files) safely.
 *
 * ```ts
 * const ch = await loadCharacter([{ name: file.name, data: await file.arrayBuffer() }, ...otherDroppedFiles]);
 * scene.add(ch.root);                                  // the character, at rest
 * ch.mapping, ch.unmapped                              // our 22 joints → its bones (src/character/retarget/mapping.ts)
 * ```
 *
 * - Nothing from the file is executed and nothing is fetched: before three's GLTFLoader sees it, the
 *   document is packed into ONE binary glTF whose buffers and images all live in its BIN chunk. A
 *   buffer or image URI is accepted only as a data: URI or as the name of one of the given files;
 *   anything else (http:, file:, blob:, an absolute path, a file that was not given) is refused with
 *   reason 'external-resource'. The packed document (`json`, `bin`) is what export/characterGlb.ts
 *   writes back (through export/glb.ts's writeGlb), with the animation added.
 * - Errors are CharacterLoadError with a `reason`: 'no-file', 'too-large' (> 100 MB in all, or a glTF JSON over
 *   16 MB), 'too-complex' (over 5 000 nodes, 2 000 bones or 20 000 entries of a list: src/character/retarget/check.ts),
 *   'bad-rig' (a node transform that is not finite or beyond ±1e6, bones at rest beyond 1e7 or all at one point),
 *   'corrupt' (not glTF 2.0, bad GLB chunks, views outside buffers, a loader failure), 'unsupported'
 *   (a required extension that needs a decoder: Draco, meshopt, KTX2), 'external-resource', 'no-skin'
 *   (no skinned mesh), 'not-humanoid' (the mapping lacks REQUIRED_JOINTS; `bones` and `mapping` are
 *   attached so a mapping editor can offer the rest).
 * - VRM 0.x / 1.0 (a document with the `VRM` or `VRMC_vrm` extension): read through @pixiv/three-vrm's
 *   VRMLoaderPlugin on the same GLTFLoader (loaded on demand, only for VRM files): its humanoid
 *   (`vrm.humanoid.getRawBoneNode`) gives the bone mapping, its meta the version, and the page gets its
 *   MToon materials. VRM 0.x characters face −Z at rest (what three-vrm's VRMUtils.rotateVRM0 turns
 *   round); retargetMotion measures the rest facing of every character from its hips and turns the
 *   motion onto it (RetargetResult.yaw, 180° for VRM 0.x), so the scene itself is not rotated here.
 *   `vrm` holds three-vrm's VRM object (the raw bones are the ones animated; the normalized rig and
 *   vrm.update() are not used, as they would overwrite the raw bones).
 */
import type { Object3D } from 'three';
import { GLTFLoader, type GLTF } from 'three/addons/loaders/GLTFLoader.js';
import type { VRM } from '@pixiv/three-vrm';
import { JOINT_NAMES, type JointName } from '../../skeleton';
import { type BoneInfo, type BoneMapping, MappingError, autoMap, validateMapping } from './mapping';
import { bonesOf } from './retarget';
import { type CharacterLoadReason, checkDocument, checkJsonSize, checkRestPose, type Refuse } from './check';
import { nextTask } from '../../yield';
import { CHUNK_BIN, CHUNK_JSON, GLB_MAGIC, type GltfJson, writeGlb } from '../../export/glb';

export const MAX_CHARACTER_BYTES = 100 * 1024 * 1024;

export type { CharacterLoadReason };

export class CharacterLoadError extends Error {
  constructor(
    readonly reason: CharacterLoadReason,
    readonly file: string,
    message: string,
    readonly bones?: BoneInfo[],
    readonly mapping?: BoneMapping,
  ) {
    super(`${file}: ${message}`);
    this.name = 'CharacterLoadError';
  }
}

export interface CharacterFile {
  name: string;
  data: ArrayBuffer | Uint8Array;
}

export interface LoadedCharacter {
  /** the main file's name */
  name: string;
  /** the scene (add it to yours); at rest as loaded */
  root: Object3D;
  gltf: GLTF;
  /** the packed document (everything in `bin`), what the GLB export starts from */
  json: GltfJson;
  bin: Uint8Array;
  /** the bones (skin joints) and their parents */
  bones: Object3D[];
  boneInfos: BoneInfo[];
  /** glTF node index of each loaded object that came from a node */
  nodeIndex: Map<Object3D, number>;
  mapping: BoneMapping;
  unmapped: JointName[];
  mappingSource: 'vrm' | 'names' | 'user';
  vrm: '0.x' | '1.0' | null;
  /** three-vrm's VRM object of a VRM file (meta, humanoid, materials), else null */
  vrmModel: VRM | null;
  /** milliseconds spent in loadCharacter */
  loadMs: number;
  /** put every node back to its rest transform as loaded (retargetMotion reads the rest pose from the scene) */
  restPose(): void;
}

export interface LoadCharacterOptions {
  /** a saved or edited mapping, used instead of the automatic one (validated) */
  mapping?: BoneMapping;
  /** default MAX_CHARACTER_BYTES */
  maxBytes?: number;
  /** decode textures (default: where the environment can, i.e. a browser) */
  textures?: boolean;
}

const MAIN = /\.(glb|vrm|gltf)$/i;
const NEEDS_DECODER: Record<string, string> = {
  KHR_draco_mesh_compression: 'Draco-compressed meshes',
  EXT_meshopt_compression: 'meshopt-compressed buffers',
  KHR_texture_basisu: 'KTX2/Basis textures',
  EXT_texture_webp: 'WebP-only textures',
};

const bytesOf = (d: ArrayBuffer | Uint8Array) => (d instanceof Uint8Array ? d : new Uint8Array(d));

/** Split a GLB into its JSON and BIN chunks (throws CharacterLoadError 'corrupt'). */
export function readGlb(data: Uint8Array, file: string): { json: GltfJson; bin: Uint8Array | null } {
  const bad = (why: string) => new CharacterLoadError('corrupt', file, `not a valid binary glTF: ${why}`);
  if (data.byteLength < 20) throw bad(`only ${data.byteLength} bytes`);
  const dv = new DataView(data.buffer, data.byteOffset, data.byteLength);
  if (dv.getUint32(0, true) !== GLB_MAGIC) throw bad("it does not start with 'glTF'");
  if (dv.getUint32(4, true) !== 2) throw bad(`container version ${dv.getUint32(4, true)}, expected 2`);
  const total = dv.getUint32(8, true);
  if (total > data.byteLength) throw bad(`the header says ${total} bytes, the file has ${data.byteLength} (truncated?)`);
  let off = 12;
  let json: GltfJson | null = null;
  let bin: Uint8Array | null = null;
  while (off + 8 <= total) {
    const len = dv.getUint32(off, true);
    const type = dv.getUint32(off + 4, true);
    if (off + 8 + len > total) throw bad(`chunk at byte ${off} runs past the end`);
    const body = data.subarray(off + 8, off + 8 + len);
    if (type === CHUNK_JSON && !json) {
      checkJsonSize(body.byteLength, refusing(file));
      json = parseJson(new TextDecoder().decode(body), file);
    }
    else if (type === CHUNK_BIN && !bin) bin = body;
    off += 8 + len;
  }
  if (!json) throw bad('no JSON chunk');
  return { json, bin };
}

const refusing = (file: string): Refuse => (reason, message) => new CharacterLoadError(reason, file, message);

function parseJson(text: string, file: string): GltfJson {
  let json: unknown;
  try {
    json = JSON.parse(text);
  } catch (e) {
    throw new CharacterLoadError('corrupt', file, `its glTF JSON does not parse (${(e as Error).message})`);
  }
  if (!json || typeof json !== 'object' || Array.isArray(json)) throw new CharacterLoadError('corrupt', file, 'its glTF JSON is not an object');
  const version = String((json as GltfJson).asset?.version ?? '');
  if (!version.startsWith('2.')) throw new CharacterLoadError('corrupt', file, `glTF version '${version || 'missing'}', only glTF 2.0 is read`);
  return json as GltfJson;
}

/** Base64 characters decoded per slice of decodeDataUri (~10 ms), the event loop served between slices. */
const BASE64_SLICE = 1 << 20;

/** A data: URI's bytes and type; base64 is decoded in slices with a turn of the event loop between them. */
async function decodeDataUri(uri: string, file: string): Promise<{ bytes: Uint8Array; mime: string }> {
  const comma = uri.indexOf(',');
  const head = comma < 0 ? '' : uri.slice(0, comma);
  const m = /^data:([^,;]*)((?:;[^,;]*)*?)(;base64)?$/s.exec(head);
  if (!m) throw new CharacterLoadError('corrupt', file, `malformed data: URI (${uri.slice(0, 40)}…)`);
  const undecodable = () => new CharacterLoadError('corrupt', file, `undecodable data: URI (${uri.slice(0, 40)}…)`);
  if (!m[3]) {
    try {
      return { bytes: new TextEncoder().encode(decodeURIComponent(uri.slice(comma + 1))), mime: m[1] };
    } catch {
      throw undecodable();
    }
  }
  let body = uri.slice(comma + 1);
  if (/[^A-Za-z0-9+/=]/.test(body)) body = body.replace(/[\t\n\f\r ]+/g, ''); // atob skips ASCII white space; slices must not split a quad
  const end = body.replace(/=+$/, '').length;
  const out = new Uint8Array(Math.floor((end * 3) / 4));
  let o = 0;
  for (let at = 0; at < body.length; at += BASE64_SLICE) {
    if (at) await nextTask();
    let s: string;
    try {
      s = atob(body.slice(at, at + BASE64_SLICE));
    } catch {
      throw undecodable();
    }
    if (o + s.length > out.length) throw undecodable();
    for (let i = 0; i < s.length; i++) out[o++] = s.charCodeAt(i);
  }
  return { bytes: o === out.length ? out : out.subarray(0, o), mime: m[1] };
}

const MIME: Record<string, string> = { png: 'image/png', jpg: 'image/jpeg', jpeg: 'image/jpeg', webp: 'image/webp', ktx2: 'image/ktx2' };

/**
 * One self-contained document: every buffer and image moved into a single BIN buffer. `resolve`
 * gives the bytes of a relative URI among the given files (or null).
 */
export async function packDocument(json: GltfJson, glbBin: Uint8Array | null, file: string, resolve: (uri: string) => Uint8Array | null): Promise<{ json: GltfJson; bin: Uint8Array }> {
  // copies of what is rewritten (buffers, views, images), the rest shared: a deep copy of a document with a 70 MB
  // data: URI in it held the page for over a second
  const copies = (v: unknown): GltfJson[] => (Array.isArray(v) ? v.map((x) => (x && typeof x === 'object' ? { ...x } : x)) : []);
  const doc: GltfJson = { ...json, buffers: copies(json.buffers), bufferViews: copies(json.bufferViews), images: copies(json.images) };
  if (!Array.isArray(json.images)) delete doc.images;
  const external = async (uri: string, what: string): Promise<{ bytes: Uint8Array; mime?: string }> => {
    if (uri.startsWith('data:')) return decodeDataUri(uri, file);
    if (/^[a-z][a-z0-9+.-]*:/i.test(uri) || uri.startsWith('/') || uri.startsWith('\\')) {
      throw new CharacterLoadError('external-resource', file, `${what} points to '${uri}': nothing is fetched from outside the files you give`);
    }
    const got = resolve(uri);
    if (!got) throw new CharacterLoadError('external-resource', file, `${what} refers to '${uri}', which is not among the files given; drop it together with ${file}`);
    return { bytes: got };
  };
  const parts: Uint8Array[] = [];
  let length = 0;
  const append = (b: Uint8Array): number => {
    const at = length;
    parts.push(b);
    length += b.byteLength;
    const pad = (4 - (length % 4)) % 4;
    if (pad) {
      parts.push(new Uint8Array(pad));
      length += pad;
    }
    return at;
  };
  const buffers: GltfJson[] = doc.buffers;
  const bufferStart: { at: number; len: number }[] = [];
  for (const [i, b] of buffers.entries()) {
    let bytes: Uint8Array;
    if (!b || typeof b !== 'object') throw new CharacterLoadError('corrupt', file, `buffer ${i} is not an object`);
    if (b.uri === undefined) {
      if (i !== 0 || !glbBin) throw new CharacterLoadError('corrupt', file, `buffer ${i} has no uri and there is no GLB BIN chunk for it`);
      bytes = glbBin;
    } else bytes = (await external(String(b.uri), `buffer ${i}`)).bytes;
    if (!(Number.isInteger(b.byteLength) && b.byteLength <= bytes.byteLength)) {
      throw new CharacterLoadError('corrupt', file, `buffer ${i} declares ${b.byteLength} bytes but holds ${bytes.byteLength}`);
    }
    bufferStart.push({ at: append(bytes.subarray(0, b.byteLength)), len: b.byteLength as number });
  }
  const views: GltfJson[] = doc.bufferViews;
  views.forEach((v, i) => {
    const b = v && typeof v === 'object' ? bufferStart[v.buffer] : undefined;
    const off = v.byteOffset ?? 0;
    if (!b || !(Number.isInteger(off) && Number.isInteger(v.byteLength) && off >= 0 && off + v.byteLength <= b.len)) {
      throw new CharacterLoadError('corrupt', file, `bufferView ${i} lies outside its buffer`);
    }
    v.buffer = 0;
    v.byteOffset = b.at + off;
  });
  for (const [i, img] of (Array.isArray(doc.images) ? doc.images : []).entries()) {
    if (!img || typeof img !== 'object' || img.uri === undefined) continue;
    const uri = String(img.uri);
    const { bytes, mime } = await external(uri, `image ${i}`);
    views.push({ buffer: 0, byteOffset: append(bytes), byteLength: bytes.byteLength });
    img.bufferView = views.length - 1;
    img.mimeType = img.mimeType ?? mime ?? MIME[uri.split('.').pop()!.toLowerCase()] ?? 'image/png';
    delete img.uri;
  }
  if (views.length) doc.bufferViews = views;
  else delete doc.bufferViews;
  const bin = new Uint8Array(length);
  let o = 0;
  for (const p of parts) {
    bin.set(p, o);
    o += p.byteLength;
  }
  doc.buffers = length ? [{ byteLength: length }] : [];
  if (!length) delete doc.buffers;
  return { json: doc, bin };
}

/** The JSON given to the loader when textures are not decoded (no DOM, e.g. Node): materials keep their factors. */
export function withoutTextures(json: GltfJson): GltfJson {
  const doc: GltfJson = JSON.parse(JSON.stringify(json));
  const strip = (o: unknown): void => {
    if (!o || typeof o !== 'object') return;
    for (const [k, v] of Object.entries(o as GltfJson)) {
      if (/Texture$/.test(k) && v && typeof v === 'object' && 'index' in (v as GltfJson)) delete (o as GltfJson)[k];
      else strip(v);
    }
  };
  (doc.materials ?? []).forEach(strip);
  // VRM 0.x keeps MToon textures by index in its own material list, and both versions name a thumbnail
  for (const m of doc.extensions?.VRM?.materialProperties ?? []) if (m && typeof m === 'object') m.textureProperties = {};
  if (doc.extensions?.VRM?.meta) delete doc.extensions.VRM.meta.texture;
  if (doc.extensions?.VRMC_vrm?.meta) delete doc.extensions.VRMC_vrm.meta.thumbnailImage;
  delete doc.textures;
  delete doc.images;
  delete doc.samplers;
  if (Array.isArray(doc.extensionsRequired)) doc.extensionsRequired = doc.extensionsRequired.filter((e: string) => e !== 'KHR_texture_transform');
  return doc;
}

export async function loadCharacter(files: CharacterFile[], opts: LoadCharacterOptions = {}): Promise<LoadedCharacter> {
  const t0 = performance.now();
  const main = files.find((f) => MAIN.test(f.name));
  if (!main) throw new CharacterLoadError('no-file', files.map((f) => f.name).join(', ') || '(nothing)', 'no .glb, .gltf or .vrm file among the files given');
  const file = main.name;
  const maxBytes = opts.maxBytes ?? MAX_CHARACTER_BYTES;
  const totalBytes = files.reduce((a, f) => a + f.data.byteLength, 0);
  if (totalBytes > maxBytes) {
    throw new CharacterLoadError('too-large', file, `${(totalBytes / 1048576).toFixed(1)} MB given; characters up to ${(maxBytes / 1048576).toFixed(0)} MB are read`);
  }
  const data = bytesOf(main.data);
  const isGlb = /\.(glb|vrm)$/i.test(file) || (data.byteLength >= 4 && new DataView(data.buffer, data.byteOffset, 4).getUint32(0, true) === GLB_MAGIC);
  const refuse = refusing(file);
  if (!isGlb) checkJsonSize(data.byteLength, refuse);
  const { json: raw, bin: glbBin } = isGlb ? readGlb(data, file) : { json: parseJson(new TextDecoder().decode(data), file), bin: null };
  checkDocument(raw, refuse); // counts and node transforms, before anything is built from them
  await nextTask();

  const required: string[] = Array.isArray(raw.extensionsRequired) ? raw.extensionsRequired : [];
  const needs = required.filter((e) => e in NEEDS_DECODER);
  if (needs.length) {
    throw new CharacterLoadError('unsupported', file, `it requires ${needs.map((e) => `${e} (${NEEDS_DECODER[e]})`).join(', ')}, which this page does not decode; export it without that compression`);
  }
  const byName = new Map(files.map((f) => [f.name, bytesOf(f.data)]));
  const resolve = (uri: string): Uint8Array | null => {
    let name: string;
    try {
      name = decodeURIComponent(uri);
    } catch {
      name = uri;
    }
    if (name.split(/[\\/]/).includes('..')) return null;
    return byName.get(name) ?? byName.get(name.split(/[\\/]/).pop()!) ?? null;
  };
  const { json, bin } = await packDocument(raw, glbBin, file, resolve);
  await nextTask();

  const nodes: GltfJson[] = Array.isArray(json.nodes) ? json.nodes : [];
  if (!Array.isArray(json.skins) || !json.skins.length || !nodes.some((n) => Number.isInteger(n?.skin) && Number.isInteger(n?.mesh))) {
    throw new CharacterLoadError('no-skin', file, 'it has no skinned mesh (no skin on a mesh node), so there are no bones to move; export the character with its armature/skin');
  }

  const textures = opts.textures ?? (typeof document !== 'undefined' || typeof createImageBitmap !== 'undefined');
  const forLoader = writeGlb(textures ? json : withoutTextures(json), bin);
  const isVrm = !!(json.extensions?.VRM || json.extensions?.VRMC_vrm);
  const loader = new GLTFLoader();
  if (isVrm) {
    const { VRMLoaderPlugin } = await import('@pixiv/three-vrm');
    loader.register((parser) => new VRMLoaderPlugin(parser));
  }
  let gltf: GLTF;
  try {
    gltf = await loader.parseAsync(forLoader.buffer as ArrayBuffer, '');
  } catch (e) {
    throw new CharacterLoadError('corrupt', file, `${isVrm ? 'three.js with three-vrm' : 'three.js'} could not read it (${(e as Error)?.message ?? e})`);
  }
  const vrmModel = (gltf.userData?.vrm as VRM | undefined) ?? null;
  if (isVrm && !vrmModel?.humanoid) {
    throw new CharacterLoadError('unsupported', file, `it declares a VRM extension (${json.extensions?.VRMC_vrm ? `VRMC_vrm ${json.extensions.VRMC_vrm.specVersion ?? '?'}` : 'VRM 0.x'}) that three-vrm could not read as a humanoid; re-export it as VRM 0.x or 1.0, or as a plain .glb`);
  }
  const root = gltf.scene;
  if (!root) throw new CharacterLoadError('no-skin', file, 'it has no scene to show (no scenes, or none with nodes)');
  const nodeIndex = new Map<Object3D, number>();
  for (const [obj, assoc] of gltf.parser.associations as Map<Object3D, { nodes?: number }>) {
    if (assoc && Number.isInteger(assoc.nodes) && (obj as { isObject3D?: boolean }).isObject3D) {
      nodeIndex.set(obj, assoc.nodes!);
    }
  }
  // unnamed nodes get 'node<index>' so a bone map can name them
  for (const [obj, n] of nodeIndex) if (!obj.name) obj.name = `node${n}`;
  // bones: every skin joint (GLTFLoader makes them Bones) under the scene
  const { objects: bones, infos: boneInfos } = bonesOf(root);
  if (!bones.length) throw new CharacterLoadError('no-skin', file, 'its skins have no joints in the scene');

  // VRM: three-vrm's humanoid (VRM bone name → the raw bone it animates)
  let vrmNames: Record<string, string> | undefined;
  if (vrmModel) {
    vrmNames = {};
    for (const vb of Object.keys(vrmModel.humanoid.humanBones)) {
      const o = vrmModel.humanoid.getRawBoneNode(vb as Parameters<VRM['humanoid']['getRawBoneNode']>[0]);
      if (o?.name) vrmNames[vb] = o.name;
    }
  }
  let mapping: BoneMapping;
  let mappingSource: LoadedCharacter['mappingSource'];
  if (opts.mapping) {
    mapping = { ...opts.mapping };
    mappingSource = 'user';
  } else {
    const auto = autoMap(boneInfos, vrmNames);
    mapping = auto.mapping;
    mappingSource = auto.source;
  }
  try {
    validateMapping(mapping, boneInfos);
  } catch (e) {
    if (!(e instanceof MappingError)) throw e;
    const found = Object.keys(mapping).length;
    throw new CharacterLoadError('not-humanoid', file,
      `${opts.mapping ? 'the saved bone map does not fit' : `only ${found} of our 22 joints were recognised among its ${bones.length} bones`}: ${e.message}`,
      boneInfos, mapping);
  }
  checkRestPose(root, bones, Object.values(mapping), refuse);
  const unmapped = JOINT_NAMES.filter((j) => mapping[j] === undefined);
  const rest: [Object3D, Object3D['position'], Object3D['quaternion'], Object3D['scale']][] = [];
  root.traverse((o) => rest.push([o, o.position.clone(), o.quaternion.clone(), o.scale.clone()]));
  return {
    name: file, root, gltf, json, bin, bones, boneInfos, nodeIndex, mapping, unmapped, mappingSource,
    vrm: vrmModel ? (vrmModel.meta?.metaVersion === '0' ? '0.x' : '1.0') : null, vrmModel, loadMs: performance.now() - t0,
    restPose() {
      for (const [o, p, q, s] of rest) {
        o.position.copy(p);
        o.quaternion.copy(q);
        o.scale.copy(s);
      }
      root.updateMatrixWorld(true);
    },
  };
}

