// What made the motion on screen, beyond its PageState: a timeline's segments, an edit's kind and inputs (with
// the motion it edited), a live recording's prompts. From it come the joints JSON's `generator` block (generatorOf)
// and the page's address (linkOf: what Copy link and a reload reproduce, and a note when the motion on screen is
// not what the link makes). Pure (no DOM): tests/unit/webProvenance.test.ts checks both.
import type { EditCondition, KeptPart, TimelineSegment } from '../../src/index';
import { stateToSearch, type Mode, type PageState } from './state';
import { TIMELINE_PARAM, encodeTimeline } from './timeline-url';

/** A motion as the page describes it: its state, model and step count and, when it is not one generation of
 * `state`, its source. */
export interface Described {
  state: PageState;
  model: string;
  steps: number;
  source?: MotionSource;
}

/** A prompt timeline (web/ui/timeline.ts): its segments, each segment's model, the steps and guidance it ran. */
export interface TimelineSource {
  kind: 'timeline';
  segments: TimelineSegment[];
  models: string[];
  steps: number;
  guidance: number;
}

/** What an edit of the motion on screen changed, and how. */
export type EditInputs =
  | { type: 'inbetween'; keepFirstSeconds: number; keepLastSeconds: number }
  | { type: 'body'; kept: KeptPart }
  | { type: 'loop'; inPlace: boolean };

/** An edit (in-between, body part, loop): its inputs, the condition and seed of the window it generated, and the
 * motion it edited. Its steps and guidance are the Described's. */
export interface EditSource {
  kind: 'edit';
  edit: EditInputs;
  condition: EditCondition;
  seed: number;
  base: Described;
}

/** A prompt of a live recording: `at` is seconds into the recording when it was sent (the one playing as the
 * recording starts was sent before it: negative); it blends in `latency` s later (absent: not measured). */
export interface RecordedPrompt {
  text: string;
  at: number;
  latency?: number;
}

/** A live recording (web/ui/live.ts): the stream's settings and the prompts that play in it. */
export interface LiveSource {
  kind: 'live';
  prompts: RecordedPrompt[];
  seed: number;
  steps: number;
  guidance: number;
}

export type MotionSource = TimelineSource | EditSource | LiveSource;

/** Only what describes a motion (not its joints or track: an edit keeps its base's description, not its motion). */
export function described(d: Described): Described {
  return { state: d.state, model: d.model, steps: d.steps, ...(d.source ? { source: d.source } : {}) };
}

const ms = (s: number) => Math.round(s * 1000) / 1000;

/**
 * A live recording's source from the stream's prompt log (times on the live clock): the recording is the `seconds`
 * before `end` on that clock; its prompts are the one playing as it starts (the last sent before) and those sent
 * during it.
 */
export function liveSource(log: readonly { text: string; at: number; latency: number | null }[], end: number, seconds: number,
  settings: { seed: number; steps: number; guidance: number }): LiveSource {
  const start = end - seconds;
  const before = log.filter((p) => p.at <= start).slice(-1);
  const during = log.filter((p) => p.at > start && p.at <= end);
  const prompts = [...before, ...during].map((p) => ({ text: p.text, at: ms(p.at - start), ...(p.latency !== null ? { latency: ms(p.latency) } : {}) }));
  return { kind: 'live', prompts, seed: settings.seed >>> 0, steps: settings.steps, guidance: settings.guidance };
}

/** The mode and prompt or action fields of a condition. */
function conditionFields(c: EditCondition | null | undefined): { mode: Mode; text?: string; action?: string } {
  if (!c) return { mode: 'random' };
  if (c.action !== undefined && c.action !== '') return { mode: 'action', action: String(c.action) };
  return { mode: 'text', text: c.prompt ?? '' };
}

/**
 * The joints JSON's `generator` block for the motion on screen (format in src/export/jointsJson.ts). Every kind has
 * `kind` ('generate' | 'timeline' | 'edit' | 'live') and the fields it always had — `model`, `mode`, `text` or
 * `action`, `steps`, `guidance`, `seed` — describing the one window that best stands for the motion: one generation's
 * own; a timeline's first segment (`segments` lists them all: prompt or action, seconds, seed, model); an edit's new
 * window (`edit`: what it changed, `base`: the block of the motion it edited); a live recording's last prompt and the
 * stream's seed (`prompts`: each prompt and when it was sent, seconds into the recording).
 */
export function generatorOf(d: Described): Record<string, unknown> {
  const s = d.state;
  const src = d.source;
  if (!src) {
    return {
      kind: 'generate', model: d.model, mode: s.mode, text: s.mode === 'text' ? s.text : undefined,
      action: s.mode === 'action' ? s.action : undefined, steps: d.steps, guidance: s.guidance, seed: s.seed >>> 0,
    };
  }
  if (src.kind === 'timeline') {
    const first = src.segments[0];
    return {
      kind: 'timeline', model: src.models[0] ?? d.model, ...conditionFields(first), steps: src.steps, guidance: src.guidance,
      seed: (first?.seed ?? s.seed) >>> 0,
      segments: src.segments.map((g, i) => {
        const c = conditionFields(g);
        return { ...(c.mode === 'action' ? { action: c.action } : { prompt: c.text }), seconds: g.seconds, seed: g.seed >>> 0, model: src.models[i] ?? d.model };
      }),
    };
  }
  if (src.kind === 'edit') {
    return {
      kind: 'edit', model: d.model, ...conditionFields(src.condition), steps: d.steps, guidance: s.guidance, seed: src.seed >>> 0,
      edit: { ...src.edit }, base: generatorOf(src.base),
    };
  }
  const last = src.prompts[src.prompts.length - 1];
  return {
    kind: 'live', model: d.model, mode: 'text', text: last?.text ?? s.text, steps: src.steps, guidance: src.guidance, seed: src.seed,
    prompts: src.prompts.map((p) => ({ ...p })),
  };
}

/** The seed a file name of the motion carries (generatorOf's). */
export function seedOf(d: Described): number {
  return generatorOf(d).seed as number;
}

/** What an edit is called in the link note. */
const EDIT_NAMES: Record<EditInputs['type'], string> = { inbetween: 'in-between', body: 'body-part edit', loop: 'loop' };

/** The page's address: its query string, and a note beside Copy link ('' when the link makes the motion on screen). */
export interface PageLink {
  search: string;
  note: string;
}

/**
 * The page's address for the controls' state and the motion on screen (`shown`). One generation: the controls' state
 * (what Generate makes; the address follows the controls). A timeline: the controls' state with the timeline (`tl`)
 * and the steps and guidance it ran with, so the link (and a reload) makes that timeline whatever else the controls
 * say. An edit or a live recording cannot be written in a link: the address is the link of the motion before the
 * edit (else of the controls' state), and the note says so.
 */
export function linkOf(controls: PageState, shown: Described | null): PageLink {
  const src = shown?.source;
  if (!src) return { search: stateToSearch(controls), note: '' };
  if (src.kind === 'timeline') {
    const q = new URLSearchParams(stateToSearch({ ...controls, steps: src.steps, guidance: src.guidance }));
    q.set('guidance', String(src.guidance)); // in random mode too: the timeline's windows ran with it
    q.set(TIMELINE_PARAM, encodeTimeline(src.segments));
    return { search: `?${q.toString()}`, note: '' };
  }
  if (src.kind === 'live') {
    return { search: stateToSearch(controls), note: 'The live recording on screen is not in this link (a link cannot hold one): it opens one motion of the settings shown.' };
  }
  const base = linkOf(controls, src.base);
  const what = EDIT_NAMES[src.edit.type];
  return {
    search: base.search,
    note: base.note ? `The ${what} on screen is not in this link. ${base.note}` : `The ${what} on screen is not in this link (a link holds no edits): it opens the motion before the edit.`,
  };
}
