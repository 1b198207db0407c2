/**
 * EMDM's CLIP text truncation (pure), mirrored by emdm/text/clip.py: at most 20 text tokens,
 * i.e. a context of 22 ([SOT] + 20 + [EOT]; a longer prompt is cut and its last kept slot becomes
 * [EOT], as OpenAI's clip.tokenize(truncate=True) does), then zero-padded to CLIP's 77 positions.
 */
export const CLIP_MAX_TEXT_TOKENS = 20;
export const CLIP_CONTEXT = CLIP_MAX_TEXT_TOKENS + 2;
export const CLIP_PADDED_LENGTH = 77;
export const CLIP_PAD_ID = 0;

/** `ids` = the tokenizer's ids with [SOT] … [EOT]; returns exactly `paddedLength` ids. */
export function emdmClipIds(ids: readonly number[], eotId: number, context = CLIP_CONTEXT, paddedLength = CLIP_PADDED_LENGTH): number[] {
  if (ids.length < 2) throw new RangeError(`emdmClipIds: expected at least [SOT, EOT], got ${ids.length} ids`);
  if (ids[ids.length - 1] !== eotId) throw new RangeError(`emdmClipIds: the last id must be the end token ${eotId}, got ${ids[ids.length - 1]}`);
  let out = ids.slice();
  if (out.length > context) {
    out = out.slice(0, context);
    out[context - 1] = eotId;
  }
  while (out.length < paddedLength) out.push(CLIP_PAD_ID);
  return out;
}

/** Cut `ids` ([CLS/SOT] … [SEP/EOT]) to at most `max` ids, keeping the final special token (as HF tokenizers do). */
export function truncateKeepingEnd(ids: readonly number[], max: number): number[] {
  if (max < 2) throw new RangeError(`truncateKeepingEnd: max must be >= 2, got ${max}`);
  if (ids.length <= max) return ids.slice();
  return [...ids.slice(0, max - 1), ids[ids.length - 1]];
}
