/**
 * The model manifest (`public/models/manifest.json`, schema in docs/MANIFEST.md) and verified
 * downloads: every file a runtime fetches is checked against the size and sha256 the manifest
 * lists, and a mismatch is refused with a ModelFileError naming the file.
 *
 * `baseUrl` is the models folder: in the browser a URL (`'/models/'`, resolved against the page);
 * in Node a `file://` URL or a filesystem path (read with node:fs, since Node's fetch has no file:).
 */

import type { Skeleton } from './skeleton';

/** The `skeleton` block: the 22-joint rig and the motion format (src/skeleton.ts). */
export type { Skeleton };

export interface TextEncoderEntry {
  kind: 'minilm' | 'clip';
  dim: number;
  pooling?: 'mean' | 'eos';
  normalize?: boolean;
  maxTokens?: number;
  /** folder (relative to the models dir) in transformers.js layout */
  dir: string;
  /** transformers.js dtype of the ONNX file: 'q8' → onnx/model_quantized.onnx, 'fp32' → onnx/model.onnx */
  dtype?: 'q8' | 'fp32';
  files: string[];
  [extra: string]: unknown;
}

export interface Schedule {
  time: number[];
  coef1: number[];
  coef2: number[];
  sigma: number[];
}

export type ModelCondition =
  | { type: 'text'; encoder: string; dim: number }
  | { type: 'action'; labels: string[]; dim: number }
  | { type: 'none'; dim: number };

export interface ModelEntry {
  task: 'text' | 'action' | 'none';
  condition: ModelCondition;
  onnx: string;
  /** training objective: 'ddgan' (EMDM, sampled with the posterior; the default) or 'diffusion' (sampled with DDIM) */
  objective?: 'ddgan' | 'diffusion';
  variants?: Record<string, string>;
  /**
   * the variant (a key of `variants`) the page and createGenerator run unless asked for another ('fp32' = the
   * `onnx` file); absent = fp32. Set where the variant's quality matches fp32 (docs/MODELS.md "Speed in the browser").
   */
  defaultVariant?: string;
  meanStd: string;
  zDim: number;
  featureDim: number;
  fps: number;
  maxFrames: number;
  guidance: number;
  /** guide only the steps whose time is above this (guidance in a limited interval); absent = every step */
  guidanceMinTime?: number;
  /** σ (frames) of x̂0's smoothing along time at every denoising step but the last; absent = none */
  x0Smoothing?: number;
  /** the sampler's root speed cap: each motion at most this multiple of its first step's conditional root speed; absent = none */
  speedCap?: number;
  defaultSteps: number;
  supportedSteps: number[];
  schedules: Record<string, Schedule>;
  preset?: Record<string, number>;
  training?: Record<string, unknown>;
  files: string[];
  [extra: string]: unknown;
}

export interface FileEntry {
  bytes: number;
  sha256: string;
}

export interface Manifest {
  schema: 1;
  skeleton: Skeleton;
  textEncoders: Record<string, TextEncoderEntry>;
  models: Record<string, ModelEntry>;
  files: Record<string, FileEntry>;
}

export type ModelFileErrorReason = 'missing' | 'sha256' | 'incompatible' | 'network';

/** A model file could not be used: `path` (relative to the models folder) and why. */
export class ModelFileError extends Error {
  readonly path: string;
  readonly reason: ModelFileErrorReason;
  constructor(path: string, reason: ModelFileErrorReason, message: string) {
    super(`${path}: ${message}`);
    this.name = 'ModelFileError';
    this.path = path;
    this.reason = reason;
  }
}

export const MANIFEST_FILE = 'manifest.json';
export const SCHEMA_VERSION = 1;

const IS_NODE =
  typeof process !== 'undefined' && !!(process as { versions?: { node?: string } }).versions?.node && typeof window === 'undefined';

/** Join the models folder and a relative path ('a/' + 'b/c' → 'a/b/c'). */
export function joinUrl(baseUrl: string, rel: string): string {
  if (!baseUrl) return rel;
  return (baseUrl.endsWith('/') ? baseUrl : baseUrl + '/') + rel.replace(/^\/+/, '');
}

function isFileLocation(url: string): boolean {
  if (url.startsWith('file:')) return true;
  // In Node a scheme-less location is a filesystem path.
  return IS_NODE && !/^[a-z][a-z0-9+.-]*:/i.test(url);
}

async function readLocalFile(url: string, path: string): Promise<ArrayBuffer> {
  const fsName = 'node:fs/promises';
  const urlName = 'node:url';
  const fs = (await import(/* @vite-ignore */ fsName)) as typeof import('node:fs/promises');
  const { fileURLToPath } = (await import(/* @vite-ignore */ urlName)) as typeof import('node:url');
  const filePath = url.startsWith('file:') ? fileURLToPath(url) : url;
  try {
    const buf = await fs.readFile(filePath);
    return buf.buffer.slice(buf.byteOffset, buf.byteOffset + buf.byteLength) as ArrayBuffer;
  } catch (e) {
    const code = (e as { code?: string }).code;
    if (code === 'ENOENT') throw new ModelFileError(path, 'missing', `not found at ${filePath}`);
    throw new ModelFileError(path, 'network', `cannot read ${filePath}: ${(e as Error).message}`);
  }
}

async function readBody(res: Response, onProgress?: (loaded: number, total: number) => void): Promise<ArrayBuffer> {
  const total = Number(res.headers.get('content-length') ?? 0);
  if (!onProgress || !res.body) return res.arrayBuffer();
  const reader = res.body.getReader();
  const chunks: Uint8Array[] = [];
  let loaded = 0;
  for (;;) {
    const { done, value } = await reader.read();
    if (done) break;
    chunks.push(value);
    loaded += value.byteLength;
    onProgress(loaded, total || loaded);
  }
  const out = new Uint8Array(loaded);
  let o = 0;
  for (const c of chunks) {
    out.set(c, o);
    o += c.byteLength;
  }
  return out.buffer;
}

/** Fetch raw bytes of `path` under `baseUrl` (no verification). */
export async function fetchBytes(
  baseUrl: string,
  path: string,
  onProgress?: (loaded: number, total: number) => void,
): Promise<ArrayBuffer> {
  const url = joinUrl(baseUrl, path);
  if (isFileLocation(url)) {
    const buf = await readLocalFile(url, path);
    onProgress?.(buf.byteLength, buf.byteLength);
    return buf;
  }
  let res: Response;
  try {
    res = await fetch(url);
  } catch (e) {
    throw new ModelFileError(path, 'network', `cannot fetch ${url}: ${(e as Error).message}`);
  }
  if (res.status === 404 || res.status === 410) {
    throw new ModelFileError(path, 'missing', `not found at ${url} (HTTP ${res.status}); put the file there (from a copy of emdm-web's public/models folder) or fix the models URL`);
  }
  if (!res.ok) throw new ModelFileError(path, 'network', `fetching ${url} failed: HTTP ${res.status} ${res.statusText}`);
  if (!isHtmlPath(path) && /^\s*text\/html\b/i.test(res.headers.get('content-type') ?? '')) {
    await res.body?.cancel().catch(() => undefined);
    throw missingAsHtml(path, url, res.status);
  }
  return readBody(res, onProgress);
}

const isHtmlPath = (path: string) => /\.html?$/i.test(path);

/**
 * Whether bytes start like an HTML page (`<!doctype html`, `<html`, `<head`, `<body`, `<script`, after
 * whitespace or a BOM): what a server that answers every unknown path with its index.html sends
 * instead of a model file, a JSON file or a weight blob, none of which starts with '<'.
 */
export function looksLikeHtml(data: ArrayBuffer | Uint8Array): boolean {
  const view = data instanceof Uint8Array ? data : new Uint8Array(data);
  const head = new TextDecoder('utf-8', { fatal: false }).decode(view.subarray(0, 256)).replace(/^\uFEFF/, '').trimStart().toLowerCase();
  return /^<(!doctype html|html|head|body|script|meta|title)\b/.test(head);
}

function missingAsHtml(path: string, url: string, status?: number): ModelFileError {
  return new ModelFileError(
    path, 'missing',
    `not found at ${url}: the server answered with an HTML page${status ? ` (HTTP ${status})` : ''} instead of the file, as a single-page-app ` +
      `fallback answers a path it does not have; put the file there (from a copy of emdm-web's public/models folder) or fix the models URL`,
  );
}

/** Lower-case hex sha256 of the bytes (WebCrypto: browsers and Node ≥ 20). */
export async function sha256Hex(data: ArrayBuffer | Uint8Array): Promise<string> {
  const subtle = globalThis.crypto?.subtle;
  if (!subtle) {
    throw new Error('sha256: crypto.subtle is unavailable (the page must be served from localhost or https)');
  }
  const view = data instanceof Uint8Array ? data : new Uint8Array(data);
  const digest = await subtle.digest('SHA-256', view as Uint8Array<ArrayBuffer>);
  return Array.from(new Uint8Array(digest), (b) => b.toString(16).padStart(2, '0')).join('');
}

function fail(field: string, msg: string): never {
  throw new ModelFileError(MANIFEST_FILE, 'incompatible', `field '${field}' ${msg}`);
}

function isObject(v: unknown): v is Record<string, unknown> {
  return typeof v === 'object' && v !== null && !Array.isArray(v);
}

/** Bounds on the sizes a manifest sets (emdm.manifest has the same): denoising steps, a model's frames, x̂0 smoothing σ. */
export const MAX_STEPS = 1000;
export const MAX_MODEL_FRAMES = 1000;
export const MAX_X0_SMOOTHING = 50;

/** A path the manifest names stays inside the models folder: '/'-separated names, none '', '.' or '..', no ':' or '\\'. */
function checkRelPath(rel: unknown, field: string): void {
  const ok = typeof rel === 'string' && rel.length <= 1024 && !/[\\:\0]/.test(rel) &&
    rel.split('/').every((p) => p !== '' && p !== '.' && p !== '..');
  if (!ok) fail(field, `is ${JSON.stringify(rel)?.slice(0, 100)}; it must be a relative path inside the models folder (names separated by '/', no '..', '.', leading '/' or ':')`);
}

function isIntIn(v: unknown, lo: number, hi: number): boolean {
  return typeof v === 'number' && Number.isInteger(v) && v >= lo && v <= hi;
}

/** Structural check of a parsed manifest; throws ModelFileError naming the first bad field. */
export function validateManifest(data: unknown): Manifest {
  if (!isObject(data)) fail('(root)', 'must be a JSON object');
  if (data.schema !== SCHEMA_VERSION) fail('schema', `is ${JSON.stringify(data.schema)}, this app reads schema ${SCHEMA_VERSION}`);
  for (const key of ['skeleton', 'textEncoders', 'models', 'files'] as const) {
    if (!isObject(data[key])) fail(key, 'must be an object');
  }
  const files = data.files as Record<string, unknown>;
  for (const [rel, meta] of Object.entries(files)) {
    checkRelPath(rel, `files["${rel}"]`);
    if (!isObject(meta)) fail(`files["${rel}"]`, 'must be {bytes, sha256}');
    if (typeof meta.bytes !== 'number' || !Number.isInteger(meta.bytes) || meta.bytes < 0) {
      fail(`files["${rel}"].bytes`, 'must be a non-negative integer');
    }
    if (typeof meta.sha256 !== 'string' || !/^[0-9a-f]{64}$/.test(meta.sha256)) {
      fail(`files["${rel}"].sha256`, 'must be 64 lower-case hex digits');
    }
  }
  for (const section of ['textEncoders', 'models'] as const) {
    for (const [name, entry] of Object.entries(data[section] as Record<string, unknown>)) {
      if (!isObject(entry)) fail(`${section}.${name}`, 'must be an object');
      if (!Array.isArray(entry.files)) fail(`${section}.${name}.files`, 'must be a list of paths');
      for (const f of entry.files as unknown[]) {
        if (typeof f !== 'string' || !(f in files)) {
          fail(`${section}.${name}.files`, `names ${JSON.stringify(f)}, which is not listed under 'files'`);
        }
      }
      for (const key of ['onnx', 'meanStd', 'trainingWeights', 'dir']) {
        if (entry[key] !== undefined) checkRelPath(entry[key], `${section}.${name}.${key}`);
      }
      if (entry.variants !== undefined) {
        if (!isObject(entry.variants)) fail(`${section}.${name}.variants`, 'must be an object of files');
        for (const [v, rel] of Object.entries(entry.variants)) checkRelPath(rel, `${section}.${name}.variants.${v}`);
      }
    }
  }
  for (const [name, entry] of Object.entries(data.models as Record<string, Record<string, unknown>>)) {
    const g = entry.guidanceMinTime;
    if (g !== undefined && !(typeof g === 'number' && Number.isFinite(g) && g >= 0)) {
      fail(`models.${name}.guidanceMinTime`, `is ${JSON.stringify(g)}; it must be a time ≥ 0 (guide only steps whose time is above it), or absent to guide every step`);
    }
    const sm = entry.x0Smoothing;
    if (sm !== undefined && !(typeof sm === 'number' && Number.isFinite(sm) && sm >= 0 && sm <= MAX_X0_SMOOTHING)) {
      fail(`models.${name}.x0Smoothing`, `is ${JSON.stringify(sm)}; it must be a σ ≥ 0 in frames, at most ${MAX_X0_SMOOTHING} (smooth x̂0 along time at every step but the last), or absent for none`);
    }
    const cap = entry.speedCap;
    if (cap !== undefined && !(typeof cap === 'number' && Number.isFinite(cap) && cap >= 0)) {
      fail(`models.${name}.speedCap`, `is ${JSON.stringify(cap)}; it must be a multiple ≥ 0 of the first step's root speed (hold each motion to it; 0 = off), or absent for none`);
    }
    const steps = entry.supportedSteps;
    if (steps !== undefined && !(Array.isArray(steps) && steps.length > 0 && steps.every((t) => isIntIn(t, 1, MAX_STEPS)))) {
      fail(`models.${name}.supportedSteps`, `is ${JSON.stringify(steps)?.slice(0, 80)}; it must be a list of step counts in 1…${MAX_STEPS}`);
    }
    if (entry.defaultSteps !== undefined && !isIntIn(entry.defaultSteps, 1, MAX_STEPS)) {
      fail(`models.${name}.defaultSteps`, `is ${JSON.stringify(entry.defaultSteps)}; it must be a step count in 1…${MAX_STEPS}`);
    }
    if (entry.maxFrames !== undefined && !isIntIn(entry.maxFrames, 1, MAX_MODEL_FRAMES)) {
      fail(`models.${name}.maxFrames`, `is ${JSON.stringify(entry.maxFrames)}; it must be a frame count in 1…${MAX_MODEL_FRAMES}`);
    }
    const d = entry.defaultVariant;
    const have = isObject(entry.variants) ? Object.keys(entry.variants) : [];
    if (d !== undefined && !(typeof d === 'string' && have.includes(d))) {
      fail(`models.${name}.defaultVariant`, `is ${JSON.stringify(d)}; it must name one of the model's variants (${have.join(', ') || 'none'}), or be absent to run the fp32 file`);
    }
  }
  for (const [name, entry] of Object.entries(data.textEncoders as Record<string, Record<string, unknown>>)) {
    if (entry.kind !== 'minilm' && entry.kind !== 'clip') fail(`textEncoders.${name}.kind`, `is ${JSON.stringify(entry.kind)}, expected "minilm" or "clip"`);
    if (typeof entry.dim !== 'number' || entry.dim <= 0) fail(`textEncoders.${name}.dim`, 'must be a positive number');
    if (typeof entry.dir !== 'string') fail(`textEncoders.${name}.dir`, 'must be a folder path');
  }
  return data as unknown as Manifest;
}

/**
 * Which file of `model` runs: the one place that decides. `requested` 'fp32' → the `onnx` file (undefined is
 * returned), a key of the entry's `variants` → that variant, undefined → the entry's `defaultVariant` (absent: fp32).
 * The result is what openModel, the generation worker and the harness take as `variant` (undefined = fp32 file).
 */
export function chooseVariant(manifest: Manifest, model: string, requested?: string): string | undefined {
  const entry = manifest.models[model];
  if (!entry) throw new Error(`model '${model}' is not in the manifest (models: ${Object.keys(manifest.models).join(', ') || 'none'})`);
  const v = requested ?? entry.defaultVariant;
  if (v === undefined || v === 'fp32') return undefined;
  const have = Object.keys(entry.variants ?? {});
  if (!have.includes(v)) throw new Error(`model '${model}' has no '${v}' file (its variants: ${have.join(', ') || 'none'}); use 'fp32' or one of those`);
  return v;
}

/** The ONNX file `model` runs with `chooseVariant`'s answer for `requested` (a path in the models folder). */
export function stepFileOf(manifest: Manifest, model: string, requested?: string): string {
  const v = chooseVariant(manifest, model, requested);
  return v === undefined ? manifest.models[model].onnx : manifest.models[model].variants![v];
}

/** Fetch and validate `<baseUrl>manifest.json` (the root of trust: it is not itself hashed). */
export async function loadManifest(baseUrl: string): Promise<Manifest> {
  const buf = await fetchBytes(baseUrl, MANIFEST_FILE);
  let data: unknown;
  try {
    data = JSON.parse(new TextDecoder().decode(buf));
  } catch (e) {
    if (looksLikeHtml(buf)) throw missingAsHtml(MANIFEST_FILE, joinUrl(baseUrl, MANIFEST_FILE));
    throw new ModelFileError(MANIFEST_FILE, 'incompatible', `not valid JSON: ${(e as Error).message}`);
  }
  return validateManifest(data);
}

/** What verification needs of a manifest: its file list (a manifest, or another list such as ORT's files.json). */
export type FileTable = Pick<Manifest, 'files'>;

/** Check bytes already in hand against the manifest's size and sha256 for `path`. */
export async function verifyBytes(manifest: FileTable, path: string, data: ArrayBuffer): Promise<void> {
  const meta = manifest.files[path];
  if (!meta) throw new ModelFileError(path, 'missing', `not listed in ${MANIFEST_FILE} 'files'; refusing an unverified file`);
  // a file that is not what the manifest lists and is an HTML page: the server does not have the file
  const html = () => !isHtmlPath(path) && looksLikeHtml(data);
  const htmlInstead = () => new ModelFileError(path, 'missing', `is an HTML page (${data.byteLength} bytes), not the file: the server answered a path it does not have with a web page; put the file there or fix the models URL`);
  if (data.byteLength !== meta.bytes) {
    if (html()) throw htmlInstead();
    throw new ModelFileError(path, 'sha256', `size ${data.byteLength} bytes differs from the manifest's ${meta.bytes}; the file is corrupt or from another build (re-download or re-export it)`);
  }
  const got = await sha256Hex(data);
  if (got !== meta.sha256) {
    if (html()) throw htmlInstead();
    throw new ModelFileError(path, 'sha256', `sha256 ${got} differs from the manifest's ${meta.sha256}; the file is corrupt or from another build (re-download or re-export it)`);
  }
}

type Progress = (loaded: number, total: number) => void;

/**
 * Something standing in front of the network for fetchVerified (the browser's model cache,
 * src/cache/modelCache.ts): it returns verified bytes for `path`, from where it keeps them or from
 * `network(progress)`, which downloads and verifies them.
 */
export type VerifiedFileSource = (
  baseUrl: string, manifest: FileTable, path: string, onProgress: Progress | undefined, network: (onProgress?: Progress) => Promise<ArrayBuffer>,
) => Promise<ArrayBuffer>;

let fileSource: VerifiedFileSource | null = null;

/** Route every fetchVerified of this JS context through `source` (null: straight to the network). */
export function setVerifiedFileSource(source: VerifiedFileSource | null): void {
  fileSource = source;
}

/** Fetch `path` (relative to the models folder) and verify it against the manifest. */
export async function fetchVerified(
  baseUrl: string,
  manifest: FileTable,
  path: string,
  onProgress?: Progress,
): Promise<ArrayBuffer> {
  if (!manifest.files[path]) {
    throw new ModelFileError(path, 'missing', `not listed in ${MANIFEST_FILE} 'files'; refusing an unverified file`);
  }
  const total = manifest.files[path].bytes;
  const network = async (progress: Progress | undefined = onProgress) => {
    const data = await fetchBytes(baseUrl, path, progress ? (loaded) => progress(loaded, total) : undefined);
    await verifyBytes(manifest, path, data);
    return data;
  };
  return fileSource ? fileSource(baseUrl, manifest, path, onProgress, network) : network();
}
