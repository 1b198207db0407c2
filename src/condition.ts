/**
 * What a generation's condition becomes for one model: its vector (zero = unconditional, an action's one-hot, a text
 * prompt's embedding through the model's text encoder, the last prompts' kept), how the encoder read a prompt, and
 * the model's capabilities check of a prompt's embedding (src/capabilities.ts). openModel (src/openModel.ts) asks it.
 */
import { type Capabilities, type PromptCheck, checkPrompt, loadCapabilities } from './capabilities';
import type { Manifest } from './manifest';
import { type TextEncoder, createTextEncoder } from './text';

export type Condition =
  | { type: 'text'; text: string }
  | { type: 'action'; label: number }
  | { type: 'none' }
  /** a ready condition vector (e.g. an embedding computed elsewhere); zero = unconditional */
  | { type: 'vector'; vector: Float32Array };

/** Prompts whose embedding an encoder keeps (oldest dropped first). */
const EMBEDDING_CACHE = 64;

export interface ConditionEncoder {
  /** the condition vector [condition dim] of a request's condition, checked against the model */
  vector(c: Condition): Promise<Float32Array>;
  /** how the encoder read a prompt (after `vector` loaded it): `truncated` when it had more than maxTokens; undefined if it cannot say */
  tokens(text: string): Promise<{ tokens: number; maxTokens: number; truncated: boolean } | undefined>;
  /** the capabilities check of a prompt's embedding; undefined without a capabilities file (a broken one is said once on the console) */
  check(embedding: Float32Array): Promise<PromptCheck | undefined>;
}

/** The condition encoder of `model` (a text model's encoder: `textEncoder`, else created on the first prompt). */
export function conditionEncoder(o: { manifest: Manifest; baseUrl: string; model: string; textEncoder?: TextEncoder }): ConditionEncoder {
  const { manifest, baseUrl, model } = o;
  const entry = manifest.models[model];
  const C = entry.condition.dim;
  let encoder: Promise<TextEncoder> | null = o.textEncoder ? Promise.resolve(o.textEncoder) : null;
  // the prompts encoded last (a timeline's windows and a regenerated segment ask for the same prompt again)
  const embeddings = new Map<string, Float32Array>();
  let capabilities: Promise<Capabilities | null> | null = null;

  async function conditionVector(c: Condition): Promise<Float32Array> {
    if (!c || typeof c !== 'object') throw new TypeError(`generate: condition must be {type: 'text'|'action'|'none'|'vector', ...}`);
    switch (c.type) {
      case 'none':
        return new Float32Array(C);
      case 'vector':
        if (c.vector.length !== C) throw new RangeError(`generate: condition vector has ${c.vector.length} values, model ${model} expects ${C}`);
        return Float32Array.from(c.vector);
      case 'action': {
        if (entry.condition.type !== 'action') throw new Error(`generate: model ${model} is a ${entry.condition.type} model; it takes no action label`);
        const labels = entry.condition.labels;
        if (!Number.isInteger(c.label) || c.label < 0 || c.label >= labels.length) {
          throw new RangeError(`generate: action label ${c.label} out of range 0…${labels.length - 1} (${labels.join(', ')})`);
        }
        const v = new Float32Array(C);
        v[c.label] = 1;
        return v;
      }
      case 'text': {
        if (entry.condition.type !== 'text') throw new Error(`generate: model ${model} is a ${entry.condition.type} model; it takes no text prompt`);
        if (typeof c.text !== 'string' || !c.text.trim()) throw new Error('generate: the text prompt is empty');
        const encId = entry.condition.encoder;
        encoder ??= createTextEncoder(manifest, baseUrl, encId);
        let enc: TextEncoder;
        try {
          enc = await encoder;
        } catch (e) {
          encoder = null;
          throw e;
        }
        const hit = embeddings.get(c.text);
        if (hit) return Float32Array.from(hit);
        const v = await enc.encode(c.text);
        if (v.length !== C) throw new Error(`generate: text encoder ${enc.id} gives ${v.length}-d vectors, model ${model} expects ${C}`);
        if (embeddings.size >= EMBEDDING_CACHE) embeddings.delete(embeddings.keys().next().value!);
        embeddings.set(c.text, Float32Array.from(v));
        return v;
      }
      default:
        throw new TypeError(`generate: unknown condition type ${(c as { type: unknown }).type}`);
    }
  }

  /** The model's capabilities check of a prompt's embedding; undefined without a capabilities file (a broken one is said once on the console). */
  async function promptCheck(embedding: Float32Array): Promise<PromptCheck | undefined> {
    // the coverage benchmark measures the EMDM models: an unlisted file of a diffusion model is not looked for (no 404)
    if (entry.objective === 'diffusion' && typeof entry.capabilities !== 'string') return undefined;
    capabilities ??= loadCapabilities(manifest, baseUrl, model).catch((e) => {
      console.warn(`generate: no prompt check for ${model}: ${(e as Error).message}`);
      return null;
    });
    const caps = await capabilities;
    return caps?.anchors ? checkPrompt(caps, embedding) : undefined;
  }

  /** How the encoder read the prompt (after conditionVector loaded it); undefined if it cannot say. */
  async function promptTokens(text: string): ReturnType<ConditionEncoder['tokens']> {
    const t = await (await encoder)?.tokenize?.(text);
    return t && { tokens: t.tokens, maxTokens: t.maxTokens, truncated: t.truncated };
  }

  return { vector: conditionVector, tokens: promptTokens, check: promptCheck };
}
