/**
 * The files a web app serves beside the library (Node only; `emdm-web/vite` and the `emdm-web` command use them):
 * ONNX Runtime's browser runtimes with the `files.json` the library verifies the .wasm with, and a models folder
 * (manifest.json and the files its `files` table lists, each checked against its size and sha256).
 */
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import { createRequire } from 'node:module';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

// The runtimes the browser loads: onnxruntime-web/wasm's (the WASM backend; transformers.js runs on it too) and, only
// when the app asks for WebGPU (`webgpu: true`), onnxruntime-web/webgpu's (.asyncify): an app without it serves ONE
// .wasm, its files.json does not list the .asyncify build, and the library then never tries WebGPU there
// (src/loadModel.ts chooseBackend). The .jsep build (the package's default entry, Node only here) and .jspi are never
// fetched: 45 MB left out. The .asyncify build runs the WASM backend too, but one file for both would cost every
// machine without WebGPU (scripts/bench/ort-wasm-bench.mjs, headless Chromium, 1 thread, 2 cores): 4.7 MB brotli to
// download instead of 2.7, ~1.1 s to the first session instead of ~0.6, and one 196-frame step of emdm-t2m-web 58 ms
// instead of 53 (int8) / 103 instead of 97 (fp32). Hence two files with WebGPU, one (the plain WASM runtime) without.
const ORT_FILE = /^ort-wasm-simd-threaded\.(wasm|mjs)$/;
const ORT_WEBGPU_FILE = /^ort-wasm-simd-threaded\.asyncify\.(wasm|mjs)$/;
const HERE = path.dirname(fileURLToPath(import.meta.url));

/** A bad models folder or file, said in one line (the command prints it and exits with status 2). */
export class AssetError extends Error {}

function sha256(bytes: Uint8Array): string {
  return createHash('sha256').update(bytes).digest('hex');
}

/** onnxruntime-web's folder, as this library resolves it (its exports map hides package.json). */
function ortDir(): string {
  const req = createRequire(path.join(HERE, 'index.js'));
  for (const base of req.resolve.paths('onnxruntime-web') ?? []) {
    const dir = path.join(base, 'onnxruntime-web');
    if (fs.existsSync(path.join(dir, 'package.json'))) return dir;
  }
  throw new AssetError(`onnxruntime-web not found from ${HERE}; install the app's dependencies`);
}

/** Which ORT runtimes an app serves: `webgpu` adds onnxruntime-web/webgpu's (.asyncify) to the WASM backend's. */
export interface OrtOptions {
  webgpu?: boolean;
}

/** ORT's browser runtime files (name → path) and the files.json (name → {bytes, sha256} of each .wasm). */
export function ortFiles({ webgpu = false }: OrtOptions = {}): { files: Map<string, string>; list: string } {
  const dist = path.join(ortDir(), 'dist');
  const wanted = (n: string) => ORT_FILE.test(n) || (webgpu && ORT_WEBGPU_FILE.test(n));
  const files = new Map(fs.readdirSync(dist).filter(wanted).sort().map((n) => [n, path.join(dist, n)]));
  const list: Record<string, { bytes: number; sha256: string }> = {};
  for (const [n, p] of files) {
    if (!n.endsWith('.wasm')) continue;
    const bytes = fs.readFileSync(p);
    list[n] = { bytes: bytes.length, sha256: sha256(bytes) };
  }
  return { files, list: JSON.stringify(list, null, 1) + '\n' };
}

/** Copy ORT's browser runtimes and files.json into `dest` (the app's `<base>ort/`); the names written. */
export function copyOrt(dest: string, options: OrtOptions = {}): string[] {
  const { files, list } = ortFiles(options);
  fs.mkdirSync(dest, { recursive: true });
  for (const [n, p] of files) fs.copyFileSync(p, path.join(dest, n));
  fs.writeFileSync(path.join(dest, 'files.json'), list);
  return [...files.keys(), 'files.json'];
}

/** manifest.json and every file its `files` table lists, relative to `dir`; `verify`: each has its listed size and
 * sha256; `browser`: only what a browser may load, without the models' `trainingWeights` (the PyTorch weights a
 * training run continues from: 22 MB no page fetches). The first problem is an AssetError naming the file. */
export function modelFiles(dir: string, verify = false, { browser = false }: { browser?: boolean } = {}): string[] {
  const man = path.join(dir, 'manifest.json');
  if (!fs.existsSync(man)) throw new AssetError(`${man} not found; the models folder is a copy of emdm-web's public/models (the models are not in the npm package)`);
  let listed: Record<string, { bytes?: number; sha256?: string }>;
  let training: string[];
  try {
    const data = JSON.parse(fs.readFileSync(man, 'utf8')) as { files?: typeof listed; models?: Record<string, { trainingWeights?: unknown }> };
    listed = data.files ?? {};
    training = Object.values(data.models ?? {}).map((m) => m?.trainingWeights).filter((f): f is string => typeof f === 'string');
  } catch (e) {
    throw new AssetError(`${man}: not JSON (${(e as Error).message})`);
  }
  if (browser) listed = Object.fromEntries(Object.entries(listed).filter(([rel]) => !training.includes(rel)));
  for (const [rel, want] of Object.entries(listed)) {
    const p = path.resolve(dir, rel);
    if (!p.startsWith(path.resolve(dir) + path.sep)) throw new AssetError(`${man}: files entry '${rel}' lies outside the folder`);
    if (!fs.existsSync(p)) throw new AssetError(`${p}: not found (listed in ${man})`);
    if (!verify) continue;
    const bytes = fs.readFileSync(p);
    if (bytes.length !== want.bytes || sha256(bytes) !== want.sha256) {
      throw new AssetError(`${p}: ${bytes.length} bytes / sha256 differ from ${man} (a changed or truncated file)`);
    }
  }
  return ['manifest.json', ...Object.keys(listed)];
}

/** The models folder's terms of use (the weights' licence and their data's attributions), not a file the manifest
 * lists: copied along where present. */
export const MODELS_TERMS = 'LICENSE.md';

/** Copy a models folder into `dest` (an app's static folder) after verifying every file (nothing is copied when one
 * is wrong): the manifest and the files a browser loads, not the training weights (`modelFiles`'s `browser`). */
export function copyModels(src: string, dest: string): string[] {
  const rels = modelFiles(src, true, { browser: true });
  if (fs.existsSync(path.join(src, MODELS_TERMS))) rels.push(MODELS_TERMS);   // the weights' licence goes with them
  for (const rel of rels) {
    fs.mkdirSync(path.dirname(path.join(dest, rel)), { recursive: true });
    fs.copyFileSync(path.join(src, rel), path.join(dest, rel));
  }
  return rels;
}
