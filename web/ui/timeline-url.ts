// A timeline's segments in the page URL (`?…&tl=…`), so a timeline can be shared and a reload restores it.
// The value is JSON: [[prompt, seconds, seed], [{"a": action}, seconds, seed], …] (URLSearchParams encodes it).
// Pure: no DOM, so vitest checks the round trip and the refusals.
import type { TimelineSegment } from '../../src/index';

export const TIMELINE_PARAM = 'tl';

/** The `tl` value of segments. */
export function encodeTimeline(segments: readonly TimelineSegment[]): string {
  return JSON.stringify(segments.map((s) => [s.action !== undefined && s.action !== '' ? { a: s.action } : (s.prompt ?? ''), s.seconds, s.seed >>> 0]));
}

/** The most segments a link may hold (a 60 s timeline of 0.3 s segments), and the most characters of its value. */
export const MAX_SEGMENTS = 200;
export const MAX_TIMELINE_CHARS = MAX_SEGMENTS * 2100;

/** A short, bounded description of any JSON value for a message (JSON.stringify of a deeply nested list overflows the stack). */
function preview(v: unknown): string {
  if (Array.isArray(v)) return `a list of ${v.length} entr${v.length === 1 ? 'y' : 'ies'}`;
  if (v !== null && typeof v === 'object') return `an object with keys ${Object.keys(v).slice(0, 5).map((k) => JSON.stringify(k.slice(0, 20))).join(', ') || '(none)'}`;
  return (JSON.stringify(v) ?? String(v)).slice(0, 60);
}

export class TimelineUrlError extends Error {
  constructor(message: string) {
    super(`The timeline in the URL (parameter '${TIMELINE_PARAM}') could not be read: ${message}`);
    this.name = 'TimelineUrlError';
  }
}

/**
 * Segments from a `tl` value. Lengths and prompts are NOT checked here (planTimeline does, with a message
 * naming the segment, so a shared link with a bad segment still shows the list); the shape, the action names
 * (`actions`) and the seeds are.
 */
export function decodeTimeline(value: string, actions: readonly string[]): TimelineSegment[] {
  if (value.length > MAX_TIMELINE_CHARS) throw new TimelineUrlError(`${value.length} characters; at most ${MAX_TIMELINE_CHARS}`);
  let doc: unknown;
  try {
    doc = JSON.parse(value);
  } catch (e) {
    throw new TimelineUrlError(`not JSON (${(e as Error).message})`);
  }
  if (!Array.isArray(doc)) throw new TimelineUrlError('expected a list of [prompt, seconds, seed] entries');
  if (doc.length > MAX_SEGMENTS) throw new TimelineUrlError(`${doc.length} segments; at most ${MAX_SEGMENTS}`);
  return doc.map((e, i) => {
    const where = `segment ${i + 1}`;
    if (!Array.isArray(e) || e.length !== 3) throw new TimelineUrlError(`${where} must be [prompt, seconds, seed], got ${preview(e)}`);
    const [what, seconds, seed] = e as [unknown, unknown, unknown];
    if (typeof seconds !== 'number' || !Number.isFinite(seconds)) throw new TimelineUrlError(`${where}: seconds must be a number, got ${preview(seconds)}`);
    if (typeof seed !== 'number' || !Number.isInteger(seed) || seed < 0 || seed > 0xffffffff) throw new TimelineUrlError(`${where}: seed must be an integer in 0…4294967295, got ${preview(seed)}`);
    if (typeof what === 'string') return { prompt: what, seconds, seed }; // the whole prompt (the value's length is bounded above)
    const a = (what as { a?: unknown } | null)?.a;
    if (typeof a === 'string' && actions.includes(a)) return { action: a, seconds, seed };
    throw new TimelineUrlError(`${where}: expected a prompt or {"a": action} with an action of ${actions.join(', ') || '(no action model)'}, got ${preview(what)}`);
  });
}

/** `search` with the `tl` parameter set to `segments` (or removed when null). */
export function withTimeline(search: string, segments: readonly TimelineSegment[] | null): string {
  const q = new URLSearchParams(search);
  if (segments) q.set(TIMELINE_PARAM, encodeTimeline(segments));
  else q.delete(TIMELINE_PARAM);
  const s = q.toString();
  return s ? `?${s}` : '';
}

/** `search` with the `tl` parameter set to `value` as it is (a link's value the page could not read, kept for the visitor). */
export function withRawTimeline(search: string, value: string): string {
  const q = new URLSearchParams(search);
  q.set(TIMELINE_PARAM, value);
  return `?${q.toString()}`;
}
