/**
 * The messages between a page and its generation worker (src/worker/generation.worker.ts), typed on
 * both sides. The page sends requests with an `id`; the worker answers each with exactly one
 * `loaded` / `result` / `solved` / `error` of the same id, and sends events (downloads, per-step progress,
 * backend fallbacks, cache notices) as they happen. Float32Array results travel as transferred
 * buffers (no copy).
 */
import type { FileEvent } from '../cache/modelCache';
import type { GenerateResult, SampleState } from '../openModel';
import type { WireBeginOptions, WireGenerateOptions } from '../requests';
import type { TimelineRequest, TimelineResult } from './generationHost';
import type { Manifest } from '../manifest';
import type { MotionPose } from '../motion/ik';
import type { BackendRequest } from '../runtime/ort';
import type { SamplerName } from '../sampler/settings';

export type { FileEvent };

/** What the worker is set up with (once, before any other request). */
export interface WorkerInit {
  manifest: Manifest;
  /** absolute URL of the models folder (the worker resolves nothing against the page) */
  baseUrl: string;
  /** 'auto' tries WebGPU and falls back to WASM (at load and when a WebGPU run fails) */
  backend: BackendRequest;
  /** WASM threads (default: the runtime's choice for a cross-origin isolated context) */
  threads?: number;
  /** keep verified model files in Cache Storage (default true where `caches` exists) */
  cache?: boolean;
}

export type { WireBeginOptions, WireGenerateOptions } from '../requests';

export type ToWorker =
  | { type: 'init'; init: WorkerInit }
  | { type: 'load'; id: number; model: string; variant?: string }
  | { type: 'generate'; id: number; model: string; variant?: string; options: WireGenerateOptions }
  /** Start several generations together (Generator.begin): answered by `begun` with their states; `step` events count the first one's steps */
  | { type: 'begin'; id: number; model: string; variant?: string; options: WireBeginOptions[] }
  /**
   * A whole timeline in the worker (GenerationHost.timeline): answered by `timeline-result`, with `timeline-window`
   * before each window and `step` events (`together`: windows begun at once); `pose`: also solve the shown joints
   * (IK). `request.previous` is copied to the worker (the sender keeps it).
   */
  | { type: 'timeline'; id: number; request: TimelineRequest; pose?: boolean }
  /** Solve bone rotations (IK) for joints made on the page's side (a loop in place, an edit); answered by `solved` */
  | { type: 'solve'; id: number; joints: Float32Array; frames: number }
  | { type: 'cancel'; id: number }
  | { type: 'dispose'; id: number };

/** Root positions and joint rotations for the character, solved by IK in the worker (GenerationHost.pose). */
export type WirePose = MotionPose;

/** One step's prediction x̂0, decoded and solved by the same code as the result (transferred buffers). */
export interface WireStepPreview {
  /** steps done (1 … steps) */
  step: number;
  steps: number;
  frames: number;
  fps: number;
  /** frames × 22 × 3 */
  joints: Float32Array;
  pose?: WirePose;
  /** decode + IK time of this preview in the worker, ms (the cost of watching) */
  ms: number;
}

export interface ModelInfo {
  model: string;
  backend: 'webgpu' | 'wasm';
  threads: number;
  sampler: SamplerName;
  /** Generator.batchesExactly (absent in the answer to dispose) */
  batchesExactly?: boolean;
}

/** An error as it crosses the boundary; the client rebuilds ModelFileError / AbortError from it. */
export interface WireError {
  name: string;
  message: string;
  stack?: string;
  /** ModelFileError */
  path?: string;
  reason?: string;
  /** NonFiniteMotionError: what held the bad number, its index, the count and the value */
  source?: string;
  index?: number;
  count?: number;
  value?: number;
  /** EditError: the timeline segment it names (0-based), or null */
  segment?: number | null;
}

export type FromWorker =
  | { type: 'loaded'; id: number; info: ModelInfo }
  | { type: 'result'; id: number; info: ModelInfo; result: GenerateResult; pose?: WirePose }
  | { type: 'begun'; id: number; info: ModelInfo; states: SampleState[] }
  | { type: 'solved'; id: number; pose: WirePose }
  | { type: 'error'; id: number; error: WireError }
  | { type: 'step'; id: number; done: number; total: number; together?: number }
  | { type: 'timeline-window'; id: number; segment: number; done: number; total: number }
  | { type: 'timeline-result'; id: number; result: TimelineResult; pose?: WirePose }
  | { type: 'step-preview'; id: number; preview: WireStepPreview }
  | { type: 'download'; model: string; loaded: number; total: number }
  | { type: 'file'; file: FileEvent }
  | { type: 'fallback'; model: string; reason: string }
  | { type: 'notice'; kind: 'info' | 'warn'; text: string }
  | { type: 'environment'; crossOriginIsolated: boolean; threads: number; hardwareConcurrency: number };
