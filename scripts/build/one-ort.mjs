// One ONNX Runtime (a Vite/Rolldown plugin for scripts/build/serve-pages.mjs, plain Node; src/vite.ts has the same for
// the pages and consumers).
// transformers.js (the text encoder) imports 'onnxruntime-web', which npm resolves to its own nested,
// older build with another 21 MB .wasm; resolve it to the project's `onnxruntime-web/wasm` instead,
// the very module src/runtime/ort.ts loads, so the text encoder and the step models share one ORT
// instance, one .wasm download and compile, and one thread pool. (Node, vitest: transformers.js runs
// on onnxruntime-node and is not bundled.) Add it to `worker.plugins` too for worker bundles.
import path from 'node:path';
import { fileURLToPath } from 'node:url';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');

/** @returns {import('vite').Plugin} */
export function oneOnnxRuntime(root = ROOT) {
  const ours = path.join(root, 'src', 'runtime', 'ort.ts');
  return {
    name: 'emdm-one-onnxruntime',
    enforce: 'pre',
    async resolveId(source, importer) {
      if (source !== 'onnxruntime-web' || !importer || !importer.split(path.sep).join('/').includes('/@huggingface/transformers/')) return null;
      const hit = await this.resolve('onnxruntime-web/wasm', ours, { skipSelf: true });
      if (!hit) throw new Error(`emdm-one-onnxruntime: cannot resolve the project's onnxruntime-web/wasm for ${importer}; run \`npm ci\``);
      return hit;
    },
  };
}
