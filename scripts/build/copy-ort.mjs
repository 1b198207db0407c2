// Self-host the ONNX Runtime Web wasm binaries (no CDN) for the test pages that scripts/build/serve-pages.mjs builds
// (the repository's pages and a consumer's app get theirs from the package's plugin, src/vite.ts, with the same
// files): copies onnxruntime-web's browser runtimes (the plain build of onnxruntime-web/wasm, which transformers.js
// runs on too, see one-ort.mjs, and the asyncify build of onnxruntime-web/webgpu) into a folder with files.json:
// {name: {bytes, sha256}} of each .wasm, which src/runtime/ort.ts uses to fetch the runtime as a verified file.
// Idempotent: a file whose size and mtime already match is skipped (and its hash kept).
// Runtime code points ORT at it with `env.wasm.wasmPaths = <base>/ort/`.
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const WASM_FILE = /^ort-wasm-simd-threaded(\.asyncify)?\.(wasm|mjs)$/;   // src/assets.ts's ORT_FILE

function packageDir(name, fromDir) {
  const req = createRequire(path.join(fromDir, 'package.json'));
  // Resolve package.json via the node_modules lookup (exports maps may hide it).
  for (const base of req.resolve.paths(name) ?? []) {
    const dir = path.join(base, name);
    if (fs.existsSync(path.join(dir, 'package.json'))) return dir;
  }
  throw new Error(`copy-ort: package '${name}' not found from ${fromDir}; run \`npm ci\` first`);
}

function readVersion(dir) {
  return JSON.parse(fs.readFileSync(path.join(dir, 'package.json'), 'utf8')).version;
}

export const FILES_JSON = 'files.json';

export function copyOrtInto(srcPkgDir, destDir) {
  const dist = path.join(srcPkgDir, 'dist');
  const names = fs.readdirSync(dist).filter((n) => WASM_FILE.test(n));
  if (!names.some((n) => n.endsWith('.wasm'))) {
    throw new Error(`copy-ort: no ort-wasm-simd-threaded*.wasm in ${dist}`);
  }
  fs.mkdirSync(destDir, { recursive: true });
  const listPath = path.join(destDir, FILES_JSON);
  let old = {};
  try {
    old = JSON.parse(fs.readFileSync(listPath, 'utf8'));
  } catch {
    old = {};
  }
  const list = {};
  let copied = 0;
  for (const n of names.sort()) {
    const src = path.join(dist, n);
    const dst = path.join(destDir, n);
    const s = fs.statSync(src);
    let same = false;
    if (fs.existsSync(dst)) {
      const d = fs.statSync(dst);
      same = d.size === s.size && Math.abs(d.mtimeMs - s.mtimeMs) < 1;
    }
    if (!same) {
      fs.copyFileSync(src, dst);
      fs.utimesSync(dst, s.atime, s.mtime);
      copied++;
    }
    if (!n.endsWith('.wasm')) continue;
    const prev = old[n];
    list[n] = same && prev?.bytes === s.size && /^[0-9a-f]{64}$/.test(prev?.sha256 ?? '')
      ? { bytes: prev.bytes, sha256: prev.sha256 }
      : { bytes: s.size, sha256: createHash('sha256').update(fs.readFileSync(dst)).digest('hex') };
  }
  const json = JSON.stringify(list, null, 1) + '\n';
  if (!fs.existsSync(listPath) || fs.readFileSync(listPath, 'utf8') !== json) fs.writeFileSync(listPath, json);
  const version = readVersion(srcPkgDir);
  const versionPath = path.join(destDir, 'VERSION');
  if (!fs.existsSync(versionPath) || fs.readFileSync(versionPath, 'utf8') !== version + '\n') fs.writeFileSync(versionPath, version + '\n');
  return { version, files: names.length, copied };
}

/** Copy the project's onnxruntime-web runtimes and files.json into `dest` (a built site's ort/). */
export function copyOrt(dest, root = ROOT) {
  return copyOrtInto(packageDir('onnxruntime-web', root), dest);
}
