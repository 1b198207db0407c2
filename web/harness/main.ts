// Core harness page: runs the TypeScript core in the browser exactly as in Node, for the
// determinism spec (tests/e2e/core-determinism.spec.ts) and the browser benchmark
// (scripts/bench/core-bench.mjs). Exposes window.coreHarness; no UI.
import { type Manifest, loadManifest } from '../../src/index';
import { loadModel } from '../../src/loadModel';
import { sha256Hex } from '../../src/manifest';
import type { Generator, GenerateOptions } from '../../src/openModel';
import { SeededRandom } from '../../src/sampler/rng';
import { createTextEncoder } from '../../src/text';
import { GenerationClient } from '../../src/worker/client';
import type { RequestSettings } from '../../src/sampler/settings';
import { buildTinyManifest } from '../../tests/fixtures/parity/tinyManifest';
import tinyMeanStdUrl from '../../tests/fixtures/parity/tiny.meanstd.f32?url&no-inline';
import tinyOnnxUrl from '../../tests/fixtures/parity/tiny-step.onnx?url&no-inline';

const params = new URLSearchParams(location.search);
const threads = params.has('threads') ? Number(params.get('threads')) : undefined;
const backend = (params.get('backend') ?? 'wasm') as 'wasm' | 'webgpu' | 'auto';
// ?models=<url> points the harness at another models folder (the benchmark serves one at /bench-models/)
const MODELS = params.get('models') ?? `${import.meta.env.BASE_URL}models/`;
// ?via=worker runs generate() in the page's generation worker (src/worker) instead of on this thread
const VIA_WORKER = params.get('via') === 'worker';

/** A harness request: the model and what to generate, sampled with its SamplingSettings (no inpainting here). */
export interface HarnessRequest extends RequestSettings {
  /** 'tiny' / 'tiny-ddim' (the parity fixture's tiny step model, DDGAN / DDIM) or a shipped model name */
  model: string;
  /** a manifest variant of the model (e.g. 'int8'); default its fp32 file */
  variant?: string;
  condition: GenerateOptions['condition'];
  frames: number;
  seed: number;
}

const dirOf = (u: string) => u.slice(0, u.lastIndexOf('/') + 1);
const baseOf = (u: string) => u.slice(u.lastIndexOf('/') + 1);

/** An in-memory manifest for the tiny fixture model (an 8-label action model). */
async function tinyManifest(): Promise<{ manifest: Manifest; baseUrl: string }> {
  if (dirOf(tinyOnnxUrl) !== dirOf(tinyMeanStdUrl)) throw new Error('harness: tiny fixture files are served from different folders');
  const [onnx, ms] = await Promise.all([tinyOnnxUrl, tinyMeanStdUrl].map(async (u) => new Uint8Array(await (await fetch(u)).arrayBuffer())));
  const real = await loadManifest(MODELS);
  const manifest = buildTinyManifest(
    real.skeleton,
    { path: baseOf(tinyOnnxUrl), bytes: onnx.byteLength, sha256: await sha256Hex(onnx) },
    { path: baseOf(tinyMeanStdUrl), bytes: ms.byteLength, sha256: await sha256Hex(ms) },
  );
  return { manifest, baseUrl: dirOf(tinyOnnxUrl) };
}

/** A generator whose every call runs in a generation worker (one worker per manifest, no model cache). */
async function workerGenerator(manifest: Manifest, baseUrl: string, model: string, variant?: string): Promise<Generator> {
  const client = new GenerationClient({ manifest, baseUrl, backend, threads, cache: false });
  const info = await client.load(model, variant);
  return {
    modelName: model, backend: info.backend, threads: info.threads, entry: manifest.models[model], sampler: info.sampler, batchesExactly: info.batchesExactly ?? true,
    generate: ({ signal, onStep, noise, onPreview, ...o }) => {
      if (noise) throw new Error('harness: a custom noise source cannot cross to the worker');
      if (onPreview) throw new Error('harness: step previews are not wired through the worker here (use GenerationClient with previewSteps)');
      return client.generate(model, { ...o, signal, onStep }, variant);
    },
    begin: (os) => {
      if (os.some((o) => o.noise)) throw new Error('harness: a custom noise source cannot cross to the worker');
      return client.begin(model, os.map(({ signal: _s, onStep: _o, noise: _n, ...o }) => o), variant, os[0]?.signal, os[0]?.onStep);
    },
    dispose: () => client.dispose(),
  };
}

const generators = new Map<string, Promise<Generator>>();
function generatorFor(model: string, variant?: string): Promise<Generator> {
  const key = `${model}|${variant ?? ''}`;
  let g = generators.get(key);
  if (!g) {
    g = (async () => {
      const { manifest, baseUrl } = model === 'tiny' || model === 'tiny-ddim' ? await tinyManifest() : { manifest: await loadManifest(MODELS), baseUrl: MODELS };
      if (VIA_WORKER) return workerGenerator(manifest, baseUrl, model, variant);
      return loadModel({ manifest, baseUrl, model, variant, backend, threads });
    })();
    generators.set(key, g);
    g.catch(() => generators.delete(key));
  }
  return g;
}

const hex = (a: Float32Array) => sha256Hex(new Uint8Array(a.buffer, a.byteOffset, a.byteLength));

const harness = {
  info() {
    return { crossOriginIsolated: globalThis.crossOriginIsolated === true, requestedThreads: threads ?? null, backend, hardwareConcurrency: navigator.hardwareConcurrency, viaWorker: VIA_WORKER };
  },
  /** First n seeded normals (float32), to compare the RNG bit for bit with Node. */
  rng(seed: number, n: number): number[] {
    return Array.from(new SeededRandom(seed).normals(n));
  },
  /** The text encoder's embedding of a prompt (to compare Node and Chromium bit for bit). */
  async encode(text: string, encoderId?: string) {
    const enc = await createTextEncoder(await loadManifest(MODELS), MODELS, encoderId);
    const v = await enc.encode(text);
    return { sha256: await hex(v), values: Array.from(v) };
  },
  async generate(req: HarnessRequest) {
    const { model, variant, ...options } = req;
    const gen = await generatorFor(model, variant);
    const r = await gen.generate(options);
    return {
      featuresSha256: await hex(r.motion.features),
      jointsSha256: await hex(r.motion.joints),
      joints: Array.from(r.motion.joints.subarray(0, 66)),
      modelCalls: r.modelCalls,
      timings: r.timings,
    };
  },
  /** ms per step and per motion at each step count (after two warm-up generations). */
  async bench(req: { model: string; variant?: string; condition: GenerateOptions['condition']; frames: number; stepCounts: number[]; guidance: number; reps: number }) {
    const gen = await generatorFor(req.model, req.variant);
    const out: { steps: number; msPerStep: number; msPerMotion: number; modelCalls: number }[] = [];
    // warm-up: V8 tiers WASM up (Liftoff → TurboFan) over the first runs
    for (let i = 0; i < 2; i++) await gen.generate({ condition: req.condition, frames: req.frames, steps: Math.max(...req.stepCounts), guidance: req.guidance, seed: 1 });
    for (const steps of req.stepCounts) {
      const totals: number[] = [];
      const perStep: number[] = [];
      let calls = 0;
      for (let i = 0; i < req.reps; i++) {
        const r = await gen.generate({ condition: req.condition, frames: req.frames, steps, guidance: req.guidance, seed: 100 + i });
        totals.push(r.timings.totalMs);
        perStep.push(...r.timings.stepMs);
        calls = r.modelCalls;
      }
      const median = (a: number[]) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
      out.push({ steps, msPerStep: median(perStep), msPerMotion: median(totals), modelCalls: calls });
    }
    return { backend: gen.backend, threads: gen.threads, results: out };
  },
};

declare global {
  interface Window {
    coreHarness: typeof harness & { ready: boolean };
  }
}
window.coreHarness = Object.assign(harness, { ready: true });
document.getElementById('status')!.textContent = `ready (${JSON.stringify(harness.info())})`;
