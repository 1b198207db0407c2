#!/usr/bin/env node
// Self-host the ONNX Runtime Web wasm binaries (no CDN): copies
//   onnxruntime-web (our direct dependency)              -> public/ort/
//   @huggingface/transformers' own nested onnxruntime-web -> public/ort-tfjs/
// Both folders are git-ignored and rebuilt from node_modules. Idempotent: a file whose size and
// mtime already match is skipped, so this is instant when nothing changed.
// Runtime code points ORT at them with `env.wasm.wasmPaths = <base>/ort/` (or `<base>/ort-tfjs/`).
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';
import { fileURLToPath } from 'node:url';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const WASM_FILE = /^ort-wasm-simd-threaded(\.[a-z]+)?\.(wasm|mjs)$/;

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

export function copyOrtInto(srcPkgDir, destDir) {
  const dist = path.join(srcPkgDir, 'dist');
  const names = fs.readdirSync(dist).filter((n) => WASM_FILE.test(n));
  if (!names.some((n) => n.endsWith('.wasm'))) {
    throw new Error(`copy-ort: no ort-wasm-simd-threaded*.wasm in ${dist}`);
  }
  fs.mkdirSync(destDir, { recursive: true });
  let copied = 0;
  for (const n of names) {
    const src = path.join(dist, n);
    const dst = path.join(destDir, n);
    const s = fs.statSync(src);
    if (fs.existsSync(dst)) {
      const d = fs.statSync(dst);
      if (d.size === s.size && Math.abs(d.mtimeMs - s.mtimeMs) < 1) continue;
    }
    fs.copyFileSync(src, dst);
    fs.utimesSync(dst, s.atime, s.mtime);
    copied++;
  }
  const version = readVersion(srcPkgDir);
  fs.writeFileSync(path.join(destDir, 'VERSION'), version + '\n');
  return { version, files: names.length, copied };
}

export function copyOrt(root = ROOT) {
  const ortDir = packageDir('onnxruntime-web', root);
  const tfjsDir = packageDir('@huggingface/transformers', root);
  const tfjsOrtDir = packageDir('onnxruntime-web', tfjsDir);
  const a = copyOrtInto(ortDir, path.join(root, 'public', 'ort'));
  const b = copyOrtInto(tfjsOrtDir, path.join(root, 'public', 'ort-tfjs'));
  return { ort: a, ortTfjs: b };
}

if (process.argv[1] && path.resolve(process.argv[1]) === fileURLToPath(import.meta.url)) {
  const r = copyOrt();
  console.log(
    `copy-ort: public/ort <- onnxruntime-web ${r.ort.version} (${r.ort.copied}/${r.ort.files} copied), ` +
      `public/ort-tfjs <- ${r.ortTfjs.version} (${r.ortTfjs.copied}/${r.ortTfjs.files} copied)`,
  );
}
