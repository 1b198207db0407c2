// `window.emdm`: the page's test API (used by the Playwright suites and by anyone scripting the demo).
import type { Mode, PageState } from './state';

export interface GenerateRequest {
  mode?: Mode;
  text?: string;
  action?: string;
  steps?: number;
  seconds?: number;
  guidance?: number;
  seed?: number;
  /** turn the compare view on/off for this and later generations (text and random modes) */
  compare?: boolean;
  /** generate with this manifest model alone (e.g. 'diffusion-t2m-web' for a benchmark), steps from its supportedSteps */
  model?: string;
}

export interface GenerateResponse {
  state: PageState;
  frames: number;
  fps: number;
  /** frames × 22 × 3 joint positions, metres */
  joints: number[];
  timings: { encodeMs: number; stepMs: number[]; decodeMs: number; ikMs: number; totalMs: number; backend: string; threads: number };
  modelCalls: number;
  /** the model that made this motion, its sampler ('ddgan' | 'ddim') and the steps it ran */
  model: string;
  sampler: string;
  steps: number;
  /** compare view: both panels' motions (the response itself describes the EMDM one) */
  compare?: { emdm: GenerateResponse; ddim: GenerateResponse };
}

/** The compare view's two motions: EMDM (left character) and DDIM (right), same prompt, seed and length. */
export interface CompareResponse {
  state: PageState;
  emdm: GenerateResponse;
  ddim: GenerateResponse;
}

export interface CompareInfo {
  /** whether the compare toggle can be used now, and why not ('' when it can) */
  available: boolean;
  reason: string;
  /** the toggle is on */
  on: boolean;
  /** the slider's step counts in compare mode ([] without a diffusion model) */
  steps: number[];
  emdm: string | null;
  ddim: string | null;
  /** EMDM runs at most this many steps (the slider's larger values run DDIM only at them) */
  emdmMaxSteps: number;
  panelsVisible: boolean;
  ddimCharacterVisible: boolean;
  /** the 3-D view is split: EMDM in the left half, DDIM in the right */
  split: boolean;
}

export interface Counters {
  /** generations requested (UI or API) */
  requests: number;
  /** generations that finished and are on screen */
  generations: number;
  /** generations cancelled because a newer one started */
  cancelled: number;
  /** generations that failed (bad model output, load errors) */
  errors: number;
  /** ONNX step-model calls of finished generations (a guided step batches both passes in one call) */
  modelCalls: number;
  /** denoising steps run, including those of cancelled generations */
  stepsRun: number;
}

export interface EmdmTestApi {
  ready: boolean;
  state: 'loading' | 'ready' | 'error';
  /** why the page (or a model) could not load, '' when fine */
  error: string;
  whenReady(): Promise<void>;
  generate(req?: GenerateRequest): Promise<GenerateResponse>;
  /** generate in the compare view (turns it on): EMDM and DDIM side by side */
  compare(req?: GenerateRequest): Promise<CompareResponse>;
  /** the compare toggle, as a user would flip it (throws, saying why, when it is unavailable) */
  setCompare(on: boolean): void;
  compareInfo(): CompareInfo;
  counters: Counters;
  /** backend in use once a model is loaded */
  backend: string;
  /** notices shown so far */
  notices(): Array<{ kind: string; text: string }>;
  /** CSP violations reported by the browser (must stay empty) */
  cspViolations: string[];
  /** frames drawn per second over the last ~2 s */
  playbackFps(): number;
  /** Chromium's performance.memory.usedJSHeapSize, or null elsewhere */
  heapBytes(): number | null;
  /** playback control for tests: pause at a time (seconds) */
  seek(time: number, play?: boolean): void;
  /** the playback clock: seconds, playing, speed, duration */
  playback(): { time: number; playing: boolean; speed: number; duration: number };
  /** rendering quality now (lowered automatically when frames are slow, unless ?quality=high) */
  quality(): { pixelRatio: number; shadows: boolean };
  /** index of the frame on screen (fractional), -1 before the first motion */
  frame(): number;
  /** timings of the cold start, ms since navigation start */
  startup: { manifestMs: number; readyMs: number };
  /** where the generation worker runs (null until it reports): isolated or not, ORT's WASM threads */
  environment: { crossOriginIsolated: boolean; threads: number; hardwareConcurrency: number } | null;
  /** the last state of each model file loaded this visit ('cache' = read from Cache Storage), `at` = when (ms) */
  files(): Array<{ path: string; state: string; cached: boolean; total: number; at: number }>;
  /** the model cache (Cache Storage): its size, and clearing it (as the page's button does) */
  cache: { usage(): Promise<{ files: number; bytes: number }>; clear(): Promise<void> };
  /** "Show steps": the step previews of the last generation as they arrived (x̂0 joints, worker decode + IK ms, arrival time, put on the character) */
  previews(): Array<{ step: number; steps: number; frames: number; joints: number[]; ms: number; at: number; played: boolean }>;
}

declare global {
  interface Window {
    emdm: EmdmTestApi;
  }
}

export function emptyCounters(): Counters {
  return { requests: 0, generations: 0, cancelled: 0, errors: 0, modelCalls: 0, stepsRun: 0 };
}
