/**
 * What a shipped model does well: `capabilities-<model>.json` beside the manifest, built from the coverage benchmark by
 * `python -m emdm.eval.capabilities` (its doc says how; docs/MODELS.md "Reproduce" when a model ships).
 *
 * ```ts
 * const caps = await loadCapabilities(manifest, baseUrl, 'emdm-t2m-web');   // null when the model has none
 * caps?.actions.filter((a) => !a.covered);                                  // what it does not do yet
 * checkPrompt(caps!, embedding);   // {known: false, score: 0.83, action: 'hop', covered: false, nearest: [...]}
 * ```
 *
 * The check: the file's anchors (int8) are well-covered benchmark prompts and training captions of the covered actions,
 * and benchmark prompts and training captions of the uncovered ones. A prompt is *known* when its closest anchor is of a
 * covered action and their cosine is at least `check.threshold` (calibrated on held-apart paraphrases); otherwise it is
 * *unknown*, and `action` names the uncovered action it reads as where that is the closest. The suggestions are the
 * closest well-covered prompts, one per action (for a prompt read as an uncovered action with a close covered relative,
 * closest to the prompt and that action together: `RELATED`). Python computes the same (emdm.prompt_check).
 * The file is verified like a model file when the manifest lists it; an unlisted one is read and checked for shape,
 * and one built for another encoder file is ignored (its embeddings would be stale).
 */
import { type Manifest, ModelFileError, fetchBytes, fetchVerified } from './manifest';

export interface ActionCapability {
  label: string;
  /** what a visitor reads for it ("reaching up to grab something" for grab-high); absent in older files: the label */
  name?: string;
  /** share of the benchmark's motions the judge recognised (emdm.eval.judge: three action classifiers' mean probability),
   * at the model's default steps */
  rate: number;
  /** rate ≥ thresholds.covered and, where measured, moving ≥ thresholds.moving */
  covered: boolean;
  /** share of its motions at the page's settings that move as its real clips do (the realism benchmark: peak joint speed at
   * least a quarter of their 5th percentile); absent where not measured. A recognised pose that never moves is not covered. */
  moving?: number;
  /** its best benchmark prompt, where one works (text models) */
  prompt?: string;
  /** its real test clips' speed (median horizontal root speed of each clip, m/s): their median and 5th–95th
   * percentile (the realism benchmark's real row; absent for an action without real test clips) */
  realSpeed?: RealSpeed;
}

export interface RealSpeed { median: number; low: number; high: number; clips: number }

/** The capabilities file version this code reads (2: anchors of the uncovered actions too, the nearest-action rule). */
export const CAPABILITIES_SCHEMA = 2;

export interface Capabilities {
  schema: typeof CAPABILITIES_SCHEMA;
  model: string;
  condition: 'text' | 'action';
  steps: number;
  thresholds: { covered: number; chip?: number; moving?: number };
  /** best first */
  actions: ActionCapability[];
  /** who recognised the rates (the coverage result's judge): one action classifier, or several by their mean
   * probability (emdm.eval.judge); `sha256` tells judges apart. Absent in older files: one classifier. */
  judge?: { classifiers: number; sha256: string };
  encoder?: { id: string; onnx: string; sha256: string };
  check?: { threshold: number; suggestions: number; falseWarnings: { n: number; warned: number }; misses: { n: number; notWarned: number } };
  anchors?: { scale: number; dim: number; texts: string[]; actions: string[]; suggest: boolean[]; embeddings: string };
  /** what Python's check said of a few prompts (both runtimes must agree: tests/unit/capabilities.test.ts) */
  examples?: ({ prompt: string } & PromptCheck)[];
}

/** Whether a prompt is near what the model does well, and the closest prompts that work (best first, one per action). */
export interface PromptCheck {
  known: boolean;
  /** best cosine to the anchors */
  score: number;
  /** the action of the closest anchor (the prompt's nearest action) */
  action: string;
  /** whether the model does `action` well (false: the prompt reads as an action it does not do yet) */
  covered: boolean;
  nearest: string[];
}

export const capabilitiesFile = (model: string): string => `capabilities-${model}.json`;

function fail(file: string, field: string, what: string): never {
  throw new ModelFileError(file, 'incompatible', `field '${field}' ${what}; rebuild it with python -m emdm.eval.capabilities`);
}

/** Check the shape of a parsed capabilities file (errors name the file and field). */
export function validateCapabilities(data: unknown, file: string): Capabilities {
  const d = data as Partial<Capabilities> | null;
  if (!d || typeof d !== 'object') fail(file, '(root)', 'must be an object');
  if (d.schema !== CAPABILITIES_SCHEMA) fail(file, 'schema', `is ${JSON.stringify(d.schema)}, this library reads ${CAPABILITIES_SCHEMA}`);
  if (!Array.isArray(d.actions) || d.actions.some((a) => typeof a?.label !== 'string' || typeof a.covered !== 'boolean' || typeof a.rate !== 'number')) {
    fail(file, 'actions', 'must be a list of {label, rate, covered}');
  }
  for (const [i, r] of d.actions.entries()) {
    const s = r.realSpeed;
    if (s !== undefined && !(['median', 'low', 'high', 'clips'] as const).every((k) => Number.isFinite(s?.[k]))) {
      fail(file, `actions[${i}].realSpeed`, 'must be {median, low, high, clips} numbers');
    }
  }
  const j = d.judge;
  if (j !== undefined && !(Number.isInteger(j?.classifiers) && j.classifiers >= 1 && typeof j.sha256 === 'string')) {
    fail(file, 'judge', 'must be {classifiers: a count ≥ 1, sha256}');
  }
  const a = d.anchors;
  if (a) {
    const n = a.texts?.length ?? -1;
    if (!Array.isArray(a.texts) || a.actions?.length !== n || a.suggest?.length !== n) fail(file, 'anchors', 'needs texts, actions and suggest of one length');
    if (!Number.isInteger(a.dim) || a.dim < 1) fail(file, 'anchors.dim', 'must be a positive integer');
    if (typeof d.check?.threshold !== 'number') fail(file, 'check.threshold', 'must be a number');
    const labels = new Set(d.actions.map((r) => r.label));
    const stray = a.actions.findIndex((x) => !labels.has(x));
    if (stray >= 0) fail(file, `anchors.actions[${stray}]`, `is ${JSON.stringify(a.actions[stray])}, not an action of the file`);
  }
  return d as Capabilities;
}

function decodeBase64(s: string): Uint8Array {
  const bin = atob(s);
  const out = new Uint8Array(bin.length);
  for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
  return out;
}

const unit = new WeakMap<Capabilities, Float32Array>();

/** The anchors as unit float rows [N × dim] (decoded once per file). */
function anchorVectors(caps: Capabilities, file: string): Float32Array {
  let v = unit.get(caps);
  if (v) return v;
  const a = caps.anchors!;
  const q = new Int8Array(decodeBase64(a.embeddings).buffer);
  if (q.length !== a.texts.length * a.dim) fail(file, 'anchors.embeddings', `holds ${q.length} values, expected ${a.texts.length} × ${a.dim}`);
  v = new Float32Array(q.length);
  for (let i = 0; i < a.texts.length; i++) {
    let n = 0;
    for (let k = 0; k < a.dim; k++) n += q[i * a.dim + k] ** 2;
    const s = 1 / Math.max(Math.sqrt(n), 1e-12);
    for (let k = 0; k < a.dim; k++) v[i * a.dim + k] = q[i * a.dim + k] * s;
  }
  unit.set(caps, v);
  return v;
}

/**
 * A prompt that reads as an uncovered action whose anchors lie this close (cosine of the two actions' anchor means) to
 * a covered action's gets its suggestions ranked by the prompt and that action's mean together: "a person waves" reads
 * as wave-both-hands (0.73 to raise-both-hands) and is offered the raised hands, not the bow, walk and run its words
 * alone are nearest to. Below it the relation is too loose to lead (kick's nearest covered mean is sneak's, 0.70).
 * Python: emdm.prompt_check.RELATED.
 */
export const RELATED = 0.72;

/**
 * A far prompt's notice names the uncovered action it reads as only from this cosine up: the held-apart paraphrases of
 * the uncovered actions read as one at 0.57 and more; what merely lands nearest one (gibberish 0.33, French 0.37, "plays
 * the guitar" as swordplay 0.47) is said to be far from all the model learned. Python: emdm.prompt_check.NAMED.
 */
export const NAMED = 0.55;

/** What a visitor reads for an action of `caps`: its file's `name`, else the label with spaces. */
export function actionName(caps: Capabilities | null, label: string): string {
  return caps?.actions.find((a) => a.label === label)?.name ?? label.replace(/[_-]+/g, ' ');
}

const means = new WeakMap<Capabilities, Map<string, Float64Array>>();

/** Each action's anchors' mean, as a unit vector. */
function actionMeans(caps: Capabilities, v: Float32Array): Map<string, Float64Array> {
  let m = means.get(caps);
  if (m) return m;
  const a = caps.anchors!;
  m = new Map();
  const counts = new Map<string, number>();
  for (const [i, x] of a.actions.entries()) {
    if (!m.has(x)) m.set(x, new Float64Array(a.dim));
    const row = m.get(x)!;
    for (let k = 0; k < a.dim; k++) row[k] += v[i * a.dim + k];
    counts.set(x, (counts.get(x) ?? 0) + 1);
  }
  for (const [x, row] of m) {
    let n = 0;
    for (let k = 0; k < a.dim; k++) n += (row[k] / counts.get(x)!) ** 2;
    const s = 1 / Math.max(Math.sqrt(n), 1e-12) / counts.get(x)!;
    for (let k = 0; k < a.dim; k++) row[k] *= s;
  }
  means.set(caps, m);
  return m;
}

const dot = (v: ArrayLike<number>, i: number, w: ArrayLike<number>, dim: number) => {
  let s = 0;
  for (let k = 0; k < dim; k++) s += v[i * dim + k] * w[k];
  return s;
};

/** Check a unit prompt embedding against a text model's capabilities (see the header). */
export function checkPrompt(caps: Capabilities, embedding: ArrayLike<number>): PromptCheck {
  const a = caps.anchors;
  if (!a || !caps.check) throw new Error(`checkPrompt: ${capabilitiesFile(caps.model)} has no anchors (an action model's file)`);
  if (embedding.length !== a.dim) throw new RangeError(`checkPrompt: the embedding has ${embedding.length} values, ${capabilitiesFile(caps.model)} ${a.dim}`);
  const v = anchorVectors(caps, capabilitiesFile(caps.model));
  const cos = a.texts.map((_, i) => dot(v, i, embedding, a.dim));
  const best = cos.reduce((b, c, i) => (c > cos[b] ? i : b), 0); // the first of the largest
  const action = a.actions[best];
  const coveredSet = new Set(caps.actions.filter((r) => r.covered).map((r) => r.label));
  const covered = coveredSet.has(action);
  let rank = cos;
  if (!covered) { // an uncovered action's prompt: led by the covered action nearest to it (RELATED)
    const m = actionMeans(caps, v);
    const mine = m.get(action)!;
    const near = Math.max(-1, ...[...coveredSet].filter((x) => m.has(x)).map((x) => dot(mine, 0, m.get(x)!, a.dim)));
    if (near >= RELATED) {
      const q = Float64Array.from(mine, (x, k) => x + embedding[k]);
      const n = Math.max(Math.hypot(...q), 1e-12);
      rank = a.texts.map((_, i) => dot(v, i, q, a.dim) / n);
    }
  }
  const order = rank.map((_, i) => i).sort((x, y) => rank[y] - rank[x] || x - y);
  const nearest: string[] = [];
  const seen = new Set<string>();
  for (const i of order) {
    if (!a.suggest[i] || seen.has(a.actions[i])) continue;
    seen.add(a.actions[i]);
    nearest.push(a.texts[i]);
    if (nearest.length === (caps.check.suggestions ?? 3)) break;
  }
  const score = cos[best];
  return { known: covered && score >= caps.check.threshold, score: Math.round(score * 1e4) / 1e4, action, covered, nearest };
}

/**
 * The capabilities of `model`, or null when it has none (no file, or one built for another text encoder file).
 * Listed in the manifest (`models[model].capabilities` and `files`): fetched and verified like a model file.
 */
export async function loadCapabilities(manifest: Manifest, baseUrl: string, model: string): Promise<Capabilities | null> {
  const entry = manifest.models[model];
  if (!entry) return null;
  const path = typeof entry.capabilities === 'string' ? entry.capabilities : capabilitiesFile(model);
  let bytes: ArrayBuffer;
  try {
    bytes = manifest.files[path] ? await fetchVerified(baseUrl, manifest, path) : await fetchBytes(baseUrl, path);
  } catch (e) {
    if (e instanceof ModelFileError && e.reason === 'missing') return null;
    throw e;
  }
  let data: unknown;
  try {
    data = JSON.parse(new TextDecoder().decode(bytes));
  } catch (e) {
    throw new ModelFileError(path, 'incompatible', `not valid JSON (${(e as Error).message}); rebuild it with python -m emdm.eval.capabilities`);
  }
  const caps = validateCapabilities(data, path);
  if (caps.model !== model) fail(path, 'model', `is ${JSON.stringify(caps.model)}, expected ${JSON.stringify(model)}`);
  if (caps.encoder) {
    const enc = manifest.textEncoders[caps.encoder.id];
    if (!enc || manifest.files[caps.encoder.onnx]?.sha256 !== caps.encoder.sha256) return null; // stale: embeddings of another encoder file
  }
  return caps;
}
