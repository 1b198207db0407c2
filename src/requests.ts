/**
 * A generation request as the library takes it (`MotionRequest`, `BeginRequest`) and its resolution against the
 * manifest: which model runs it (`modelFor`) and the options the generation host takes (`resolveRequest`,
 * `wireBegin`), with the manifest's defaults filled in. createGenerator, the generation worker's timeline
 * (GenerationHost.timeline) and the demo page share them, so a request means the same wherever it runs.
 */
import type { BeginOptions, GenerateOptions, SampleState } from './openModel';
import type { Manifest, ModelEntry } from './manifest';
import type { KnownMotion } from './sampler/mask';
import type { RequestSettings, SamplingSettings } from './sampler/settings';

/**
 * A request: what to generate, and how to sample it (SamplingSettings as a request gives them, each field defaulting to
 * the model's manifest entry; inpainting as `known`, which the model turns into the settings' normalised `known`).
 */
export interface MotionRequest extends Partial<RequestSettings> {
  /** text prompt (text model) */
  prompt?: string;
  /** action label: its index or its name in the action model's labels */
  action?: number | string;
  /** a model of the manifest (default: chosen by prompt / action, see above) */
  model?: string;
  /** length in seconds (default: the model's longest, maxFrames / fps); `frames` wins when given */
  seconds?: number;
  frames?: number;
  /** uint32 seed: the same seed gives the same motion on the same backend (default: random) */
  seed?: number;
  smooth?: boolean;
  footCleanup?: boolean;
  /**
   * Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"; src/edit.ts builds these for timelines,
   * in-betweening, body-part edits and loops): keep the entries of `features` (frames × 263, de-normalised: an
   * earlier result's `features`) where `keep` (`keepMask(frames, …)`) is 1 and generate the rest. The arrays are
   * copied, not taken. Kept frames after free ones decode where the known motion has them (`pinKeptRoot`).
   * `fromTime`: impose them only at the steps with t ≤ it (and the last; default every step). Not the sampler's
   * SamplingSettings `known` (normalised features): the model makes that, with `keep` and `keepFromTime`, from this.
   */
  known?: KnownMotion;
  /** finish a generation `begin` started (its state; the request as it was begun, now with `known.features`) */
  resume?: SampleState;
  onStep?: (done: number, total: number) => void;
  signal?: AbortSignal;
}

/**
 * A request to `MotionGenerator.begin` (src/edit.ts's EditBeginRequest fits it): a generation stopped before its first
 * denoising step with t ≤ `stopAt`; `keep` (with `keepFromTime`) marks what it will keep once `known` is given.
 */
export type BeginRequest = Omit<MotionRequest, 'known' | 'resume' | 'onStep' | 'signal'> & { stopAt: number } & Pick<SamplingSettings, 'keep' | 'keepFromTime'>;

/** The options of one generation as they cross to the worker (src/worker/protocol.ts): GenerateOptions without its signal, callbacks and noise source. */
export type WireGenerateOptions = Omit<GenerateOptions, 'signal' | 'onStep' | 'onPreview' | 'noise'> & {
  /** also solve the joints into bone rotations (IK) in the worker: the result carries `pose` */
  pose?: boolean;
  /**
   * Watch it denoise: after each step, send its prediction x̂0 decoded to joints (and solved to a pose
   * when `pose` is asked) as a `step-preview` message. Off by default; the result is the same either way.
   */
  previewSteps?: boolean;
};

/** A request of `begin` as it crosses: BeginOptions without its signal, callbacks and noise source. */
export type WireBeginOptions = Omit<BeginOptions, 'signal' | 'onStep' | 'noise'>;

/** The model a request runs on: `model`, else the manifest's EMDM model for the task (text for a prompt or nothing). */
export function modelFor(manifest: Manifest, req: Pick<MotionRequest, 'model' | 'action'>): string {
  if (req.model !== undefined) {
    if (!manifest.models[req.model]) throw new Error(`createGenerator: model '${req.model}' is not in the manifest (models: ${Object.keys(manifest.models).join(', ')})`);
    return req.model;
  }
  const task: ModelEntry['task'] = req.action !== undefined ? 'action' : 'text';
  const hits = Object.entries(manifest.models).filter(([, e]) => e.task === task);
  const hit = hits.find(([, e]) => (e.objective ?? 'ddgan') === 'ddgan') ?? hits[0];
  if (!hit) throw new Error(`createGenerator: the manifest has no ${task} model (models: ${Object.keys(manifest.models).join(', ') || 'none'})`);
  return hit[0];
}

function randomSeed(): number {
  return crypto.getRandomValues(new Uint32Array(1))[0];
}

/** The request as the generation host takes it (condition, frames, steps, guidance and seed filled in from the manifest). */
export function resolveRequest(manifest: Manifest, req: MotionRequest): { model: string; options: WireGenerateOptions } {
  if (req.prompt !== undefined && req.action !== undefined) throw new Error('generate: give a prompt or an action, not both');
  const model = modelFor(manifest, req);
  const entry = manifest.models[model];
  let condition: WireGenerateOptions['condition'];
  if (req.prompt !== undefined) condition = { type: 'text', text: req.prompt };
  else if (req.action !== undefined) {
    if (entry.condition.type !== 'action') throw new Error(`generate: ${model} takes a prompt, not an action (action: ${JSON.stringify(req.action)})`);
    const labels = entry.condition.labels;
    const label = typeof req.action === 'number' ? req.action : labels.indexOf(req.action);
    if (!Number.isInteger(label) || label < 0 || label >= labels.length) {
      throw new RangeError(`generate: action '${String(req.action)}' is not a label of ${model} (${labels.join(', ')}): give one of these names or its index, 0 to ${labels.length - 1}`);
    }
    condition = { type: 'action', label };
  } else condition = { type: 'none' };
  let frames = req.frames;
  if (frames === undefined) {
    if (req.seconds !== undefined && !(req.seconds > 0)) throw new RangeError(`generate: seconds must be > 0, got ${req.seconds}`);
    frames = req.seconds === undefined ? entry.maxFrames : Math.min(entry.maxFrames, Math.max(1, Math.round(req.seconds * entry.fps)));
  }
  return {
    model,
    options: {
      condition, frames, ...settingsOf(req, entry),
      seed: req.seed ?? randomSeed(), smooth: req.smooth, footCleanup: req.footCleanup,
      ...(req.known ? { known: { ...req.known, features: Float32Array.from(req.known.features), keep: Float32Array.from(req.known.keep) } } : {}),
      ...(req.resume ? { resume: req.resume } : {}),
    },
  };
}

/** A request's settings with the manifest's steps and guidance filled in (the rest, when absent, openModel's defaults). */
function settingsOf(req: Partial<RequestSettings>, entry: ModelEntry): RequestSettings {
  const { method, steps = entry.defaultSteps, guidance = entry.guidance, guidanceMinTime, x0Smoothing, speedCap } = req;
  return {
    ...(method !== undefined ? { method } : {}), steps, guidance,
    ...(guidanceMinTime !== undefined ? { guidanceMinTime } : {}), ...(x0Smoothing !== undefined ? { x0Smoothing } : {}),
    ...(speedCap !== undefined ? { speedCap } : {}),
  };
}

/**
 * `begin` for requests of several models: one `run` per model (its requests in their order, one batch), the states
 * back in the requests' order. createGenerator's begin and the demo page's timeline both group this way.
 */
export async function beginByModel<R>(reqs: readonly R[], modelOf: (r: R) => string, run: (model: string, reqs: R[]) => Promise<SampleState[]>): Promise<SampleState[]> {
  const groups = new Map<string, number[]>();
  reqs.forEach((r, i) => {
    const m = modelOf(r);
    groups.set(m, [...(groups.get(m) ?? []), i]);
  });
  const states: SampleState[] = new Array(reqs.length);
  for (const [model, at] of groups) {
    const got = await run(model, at.map((i) => reqs[i]));
    at.forEach((i, j) => (states[i] = got[j]));
  }
  return states;
}

/** A begin request as the generation host takes it (resolveRequest's options, stopped at stopAt, keeping `keep`). */
export function wireBegin(manifest: Manifest, r: BeginRequest): WireBeginOptions {
  const { stopAt, keep, keepFromTime, ...req } = r;
  const { smooth: _s, footCleanup: _f, ...wire } = resolveRequest(manifest, req).options;
  return { ...wire, stopAt, ...(keep ? { known: { keep: Float32Array.from(keep), fromTime: keepFromTime } } : {}) };
}

