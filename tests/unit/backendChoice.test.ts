// Which ONNX Runtime files an app serves, and the backend the library opens there (issue 32): the emdm-web/vite
// plugin writes one .wasm by default (the WASM backend's) and both with `webgpu: true`; files.json lists them, and
// src/loadModel.ts's chooseBackend never tries WebGPU when its runtime is not listed ('auto' silently, an explicit
// 'webgpu' with a notice). Headless Chromium has no WebGPU adapter, so the choice is tested here with fake lists.
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { afterAll, describe, expect, it } from 'vitest';
import { chooseBackend, type GpuState } from '../../src/loadModel';
import { type RuntimeFileList, WASM_RUNTIME_FILE, WEBGPU_RUNTIME_FILE } from '../../src/runtime/ort';
import { copyOrt, ortFiles } from '../../src/assets';
import { emdm } from '../../src/vite';

const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'emdm-backend-'));
afterAll(() => fs.rmSync(tmp, { recursive: true, force: true }));

const entry = { bytes: 1, sha256: '0'.repeat(64) };
const WASM_ONLY: RuntimeFileList = { [WASM_RUNTIME_FILE]: entry };
const BOTH: RuntimeFileList = { [WEBGPU_RUNTIME_FILE]: entry, [WASM_RUNTIME_FILE]: entry };

/** A gpu probe that answers `state` and counts its calls. */
function probe(state: GpuState) {
  const p = { calls: 0, ask: async () => (p.calls++, state) };
  return p;
}

describe('chooseBackend', () => {
  it("an app serving only the WASM runtime: 'auto' runs WASM silently, 'webgpu' with the notice, and no GPU is asked for", async () => {
    const gpu = probe('adapter');
    expect(await chooseBackend('auto', WASM_ONLY, gpu.ask)).toEqual({ backend: 'wasm' });
    const explicit = await chooseBackend('webgpu', WASM_ONLY, gpu.ask);
    expect(explicit.backend).toBe('wasm');
    expect(explicit.fallback).toMatch(/^WebGPU is not available \(this app serves only ONNX Runtime's WebAssembly runtime; emdm\(\{ webgpu: true \}\) or 'emdm-web ort --webgpu' adds WebGPU's\)$/);
    expect(gpu.calls).toBe(0);
  });

  it('an app serving both runtimes (or no list: Node, older deployments): WebGPU where an adapter is, else WASM with the reason', async () => {
    for (const served of [BOTH, null]) {
      for (const request of ['auto', 'webgpu'] as const) {
        expect(await chooseBackend(request, served, probe('adapter').ask)).toEqual({ backend: 'webgpu' });
        expect(await chooseBackend(request, served, probe('no-adapter').ask)).toEqual({ backend: 'wasm', fallback: 'WebGPU is not available (no usable GPU adapter)' });
        expect(await chooseBackend(request, served, probe('no-api').ask)).toEqual({ backend: 'wasm', fallback: 'WebGPU is not available in this browser' });
      }
    }
  });

  it("'wasm' is WASM whatever is served", async () => {
    for (const served of [WASM_ONLY, BOTH, null]) expect(await chooseBackend('wasm', served, probe('adapter').ask)).toEqual({ backend: 'wasm' });
  });
});

describe('the ORT files an app serves (src/assets.ts, the emdm-web/vite plugin)', () => {
  const wasmOf = (list: string) => Object.keys(JSON.parse(list));

  it('one .wasm by default, both with webgpu', () => {
    const one = ortFiles();
    expect([...one.files.keys()]).toEqual(['ort-wasm-simd-threaded.mjs', 'ort-wasm-simd-threaded.wasm']);
    expect(wasmOf(one.list)).toEqual([WASM_RUNTIME_FILE]);
    const both = ortFiles({ webgpu: true });
    expect([...both.files.keys()]).toEqual(['ort-wasm-simd-threaded.asyncify.mjs', 'ort-wasm-simd-threaded.asyncify.wasm',
      'ort-wasm-simd-threaded.mjs', 'ort-wasm-simd-threaded.wasm']);
    expect(wasmOf(both.list)).toEqual([WEBGPU_RUNTIME_FILE, WASM_RUNTIME_FILE]);
  });

  it("the plugin's build writes what its webgpu option asks for into <outDir>/ort/", () => {
    for (const [options, want] of [[{}, [WASM_RUNTIME_FILE]], [{ webgpu: true }, [WEBGPU_RUNTIME_FILE, WASM_RUNTIME_FILE]]] as const) {
      const out = fs.mkdtempSync(path.join(tmp, 'dist-'));
      const main = emdm(options).find((p) => p.name === 'emdm-web')!;
      (main.writeBundle as (o: { dir: string }) => void).call({}, { dir: out });
      const ort = path.join(out, 'ort');
      expect(fs.readdirSync(ort).filter((f) => f.endsWith('.wasm')).sort()).toEqual(want);
      expect(wasmOf(fs.readFileSync(path.join(ort, 'files.json'), 'utf8'))).toEqual(want);
    }
  });

  it("an app's own public/ort/ (from `npx emdm-web ort`) does not stop the build writing the models and WebGPU's runtime", () => {
    const out = fs.mkdtempSync(path.join(tmp, 'dist-'));
    copyOrt(path.join(out, 'ort'));                 // what Vite copied from the app's public/ before writeBundle
    const models = fs.mkdtempSync(path.join(tmp, 'models-'));
    fs.writeFileSync(path.join(models, 'manifest.json'), JSON.stringify({ files: {} }));
    const main = emdm({ models, webgpu: true }).find((p) => p.name === 'emdm-web')!;
    (main.buildStart as () => void).call({});
    (main.writeBundle as (o: { dir: string }) => void).call({}, { dir: out });
    expect(fs.readdirSync(path.join(out, 'ort')).filter((f) => f.endsWith('.wasm')).sort()).toEqual([WEBGPU_RUNTIME_FILE, WASM_RUNTIME_FILE]);
    expect(wasmOf(fs.readFileSync(path.join(out, 'ort', 'files.json'), 'utf8'))).toEqual([WEBGPU_RUNTIME_FILE, WASM_RUNTIME_FILE]);
    expect(fs.existsSync(path.join(out, 'models', 'manifest.json'))).toBe(true);
  });
});
