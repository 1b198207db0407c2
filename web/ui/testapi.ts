// `window.emdm`: the page's test API (used by the Playwright suites and by anyone scripting the demo).
import { type Counters, emptyCounters } from './counters';
import type { PageContext } from './page-context';
import type { Produced } from './session';
import type { EditTestApi } from './timeline';
import type { LiveTestApi } from './live';
import { MAX_GUIDANCE, MAX_SECONDS, MAX_SEED, MIN_GUIDANCE, MIN_SECONDS, stepChoices, type Mode, type PageState, type StateLimits } from './state';

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
  /** request values that were clamped to what the page allows (e.g. "seconds 1000000000 → 9.8 (1–9.8 s)") */
  adjusted?: string[];
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
  /** where each character is drawn now (its posed mesh through its camera; page CSS pixels, like getBoundingClientRect): for layout checks */
  characterRects(): Array<{ x: number; y: number; width: number; height: number }>;
  /** the timeline & editing panel (web/ui/timeline.ts), once the page is ready */
  edit?: EditTestApi;
  /** live mode (web/ui/live.ts): its state, the stream's figures, the frames displayed and repeated, the prompts sent */
  live?: LiveTestApi;
}

declare global {
  interface Window {
    emdm: EmdmTestApi;
  }
}

// ---------------------------------------------------------------- request validation (pure)

/** The fields a GenerateRequest may have. */
export const REQUEST_FIELDS = ['mode', 'text', 'action', 'steps', 'seconds', 'guidance', 'seed', 'compare', 'model'] as const;

/** What checkRequest needs to know about the page (no DOM). */
export interface RequestContext {
  /** the state the controls show (fields the request leaves out keep these values) */
  current: PageState;
  limits: StateLimits;
  /** the manifest's models and their step counts (for `model`) */
  models: Record<string, { supportedSteps: number[] }>;
  /** why the compare view cannot be used in a mode ('' when it can) */
  compareUnavailable(mode: Mode): string;
}

export interface CheckedRequest {
  state: PageState;
  /** a named manifest model (the request's `model`), else undefined */
  model?: string;
  /** what was clamped, e.g. "seconds 1000000000 → 9.8 (1–9.8 s)" ('' none) */
  adjusted: string[];
}

/**
 * Check a WHOLE test-API request against the page before anything is touched: an invalid field (wrong
 * type, NaN/Infinity, seconds ≤ 0, an unknown mode/action/model/field, a step count the model has no
 * schedule for, a seed that is not a whole number 0–2³²−1, compare where it is unavailable) throws a
 * TypeError/RangeError naming the field, the value and what is allowed. Finite seconds and guidance
 * outside the sliders' ranges are clamped (as a URL's are), and `adjusted` says so.
 */
export function checkRequest(req: unknown, ctx: RequestContext): CheckedRequest {
  const where = 'window.emdm.generate';
  if (req === undefined || req === null) req = {};
  if (typeof req !== 'object' || Array.isArray(req)) throw new TypeError(`${where}: the request must be an object like { text: 'a person walks', seconds: 4 }, not ${JSON.stringify(req)}`);
  const r = req as Record<string, unknown>;
  const unknown = Object.keys(r).filter((k) => !(REQUEST_FIELDS as readonly string[]).includes(k));
  if (unknown.length) throw new TypeError(`${where}: unknown field${unknown.length > 1 ? 's' : ''} ${unknown.map((k) => `'${k}'`).join(', ')} (known: ${REQUEST_FIELDS.join(', ')})`);
  const s: PageState = { ...ctx.current };
  const adjusted: string[] = [];
  const show = (v: unknown) => (typeof v === 'string' ? `'${v}'` : typeof v === 'number' ? String(v) : JSON.stringify(v) ?? String(v));
  const str = (k: string): string | undefined => {
    const v = r[k];
    if (v === undefined) return undefined;
    if (typeof v !== 'string') throw new TypeError(`${where}: ${k} must be a string, not ${show(v)}`);
    return v;
  };
  const num = (k: string): number | undefined => {
    const v = r[k];
    if (v === undefined) return undefined;
    if (typeof v !== 'number' || !Number.isFinite(v)) throw new RangeError(`${where}: ${k} must be a finite number, not ${show(v)}`);
    return v;
  };
  const mode = str('mode');
  if (mode !== undefined) {
    if (mode !== 'text' && mode !== 'action' && mode !== 'random') throw new RangeError(`${where}: mode ${show(mode)} is not text, action or random`);
    s.mode = mode;
  }
  const text = str('text');
  if (text !== undefined) s.text = text;
  const action = str('action');
  if (action !== undefined) {
    if (!ctx.limits.actions.includes(action)) {
      throw new RangeError(`${where}: unknown action ${show(action)} (${ctx.limits.actions.length ? `actions: ${ctx.limits.actions.join(', ')}` : 'no action model is shipped'})`);
    }
    s.action = action;
  }
  // a prompt asks for a text motion, an action for that action: never the other mode's motion (a page that fell back
  // to action mode after its text model failed would run the selected action for a prompt)
  if (text !== undefined && action !== undefined && mode === undefined) throw new TypeError(`${where}: give mode 'text' or 'action' with both a text and an action`);
  if (mode === undefined && (text !== undefined || action !== undefined)) s.mode = text !== undefined ? 'text' : 'action';
  if (mode !== undefined && text !== undefined && mode !== 'text') throw new TypeError(`${where}: text is the prompt of mode 'text', not of mode ${show(mode)}`);
  if (mode !== undefined && action !== undefined && mode !== 'action') throw new TypeError(`${where}: action is for mode 'action', not mode ${show(mode)}`);
  const compare = r.compare;
  if (compare !== undefined) {
    if (typeof compare !== 'boolean') throw new TypeError(`${where}: compare must be true or false, not ${show(compare)}`);
    s.compare = compare;
  }
  const model = str('model');
  if (model !== undefined) {
    if (!ctx.models[model]) throw new RangeError(`${where}: no model '${model}' in the manifest (models: ${Object.keys(ctx.models).join(', ')})`);
    if (compare === true) throw new TypeError(`${where}: give either model or compare, not both`);
    s.compare = false;
  }
  const steps = num('steps');
  if (steps !== undefined) s.steps = steps;
  const choices = model !== undefined ? ctx.models[model].supportedSteps : stepChoices(ctx.limits, s.compare);
  if (!choices.includes(s.steps)) {
    throw new RangeError(`${where}: steps ${s.steps} is not one of ${model !== undefined ? `${model}'s ` : ''}${choices.join(', ')}`);
  }
  const seconds = num('seconds');
  if (seconds !== undefined) {
    if (seconds <= 0) throw new RangeError(`${where}: seconds must be more than 0, not ${seconds} (the motion is ${MIN_SECONDS}–${MAX_SECONDS} s long)`);
    const c = Number((Math.round(Math.min(MAX_SECONDS, Math.max(MIN_SECONDS, seconds)) / 0.05) * 0.05).toFixed(2));
    if (seconds < MIN_SECONDS || seconds > MAX_SECONDS) adjusted.push(`seconds ${seconds} → ${c} (${MIN_SECONDS}–${MAX_SECONDS} s)`);
    s.seconds = c;
  }
  const guidance = num('guidance');
  if (guidance !== undefined) {
    const c = Number(Math.min(MAX_GUIDANCE, Math.max(MIN_GUIDANCE, guidance)).toFixed(2));
    if (guidance < MIN_GUIDANCE || guidance > MAX_GUIDANCE) adjusted.push(`guidance ${guidance} → ${c} (${MIN_GUIDANCE}–${MAX_GUIDANCE})`);
    s.guidance = c;
  }
  const seed = num('seed');
  if (seed !== undefined) {
    if (!Number.isInteger(seed) || seed < 0 || seed > MAX_SEED) throw new RangeError(`${where}: seed must be a whole number 0–${MAX_SEED}, not ${seed}`);
    s.seed = seed;
  }
  if (s.compare && model === undefined) {
    const why = ctx.compareUnavailable(s.mode);
    if (why) throw new Error(`${where}: compare view unavailable: ${why}`);
  }
  return { state: s, model, adjusted };
}

// ---------------------------------------------------------------- installation

const LOADING = 'the page is still loading (await window.emdm.whenReady())';

/** What the test API reads from the page before its models are loaded (structural: no DOM classes here). */
export interface TestApiSources {
  notices: { log: Array<{ kind: string; text: string }> };
  files(): ReturnType<EmdmTestApi['files']>;
  cache: EmdmTestApi['cache'];
  /** frame times of the last ~2 s (ms) */
  frameTimes: number[];
  playback: EmdmTestApi['playback'];
  quality: EmdmTestApi['quality'];
}

/**
 * `window.emdm` as the page starts: loading, generate/compare reject until the models are there
 * (connect the rest with the returned object's fields), CSP violations collected. `finish` marks the
 * end of the cold start.
 */
export function installTestApi(src: TestApiSources): { api: EmdmTestApi; finish(state: 'ready' | 'error', error?: string): void } {
  let resolveReady!: () => void;
  const readyPromise = new Promise<void>((r) => (resolveReady = r));
  const api: EmdmTestApi = {
    ready: false,
    state: 'loading',
    error: '',
    whenReady: () => readyPromise,
    generate: () => Promise.reject(new Error(`window.emdm.generate: ${LOADING}`)),
    compare: () => Promise.reject(new Error(`window.emdm.compare: ${LOADING}`)),
    setCompare: () => {
      throw new Error(`window.emdm.setCompare: ${LOADING}`);
    },
    compareInfo: () => ({ available: false, reason: 'the page is still loading', on: false, steps: [], emdm: null, ddim: null, emdmMaxSteps: 0, panelsVisible: false, ddimCharacterVisible: false, split: false }),
    counters: emptyCounters(),
    backend: '',
    notices: () => src.notices.log.slice(),
    cspViolations: [],
    playbackFps() {
      const t = src.frameTimes;
      if (t.length < 2) return 0;
      return ((t.length - 1) * 1000) / (t[t.length - 1] - t[0]);
    },
    heapBytes() {
      const m = (performance as { memory?: { usedJSHeapSize: number } }).memory;
      return m ? m.usedJSHeapSize : null;
    },
    seek: () => undefined,
    playback: src.playback,
    quality: src.quality,
    frame: () => -1,
    startup: { manifestMs: NaN, readyMs: NaN },
    environment: null,
    files: src.files,
    previews: () => [],
    characterRects: () => [],
    cache: src.cache,
  };
  window.emdm = api;
  document.addEventListener('securitypolicyviolation', (e) => {
    api.cspViolations.push(`${e.violatedDirective}: ${e.blockedURI || 'inline'} (${e.sourceFile}:${e.lineNumber})`);
  });
  return {
    api,
    finish(state, error = '') {
      api.state = state;
      api.error = error;
      api.ready = true;
      api.startup.readyMs = performance.now();
      resolveReady();
    },
  };
}

/** Prefix an error with where it was thrown (unless it already says). */
function from(where: string, e: unknown): unknown {
  if (e instanceof Error && !e.message.startsWith('window.emdm.')) e.message = `${where}: ${e.message}`;
  return e;
}

function respond(s: PageState, p: Produced): GenerateResponse {
  return {
    state: s, frames: p.track.frames, fps: p.track.fps, joints: Array.from(p.result.motion.joints),
    timings: { ...p.result.timings, stepMs: [...p.result.timings.stepMs], ikMs: p.ikMs },
    modelCalls: p.result.modelCalls, model: p.model, sampler: p.result.sampler, steps: p.result.steps,
  };
}

/**
 * The test API once the models are known: generate/compare through the page (a request is checked
 * whole, by checkRequest and the session, before any control changes), the compare toggle, playback.
 */
export function connectTestApi(api: EmdmTestApi, page: PageContext): void {
  const { session, view, controls } = page;
  Object.defineProperty(api, 'backend', { get: () => session.backend, enumerable: true, configurable: true });
  api.generate = (req: GenerateRequest = {}) => {
    let checked: CheckedRequest;
    try {
      checked = checkRequest(req, {
        current: controls.read(), limits: session.limits, models: session.manifest.models,
        compareUnavailable: (mode) => controls.compareUnavailable(mode),
      });
      session.check(checked.state, checked.model, controls.compareUnavailable(checked.state.mode));
    } catch (e) {
      return Promise.reject(from('window.emdm.generate', e));
    }
    const s = checked.state;
    controls.set(s);
    return page.generate(s, checked.model !== undefined ? { model: checked.model } : {}).then((g) => {
      const r = respond(g.state, g.main);
      if (g.ddim) r.compare = { emdm: respond(g.state, g.main), ddim: respond(g.state, g.ddim) };
      if (checked.adjusted.length) r.adjusted = checked.adjusted;
      return r;
    });
  };
  api.compare = async (req: GenerateRequest = {}): Promise<CompareResponse> => {
    const r = await api.generate({ ...req, compare: true });
    if (!r.compare) throw new Error('window.emdm.compare: the page did not produce a comparison');
    return { state: r.state, ...r.compare };
  };
  api.setCompare = (on: boolean) => {
    const why = controls.compareUnavailable();
    if (on && why) throw new Error(`window.emdm.setCompare: compare view unavailable: ${why}`);
    controls.setCompare(on, true);
  };
  api.compareInfo = () => {
    const why = controls.compareUnavailable();
    const { text, diffusion } = session.models;
    return {
      available: why === '', reason: why, on: controls.read().compare, steps: [...session.limits.compareSteps],
      emdm: text?.name ?? null, ddim: diffusion?.name ?? null,
      emdmMaxSteps: text ? Math.max(...text.entry.supportedSteps) : 0,
      panelsVisible: !view.comparePanels.hidden, ddimCharacterVisible: view.ddimCharacter.object.visible, split: view.stage.isSplit,
    };
  };
  api.seek = (time: number, play = false) => {
    view.player.seek(time);
    view.player.playing = play;
  };
  api.frame = () => (view.player.track ? view.player.frame : -1);
  api.previews = () => view.previews.map((p) => ({ ...p, joints: [...p.joints] }));
  api.characterRects = () => view.stage.characterRects();
}
