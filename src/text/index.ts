export { createTextEncoder, DEFAULT_TEXT_ENCODER, TextEncoderError, tokenizeClip } from './encoder';
export type { PromptTokens, TextEncoder, TextEncoderOptions } from './encoder';
export { emdmClipIds, truncateKeepingEnd, CLIP_CONTEXT, CLIP_MAX_TEXT_TOKENS, CLIP_PADDED_LENGTH, CLIP_PAD_ID } from './clipTokens';
export { cosine, l2Normalize, meanPool } from './pooling';
