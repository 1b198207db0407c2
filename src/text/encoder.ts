/**
 * Text encoders (one interface, two implementations), run by transformers.js on verified files:
 * - `minilm` (all-MiniLM-L6-v2, shipped): BERT token vectors → mean pooling → L2 norm (384-d).
 * - `clip` (CLIP ViT-B/32 text tower, EMDM's encoder): EMDM truncation (20 tokens, padded to 77)
 *   → projected end-of-text embedding (512-d, not normalised), as EMDM feeds its model.
 * A prompt's only limit is in tokens: the manifest's `maxTokens` (counting the encoder's start and
 * end tokens); `tokenize` says whether a prompt was cut. Python computes the same ids and vectors
 * from the same files (scripts/emdm/text).
 */
import { fetchVerified, joinUrl, ModelFileError, type Manifest, type TextEncoderEntry } from '../manifest';
import { CLIP_CONTEXT, emdmClipIds, truncateKeepingEnd } from './clipTokens';
import { l2Normalize, meanPool } from './pooling';
import { loadMark } from '../runtime/ort';
import { isNodeRuntime, loadTransformers, provideVerifiedFile } from './transformersEnv';

/** The tokens an encoder reads from a prompt. */
export interface PromptTokens {
  /** the ids the encoder runs (at most maxTokens, start and end tokens included) */
  ids: number[];
  /** how many tokens the whole prompt has (more than ids.length when it was cut) */
  tokens: number;
  maxTokens: number;
  truncated: boolean;
}

export interface TextEncoder {
  readonly id: string;
  readonly dim: number;
  encode(text: string): Promise<Float32Array>;
  /**
   * The ids `encode` runs on `text`, and whether the prompt was cut to the manifest's maxTokens.
   * Every encoder createTextEncoder makes has it; a wrapper without it gives prompts no truncation notice.
   */
  tokenize?(text: string): Promise<PromptTokens>;
}

export interface TextEncoderOptions {
  /** where ONNX Runtime's wasm is served (browser; the step models' ORT, shared); default `<BASE_URL>ort/` */
  wasmPaths?: string;
  /** WASM threads of the shared ORT (src/runtime/ort.ts; default there) */
  threads?: number;
  /** download progress over all files of the encoder */
  onDownload?: (loaded: number, total: number) => void;
}

export const DEFAULT_TEXT_ENCODER = 'all-MiniLM-L6-v2';

export class TextEncoderError extends Error {
  constructor(readonly encoderId: string, message: string) {
    super(`text encoder ${encoderId}: ${message}`);
    this.name = 'TextEncoderError';
  }
}

function checkText(id: string, text: unknown): string {
  if (typeof text !== 'string') throw new TextEncoderError(id, `encode() expects a string, got ${text === null ? 'null' : typeof text}`);
  return text;
}

/** Model id handed to transformers.js: the encoder folder as a path it cannot mistake for a Hub id. */
function modelRoot(baseUrl: string, dir: string): string {
  let root = joinUrl(baseUrl, dir).replace(/\/+$/, '');
  if (root.startsWith('file://')) root = decodeURIComponent(root.slice('file://'.length));
  if (!root.startsWith('/') && !/^[a-z]+:/i.test(root)) root = '/' + root; // relative URL → absolute path
  return root;
}

async function prefetch(manifest: Manifest, baseUrl: string, entry: TextEncoderEntry, root: string, onDownload?: (l: number, t: number) => void): Promise<void> {
  const total = entry.files.reduce((s, f) => s + (manifest.files[f]?.bytes ?? 0), 0);
  const done = new Map<string, number>();
  const report = () => onDownload?.([...done.values()].reduce((a, b) => a + b, 0), total);
  const prefix = entry.dir.replace(/\/+$/, '') + '/';
  await Promise.all(
    entry.files.map(async (rel) => {
      if (!rel.startsWith(prefix)) {
        throw new ModelFileError(rel, 'incompatible', `listed by a text encoder whose folder is '${entry.dir}'`);
      }
      const bytes = await fetchVerified(baseUrl, manifest, rel, (l) => {
        done.set(rel, l);
        report();
      });
      provideVerifiedFile(`${root}/${rel.slice(prefix.length)}`, bytes);
    }),
  );
}

/** Free transformers.js tensors (inputs and outputs of a run) once their numbers have been copied out. */
export function disposeAll(tensors: Record<string, unknown>): void {
  for (const t of Object.values(tensors)) (t as { dispose?: () => void } | null)?.dispose?.();
}

/** Run calls one at a time (an ORT-web session must not run twice at once); a failure does not block later calls. */
function serialised(fn: (text: string) => Promise<Float32Array>): (text: string) => Promise<Float32Array> {
  let tail: Promise<unknown> = Promise.resolve();
  return (text: string) => {
    const run = tail.then(() => fn(text));
    tail = run.catch(() => undefined);
    return run;
  };
}

function entryFor(manifest: Manifest, id: string): TextEncoderEntry {
  const entry = manifest.textEncoders[id];
  if (!entry) {
    const known = Object.keys(manifest.textEncoders).join(', ') || 'none';
    throw new ModelFileError('manifest.json', 'incompatible', `no textEncoders entry '${id}' (known: ${known})`);
  }
  return entry;
}

/**
 * ORT session options of the encoders: no graph optimisation. On a cold WASM runtime (a page load),
 * optimising the int8 MiniLM graph is what its session creation spends its time on: measured with
 * onnxruntime-web 1.30 in fresh Node processes on this 2-core machine (load average 13–16), creating it
 * took 1.1–3.6 s with 'all'/'extended'/'basic' and 0.3–0.9 s with 'disabled'; its first encode is
 * ~0.3 s slower and later ones ~20 ms instead of ~12 ms (one per prompt). Vectors stay within the
 * Python parity tests' cosine ≥ 0.999.
 */
export const ENCODER_SESSION_OPTIONS = { graphOptimizationLevel: 'disabled' } as const;

const loaded = new Map<string, Promise<TextEncoder>>();

/**
 * Load the encoder `id` (default: the shipped MiniLM) named by the manifest under `baseUrl`.
 * Loads are shared: asking again for the same files (same folder, same sha256s) returns the same
 * encoder instead of a second copy of the model; a failed load is forgotten, so a retry loads anew.
 */
export function createTextEncoder(manifest: Manifest, baseUrl: string, id: string = DEFAULT_TEXT_ENCODER, opts: TextEncoderOptions = {}): Promise<TextEncoder> {
  let key: string;
  try {
    const entry = entryFor(manifest, id);
    key = [baseUrl, id, ...entry.files.map((f) => `${f}:${manifest.files[f]?.sha256 ?? '?'}`)].join('|');
  } catch (e) {
    return Promise.reject(e);
  }
  let p = loaded.get(key);
  if (!p) {
    p = load(manifest, baseUrl, id, opts);
    loaded.set(key, p);
    p.catch(() => loaded.delete(key));
  } else if (opts.onDownload) {
    const total = manifest.textEncoders[id].files.reduce((s, f) => s + (manifest.files[f]?.bytes ?? 0), 0);
    const cb = opts.onDownload;
    void p.then(() => cb(total, total), () => undefined);
  }
  return p;
}

async function load(manifest: Manifest, baseUrl: string, id: string, opts: TextEncoderOptions): Promise<TextEncoder> {
  const entry = entryFor(manifest, id);
  const root = modelRoot(baseUrl, entry.dir);
  const [tf] = await Promise.all([loadTransformers({ wasmPaths: opts.wasmPaths, threads: opts.threads }), prefetch(manifest, baseUrl, entry, root, opts.onDownload)]);
  loadMark(`encoder-files:${id}`);
  const device = isNodeRuntime ? 'cpu' : 'wasm';
  const common = { local_files_only: true, device, session_options: ENCODER_SESSION_OPTIONS } as const;
  if (entry.kind === 'minilm') {
    const dtype = entry.dtype ?? 'q8';
    const [tokenizer, model] = await Promise.all([
      tf.AutoTokenizer.from_pretrained(root, { local_files_only: true }),
      tf.AutoModel.from_pretrained(root, { ...common, dtype }),
    ]);
    loadMark(`encoder-ready:${id}`);
    const maxTokens = entry.maxTokens ?? 128;
    const tokenize = (text: string): PromptTokens => {
      // transformers.js's own truncation drops [SEP]; HF tokenizers, which Python uses, keep it.
      // Encode untruncated and cut here exactly like Python does.
      const all = tokenizer.encode(checkText(id, text));
      const ids = truncateKeepingEnd(all, maxTokens);
      return { ids, tokens: all.length, maxTokens, truncated: ids.length < all.length };
    };
    return {
      id,
      dim: entry.dim,
      tokenize: async (text: string) => tokenize(text),
      encode: serialised(async (text: string): Promise<Float32Array> => {
        const { ids } = tokenize(text);
        const n = ids.length;
        const inputs = {
          input_ids: new tf.Tensor('int64', BigInt64Array.from(ids, (x) => BigInt(x)), [1, n]),
          attention_mask: new tf.Tensor('int64', new BigInt64Array(n).fill(1n), [1, n]),
          token_type_ids: new tf.Tensor('int64', new BigInt64Array(n), [1, n]),
        };
        const out = await model(inputs).finally(() => disposeAll(inputs));
        try {
          const hidden = (out.last_hidden_state ?? out.token_embeddings) as { data: Float32Array; dims: number[] } | undefined;
          if (!hidden) throw new TextEncoderError(id, `model output has no last_hidden_state (outputs: ${Object.keys(out).join(', ')})`);
          const [, tokens, dim] = hidden.dims;
          if (dim !== entry.dim) throw new TextEncoderError(id, `model gives ${dim}-d token vectors, manifest says dim ${entry.dim}`);
          const v = meanPool(hidden.data, tokens, dim);
          return entry.normalize === false ? v : l2Normalize(v);
        } finally {
          disposeAll(out);
        }
      }),
    };
  }
  if (entry.kind === 'clip') {
    const dtype = entry.dtype ?? 'fp32';
    const [tokenizer, model] = await Promise.all([
      tf.AutoTokenizer.from_pretrained(root, { local_files_only: true }),
      tf.CLIPTextModelWithProjection.from_pretrained(root, { ...common, dtype }),
    ]);
    const eot = tokenizer.model.tokens_to_ids.get('<|endoftext|>');
    if (eot === undefined) throw new TextEncoderError(id, 'tokenizer has no <|endoftext|> token; is this a CLIP tokenizer?');
    if (entry.maxTokens !== undefined && entry.maxTokens !== CLIP_CONTEXT) {
      throw new ModelFileError('manifest.json', 'incompatible', `textEncoders.${id}.maxTokens is ${entry.maxTokens}; EMDM's CLIP reads ${CLIP_CONTEXT} tokens ([SOT] + 20 + [EOT])`);
    }
    return {
      id,
      dim: entry.dim,
      async tokenize(text: string): Promise<PromptTokens> {
        const all = tokenizeClip(tokenizer, checkText(id, text));
        const ids = emdmClipIds(all, eot, CLIP_CONTEXT, 0); // without the zero padding
        return { ids, tokens: all.length, maxTokens: CLIP_CONTEXT, truncated: ids.length < all.length };
      },
      encode: serialised(async (text: string): Promise<Float32Array> => {
        const t = checkText(id, text);
        const ids = emdmClipIds(tokenizeClip(tokenizer, t), eot);
        const inputs = { input_ids: new tf.Tensor('int64', BigInt64Array.from(ids, (x) => BigInt(x)), [1, ids.length]) };
        const out = await model(inputs).finally(() => disposeAll(inputs));
        try {
          const emb = out.text_embeds as { data: Float32Array; dims: number[] } | undefined;
          if (!emb) throw new TextEncoderError(id, `model output has no text_embeds (outputs: ${Object.keys(out).join(', ')})`);
          if (emb.data.length !== entry.dim) throw new TextEncoderError(id, `model gives ${emb.data.length}-d vectors, manifest says dim ${entry.dim}`);
          const v = Float32Array.from(emb.data);
          return entry.normalize ? l2Normalize(v) : v;
        } finally {
          disposeAll(out);
        }
      }),
    };
  }
  throw new ModelFileError('manifest.json', 'incompatible', `textEncoders.${id}.kind is '${String((entry as { kind: unknown }).kind)}', expected 'minilm' or 'clip'`);
}

/** CLIP token ids of `text` with [SOT] … [EOT], untruncated (EMDM's truncation is applied after). */
export function tokenizeClip(tokenizer: { encode(text: string): number[] }, text: string): number[] {
  return tokenizer.encode(text);
}
