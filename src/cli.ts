#!/usr/bin/env node
/**
 * `npx emdm-web`: put the files a web app serves beside the library into its static folder (for bundlers other than
 * Vite; `emdm-web/vite` does this itself).
 *
 *     npx emdm-web models <models folder> <dest>     # manifest.json + its files, each checked (sha256) first
 *     npx emdm-web ort <dest> [--webgpu]              # ONNX Runtime's WASM runtime (+ WebGPU's) + files.json
 *
 * Serve them at `<base>models/` and `<base>ort/`. A bad argument or file: one line, exit status 2.
 */
import path from 'node:path';
import { AssetError, copyModels, copyOrt } from './assets';

const USAGE = 'usage: emdm-web models <models folder> <dest> | emdm-web ort <dest> [--webgpu]';

/** `ort`'s arguments: one folder and an optional `--webgpu` (in either order), or null. */
function ortArgs(rest: string[]): { dest: string; webgpu: boolean } | null {
  const dests = rest.filter((a) => a !== '--webgpu');
  if (dests.length !== 1 || dests[0].startsWith('-') || rest.length - dests.length > 1) return null;
  return { dest: dests[0], webgpu: dests.length < rest.length };
}

export function main(argv: string[]): number {
  const [command, ...rest] = argv;
  try {
    if (command === 'models' && rest.length === 2) {
      const files = copyModels(path.resolve(rest[0]), path.resolve(rest[1]));
      console.log(`emdm-web: ${files.length} model files (verified) -> ${rest[1]}`);
    } else if (command === 'ort' && ortArgs(rest)) {
      const { dest, webgpu } = ortArgs(rest)!;
      const files = copyOrt(path.resolve(dest), { webgpu });
      console.log(`emdm-web: ${files.length} ONNX Runtime files (${webgpu ? 'WASM and WebGPU runtimes' : 'WASM runtime'}) -> ${dest}`);
    } else {
      console.error(USAGE);
      return 2;
    }
  } catch (e) {
    if (!(e instanceof AssetError)) throw e;
    console.error(`emdm-web: ${e.message}`);
    return 2;
  }
  return 0;
}

process.exitCode = main(process.argv.slice(2));
