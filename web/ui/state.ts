// The page state (everything that determines a motion) and its URL form. Pure functions: parsing
// clamps out-of-range or malformed values to the nearest valid one and says what it changed, so a
// shared link always reproduces a motion and a bad link never breaks the page.

export type Mode = 'text' | 'action' | 'random';
export type BackendChoice = 'auto' | 'wasm' | 'webgpu';

export interface PageState {
  mode: Mode;
  text: string;
  action: string;          // action label ('' when the model has none)
  steps: number;           // one of the supported step counts
  seconds: number;         // motion length, MIN_SECONDS..MAX_SECONDS in 0.05 s (one 20 fps frame)
  guidance: number;        // classifier-free guidance scale
  seed: number;            // uint32
  backend: BackendChoice;
  /** side-by-side EMDM vs diffusion (DDIM) view (only when the manifest has a diffusion model) */
  compare: boolean;
}

/** What the loaded models allow (from the manifest). */
export interface StateLimits {
  supportedSteps: number[];
  defaultSteps: number;
  defaultGuidance: number;
  actions: string[];
  fps: number;
  maxFrames: number;
  defaultText: string;
  /** step counts of the compare view (EMDM's and the diffusion model's, merged); [] = no diffusion model */
  compareSteps: number[];
}

export const MIN_SECONDS = 1;
export const MAX_SECONDS = 9.8;
export const DEFAULT_SECONDS = 6;
export const MIN_GUIDANCE = 1;
export const MAX_GUIDANCE = 6;
export const MAX_SEED = 0xffffffff;

export interface Parsed {
  state: PageState;
  notices: string[];
}

export function defaultState(l: StateLimits, seed: number): PageState {
  return {
    mode: 'text',
    text: l.defaultText,
    action: l.actions[0] ?? '',
    steps: l.defaultSteps,
    seconds: DEFAULT_SECONDS,
    guidance: l.defaultGuidance,
    seed: seed >>> 0,
    backend: 'auto',
    compare: false,
  };
}

/** The step counts the slider offers for a state: the compare view adds the diffusion model's. */
export function stepChoices(l: Pick<StateLimits, 'supportedSteps' | 'compareSteps'>, compare: boolean): number[] {
  return compare && l.compareSteps.length ? l.compareSteps : l.supportedSteps;
}

/** Frames for a length in seconds (at least 2, at most maxFrames). */
export function framesFor(seconds: number, l: Pick<StateLimits, 'fps' | 'maxFrames'>): number {
  return Math.max(2, Math.min(l.maxFrames, Math.round(seconds * l.fps)));
}

/** The step count the EMDM model runs for a slider value: the largest it supports up to it, else its smallest (as
 * the compare view's EMDM side: 20, 50 and 100, DDIM's counts, run 10). */
export function emdmSteps(n: number, supported: number[]): number {
  const e = [...supported].sort((a, b) => a - b);
  const below = e.filter((s) => s <= n);
  return below.length ? below[below.length - 1] : e[0];
}

/** The supported step count nearest to n (ties go to the larger count). */
export function nearestSteps(n: number, supported: number[]): number {
  let best = supported[0];
  for (const s of supported) {
    if (Math.abs(s - n) < Math.abs(best - n) || (Math.abs(s - n) === Math.abs(best - n) && s > best)) best = s;
  }
  return best;
}

const round = (x: number, step: number) => Math.round(x / step) * step;
const fmt = (x: number) => String(Number(x.toFixed(3)));

/** Parse a query string (e.g. location.search) against the model limits. */
export function parseState(search: string, l: StateLimits, fallbackSeed: number): Parsed {
  const q = new URLSearchParams(search);
  const s = defaultState(l, fallbackSeed);
  const notices: string[] = [];

  const mode = q.get('mode');
  if (mode !== null) {
    if (mode === 'text' || mode === 'action' || mode === 'random') s.mode = mode;
    else notices.push(`URL mode='${mode}' is not text, action or random; using text.`);
  }
  const text = q.get('text');
  // no length limit here: the text encoder reads at most the manifest's maxTokens and the page says when it cut
  if (text !== null) s.text = text;
  const action = q.get('action');
  if (action !== null) {
    if (l.actions.includes(action)) s.action = action;
    else if (l.actions.length) notices.push(`URL action='${action}' is not an action the model knows; using '${s.action}'.`);
  }
  const num = (name: string, apply: (v: number) => void) => {
    const raw = q.get(name);
    if (raw === null) return;
    const v = Number(raw);
    if (raw.trim() === '' || !Number.isFinite(v)) notices.push(`URL ${name}='${raw}' is not a number; ignored.`);
    else apply(v);
  };
  const compare = q.get('compare');
  if (compare !== null) {
    if (compare !== '1' && compare !== '0') notices.push(`URL compare='${compare}' is not 1 or 0; ignored.`);
    else if (compare === '1' && !l.compareSteps.length) notices.push('URL compare=1: this demo ships no diffusion (DDIM) model to compare with.');
    else if (compare === '1' && s.mode === 'action') notices.push('URL compare=1: the diffusion model takes a text prompt or nothing, not an action; compare is off.');
    else s.compare = compare === '1';
  }
  num('steps', (v) => {
    const choices = stepChoices(l, s.compare);
    const n = nearestSteps(v, choices);
    if (n !== v) notices.push(`URL steps=${fmt(v)} is not supported (choices: ${choices.join(', ')}); using ${n}.`);
    s.steps = n;
  });
  num('seconds', (v) => {
    const c = round(Math.min(MAX_SECONDS, Math.max(MIN_SECONDS, v)), 0.05);
    if (Math.abs(c - v) > 1e-9 && (v < MIN_SECONDS || v > MAX_SECONDS)) {
      notices.push(`URL seconds=${fmt(v)} is outside ${MIN_SECONDS}–${MAX_SECONDS} s; using ${fmt(c)}.`);
    }
    s.seconds = Number(c.toFixed(2));
  });
  num('guidance', (v) => {
    const c = Math.min(MAX_GUIDANCE, Math.max(MIN_GUIDANCE, v));
    if (c !== v) notices.push(`URL guidance=${fmt(v)} is outside ${MIN_GUIDANCE}–${MAX_GUIDANCE}; using ${fmt(c)}.`);
    s.guidance = Number(c.toFixed(2));
  });
  num('seed', (v) => {
    const c = Math.min(MAX_SEED, Math.max(0, Math.trunc(v)));
    if (c !== v) notices.push(`URL seed=${fmt(v)} must be a whole number 0–${MAX_SEED}; using ${c}.`);
    s.seed = c;
  });
  const backend = q.get('backend');
  if (backend !== null) {
    if (backend === 'auto' || backend === 'wasm' || backend === 'webgpu') s.backend = backend;
    else notices.push(`URL backend='${backend}' is not auto, wasm or webgpu; using auto.`);
  }
  return { state: s, notices };
}

/** The URL parameters of a state (parseState reads them; stateToSearch writes them). */
export const STATE_PARAMS = ['mode', 'text', 'action', 'steps', 'seconds', 'guidance', 'seed', 'backend', 'compare'] as const;
/**
 * Page flags read elsewhere: `noauto` (no first motion on load), `quality=high` (no adaptive resolution) or `low` (the
 * lowest at once), `tl` (a
 * timeline, web/ui/timeline-url.ts), `variant` (the model file: fp32, int8, …; web/ui/engine.ts pageVariant), `threads`
 * (WASM threads, 1…16; web/ui/engine.ts pageThreads).
 */
export const PAGE_FLAGS = ['noauto', 'quality', 'tl', 'variant', 'threads'] as const;

/** The notice for URL parameters the page does not know ('' when there are none): it names them and the known ones. */
export function unknownParamsNotice(search: string): string {
  const known: readonly string[] = [...STATE_PARAMS, ...PAGE_FLAGS];
  const unknown = [...new Set([...new URLSearchParams(search).keys()])].filter((k) => !known.includes(k));
  if (!unknown.length) return '';
  const names = unknown.map((k) => `'${k}'`).join(', ');
  return `URL parameter${unknown.length > 1 ? 's' : ''} ${names} ${unknown.length > 1 ? 'are' : 'is'} not known and ignored `
    + `(known: ${known.join(', ')}${unknown.some((k) => /len|dur|time|frame/i.test(k)) ? "; the motion's length is 'seconds'" : ''}).`;
}

/** Notices for page flags with a value the page does not use (`quality` other than 'high' or 'low'). */
export function pageFlagNotices(search: string): string[] {
  const q = new URLSearchParams(search);
  const quality = q.get('quality');
  return quality !== null && quality !== 'high' && quality !== 'low'
    ? [`URL quality='${quality}' is not 'high' or 'low'; the page lowers its resolution when frames are slow.`]
    : [];
}

/** The query string for a state (only what determines the motion, plus a non-default backend). */
export function stateToSearch(s: PageState): string {
  const q = new URLSearchParams();
  q.set('mode', s.mode);
  if (s.mode === 'text') q.set('text', s.text);
  if (s.mode === 'action') q.set('action', s.action);
  q.set('steps', String(s.steps));
  q.set('seconds', String(s.seconds));
  if (s.mode !== 'random') q.set('guidance', String(s.guidance));
  q.set('seed', String(s.seed >>> 0));
  if (s.backend !== 'auto') q.set('backend', s.backend);
  if (s.compare) q.set('compare', '1');
  return `?${q.toString()}`;
}

/** A fresh random uint32 seed. */
export function randomSeed(): number {
  const a = new Uint32Array(1);
  crypto.getRandomValues(a);
  return a[0];
}
