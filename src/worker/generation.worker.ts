/**
 * The generation worker (a module Web Worker): the text encoder (transformers.js), the ONNX step model
 * (ORT-web) and the whole sampler loop run here, so the page's thread only renders and handles input.
 * It speaks the protocol of ./protocol.ts; src/worker/client.ts is the page's side.
 *
 * Cancellation: each generation has an AbortController; a `cancel` message aborts it, and the sampler
 * stops at the next step boundary (the runtime yields to the event loop before every model call, so the
 * message is handled between steps, not after the loop).
 */
import { EditError } from '../edit';
import { NonFiniteMotionError } from '../errors';
import type { GenerateOptions, Motion } from '../openModel';
import { ModelFileError } from '../manifest';
import { defaultThreads } from '../runtime/ort';
import { useModelCache } from '../cache/modelCache';
import { GenerationHost } from './generationHost';
import type { FromWorker, ModelInfo, ToWorker, WireError, WirePose, WireStepPreview } from './protocol';

interface WorkerScope {
  postMessage(message: unknown, options?: { transfer?: Transferable[] }): void;
  addEventListener(type: 'message', fn: (e: MessageEvent<ToWorker>) => void): void;
  crossOriginIsolated?: boolean;
}
const scope = globalThis as unknown as WorkerScope;

function post(msg: FromWorker, transfer: Transferable[] = []): void {
  scope.postMessage(msg, { transfer });
}

function wireError(e: unknown): WireError {
  if (e instanceof ModelFileError) {
    return { name: e.name, message: e.message, stack: e.stack, path: e.path, reason: e.reason };
  }
  if (e instanceof EditError) return { name: e.name, message: e.message, stack: e.stack, segment: e.segment };
  if (e instanceof NonFiniteMotionError) {
    return { name: e.name, message: e.message, stack: e.stack, source: e.source, index: e.index, count: e.count, value: e.value };
  }
  if (e instanceof Error) return { name: e.name, message: e.message, stack: e.stack };
  return { name: 'Error', message: String(e) };
}

let host: GenerationHost | null = null;
const running = new Map<number, AbortController>();

function needHost(): GenerationHost {
  if (!host) throw new Error('generation worker: no init message before the first request (GenerationClient sends it)');
  return host;
}

function infoOf(model: string, g: Pick<ModelInfo, 'backend' | 'threads' | 'sampler' | 'batchesExactly'>): ModelInfo {
  return { model, backend: g.backend, threads: g.threads, sampler: g.sampler, ...(g.batchesExactly !== undefined ? { batchesExactly: g.batchesExactly } : {}) };
}

/** Every distinct buffer behind the arrays (a buffer listed twice makes postMessage throw). */
function buffersOf(...arrays: Array<Float32Array | undefined>): ArrayBuffer[] {
  const set = new Set<ArrayBuffer>();
  for (const a of arrays) if (a && a.buffer instanceof ArrayBuffer) set.add(a.buffer);
  return [...set];
}

/** Run request `id`'s job with a signal a `cancel` message aborts; a failure is answered as its `error`. */
async function cancellable(id: number, job: (signal: AbortSignal) => Promise<void>): Promise<void> {
  const ctrl = new AbortController();
  running.set(id, ctrl);
  try {
    await job(ctrl.signal);
  } catch (e) {
    post({ type: 'error', id, error: wireError(e) });
  } finally {
    running.delete(id);
  }
}

async function handle(msg: ToWorker): Promise<void> {
  switch (msg.type) {
    case 'init': {
      const { init } = msg;
      if (init.cache !== false) useModelCache((file) => post({ type: 'file', file }), (text) => post({ type: 'notice', kind: 'warn', text }));
      host = new GenerationHost(init, {
        download: (model, loaded, total) => post({ type: 'download', model, loaded, total }),
        fallback: (model, reason) => post({ type: 'fallback', model, reason }),
      });
      post({
        type: 'environment', crossOriginIsolated: scope.crossOriginIsolated === true, threads: init.threads ?? defaultThreads(),
        hardwareConcurrency: (globalThis as { navigator?: { hardwareConcurrency?: number } }).navigator?.hardwareConcurrency ?? 1,
      });
      return;
    }
    case 'load': {
      try {
        const g = await needHost().load(msg.model, msg.variant);
        post({ type: 'loaded', id: msg.id, info: infoOf(msg.model, g) });
      } catch (e) {
        post({ type: 'error', id: msg.id, error: wireError(e) });
      }
      return;
    }
    case 'generate':
      return cancellable(msg.id, async (signal) => {
        const h = needHost();
        const { pose: wantPose, previewSteps, ...wire } = msg.options;
        const solve = (m: Motion): WirePose => h.pose(m.joints, m.frames);
        const o: GenerateOptions = { ...wire, signal, onStep: (done, total) => post({ type: 'step', id: msg.id, done, total }) };
        if (previewSteps) {
          // each step's x̂0, decoded by generate() like the result and solved here like the result
          o.onPreview = (p) => {
            const t0 = performance.now();
            const ppose = wantPose ? solve(p.motion) : undefined;
            const preview: WireStepPreview = {
              step: p.step, steps: p.steps, frames: p.motion.frames, fps: p.motion.fps, joints: p.motion.joints, pose: ppose,
              ms: p.decodeMs + performance.now() - t0,
            };
            post({ type: 'step-preview', id: msg.id, preview }, buffersOf(p.motion.joints, ppose?.rootPos, ppose?.quats));
          };
        }
        const { gen, result, pose } = await h.generate(msg.model, o, msg.variant, wantPose);
        const transfer = buffersOf(result.motion.joints, result.motion.features, pose?.rootPos, pose?.quats);
        post({ type: 'result', id: msg.id, info: infoOf(msg.model, gen), result, pose }, transfer);
      });
    case 'begin':
      return cancellable(msg.id, async (signal) => {
        // progress: the first request's steps (they all run together)
        const os = msg.options.map((w, i) => ({ ...w, signal, ...(i === 0 ? { onStep: (done: number, total: number) => post({ type: 'step', id: msg.id, done, total }) } : {}) }));
        const { gen, states } = await needHost().begin(msg.model, os, msg.variant);
        post({ type: 'begun', id: msg.id, info: infoOf(msg.model, gen), states }, states.map((s) => s.x.buffer as ArrayBuffer));
      });
    case 'timeline':
      return cancellable(msg.id, async (signal) => {
        const { pose, ...result } = await needHost().timeline(msg.request, {
          signal,
          onWindow: (segment, done, total) => post({ type: 'timeline-window', id: msg.id, segment, done, total }),
          onStep: (done, total, together) => post({ type: 'step', id: msg.id, done, total, together }),
        }, msg.pose);
        const t = result.timeline;
        const windows = t.segments.flatMap((s) => s.windows.flatMap((w) => [w.features, w.joints]));
        post({ type: 'timeline-result', id: msg.id, result, pose }, buffersOf(t.features, t.joints, result.display, ...windows, pose?.rootPos, pose?.quats));
      });
    case 'solve': {
      try {
        const pose = needHost().pose(msg.joints, msg.frames);
        post({ type: 'solved', id: msg.id, pose }, buffersOf(pose.rootPos, pose.quats));
      } catch (e) {
        post({ type: 'error', id: msg.id, error: wireError(e) });
      }
      return;
    }
    case 'cancel': {
      const ctrl = running.get(msg.id);
      if (ctrl) {
        const reason = new Error('cancelled: a newer request replaced this one');
        reason.name = 'AbortError';
        ctrl.abort(reason);
      }
      return;
    }
    case 'dispose': {
      for (const c of running.values()) c.abort();
      await host?.dispose();
      host = null;
      post({ type: 'loaded', id: msg.id, info: { model: '', backend: 'wasm', threads: 0, sampler: 'ddgan' } });
      return;
    }
  }
}

scope.addEventListener('message', (e) => {
  void handle(e.data);
});
