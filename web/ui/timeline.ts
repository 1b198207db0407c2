// "Beyond one prompt" on the page (issue 14): a prompt timeline (segments of prompt or action + seconds,
// generated window by window far past the model's 196 frames, one segment regenerated without touching the
// ones before it, kept in the URL), and edits of the motion on screen: in-betweening (keep the first and
// last second, a new middle), body-part edits (keep the lower or upper body) and seamless loops (+ in place).
// The bookkeeping is src/edit.ts's; every generation runs in the generation worker through the page's
// session (progress, and the newest request wins: a new one cancels the running one at its next step). A
// timeline is one request: its windows, seam easing, stitching, decoding and IK all run in the worker
// (GenerationHost.timeline); the edits send their one window and decode here.
// The panel builds its DOM inside one container (#edit-panel in index.html) and styles it in timeline.css.
import { EditError, MAX_TIMELINE_SECONDS, bodyPartEdit, inBetween, makeLoop, type EditCondition, type EditMotion, type KeptPart, type Timeline, type TimelineSegment } from '../../src/index';
import { inBetweenRange, planTimeline } from '../../src/edit';
import { decodeJoints } from '../../src/motion/decode';
import { recoverJoints } from '../../src/motion/recover';
import { el } from './dom';
import { quoted } from './knows';
import type { PageContext } from './page-context';
import { described, type Described, type EditInputs, type EditSource } from './provenance';
import { randomSeed } from './state';
import { type EditJob, type EditKind, type EditSummary, type RequestPanel, type Shown, runEditRequest } from './timeline-request';
import { TimelineRows, button } from './timeline-rows';
import { TIMELINE_PARAM, decodeTimeline, withTimeline } from './timeline-url';
import './timeline.css';

export type { EditSummary } from './timeline-request';

/** Read before the page rewrites its URL (web/main.ts replaces it with the controls' state on start). */
const INITIAL = new URLSearchParams(location.search);

/** The panel's hooks for Playwright (window.emdm.edit). */
export interface EditTestApi {
  segments(): TimelineSegment[];
  setSegments(s: TimelineSegment[]): void;
  generateAll(): Promise<EditSummary>;
  regenerate(i: number): Promise<EditSummary>;
  /** keep the first `first` and the last `last` seconds (default 1 each) */
  inBetween(prompt: string, first?: number, last?: number): Promise<EditSummary>;
  bodyEdit(part: KeptPart, prompt: string): Promise<EditSummary>;
  loop(inPlace: boolean): Promise<EditSummary>;
  /** the message under the panel ('' when none) */
  message(): string;
  /** the motion on screen as the panel edits it: raw decoded joints (no smoothing) and features */
  current(): { frames: number; fps: number; joints: number[]; features: number[] } | null;
  /** the full N-frame loop of the last loop (frame N−K repeats frame 0), null before one */
  lastLoopFull(): { frames: number; joints: number[] } | null;
}

const PROMPT = '';

export class TimelinePanel implements RequestPanel {
  /** each mode's message (errors) and progress line, shown next to that mode's controls */
  private readonly msgs: Record<EditKind, HTMLElement> = { timeline: el('p', 'tl-message'), inbetween: el('p', 'tl-message'), body: el('p', 'tl-message'), loop: el('p', 'tl-message') };
  private readonly busy: Record<EditKind, HTMLElement> = { timeline: el('p', 'tl-progress'), inbetween: el('p', 'tl-progress'), body: el('p', 'tl-progress'), loop: el('p', 'tl-progress') };
  private readonly rows: TimelineRows;
  /** the last generated timeline (its segments are reused when regenerating a later one) and the steps/guidance it ran with */
  private timeline: Timeline | null = null;
  private timelineSettings = '';
  /** the full N frames of the last loop */
  private lastLoop: EditMotion | null = null;
  /** the last motion this panel showed, with raw decoded joints, and its condition (null: several) */
  private current: EditMotion | null = null;
  private currentCondition: EditCondition | null = null;
  readonly actions: readonly string[];

  constructor(readonly page: PageContext, container: HTMLElement) {
    this.actions = page.session.limits.actions;
    this.rows = new TimelineRows(this.actions, {
      generate: () => void this.generateAll().catch(() => undefined),
      regenerate: (i) => void this.regenerate(i).catch(() => undefined),
      refuse: (text) => this.say(text),
    });
    const details = el('details', 'tl-panel');
    const summary = el('summary', undefined, 'Timeline & editing');
    const body = el('div', 'tl-body');
    details.append(summary, body);
    container.replaceChildren(details);

    // ---- timeline
    const intro = el('p', 'tl-hint', `Chain prompts up to ${MAX_TIMELINE_SECONDS} s: each segment continues from the last second of the one before.`);
    const add = button('Add segment', 'ghost', () => this.rows.add({ prompt: PROMPT, seconds: 4, seed: randomSeed() }, true));
    const genAll = button('Generate timeline', 'primary tl-generate', () => void this.generateAll().catch(() => undefined));
    const bar = el('div', 'tl-row-actions');
    bar.append(add, this.rows.total);
    for (const k of Object.keys(this.msgs) as EditKind[]) {
      this.msgs[k].setAttribute('role', 'alert');
      this.msgs[k].hidden = true;
      this.busy[k].setAttribute('aria-live', 'polite');
      this.busy[k].hidden = true;
    }
    body.append(el('h2', undefined, 'Timeline'), intro, this.rows.list, bar, genAll, this.busy.timeline, this.msgs.timeline);

    // ---- edits of the motion on screen
    const ibPrompt = input('tl-ib-prompt', 'New middle (prompt)', 'a person jumps up');
    const ibFirst = secondsInput('tl-ib-first', 'Keep the first seconds', 1);
    const ibLast = secondsInput('tl-ib-last', 'Keep the last seconds', 1);
    const ibKeep = el('span', 'tl-check');
    ibKeep.append(document.createTextNode('keep first '), ibFirst, document.createTextNode(' s, last '), ibLast, document.createTextNode(' s'));
    const ibGo = button('Regenerate the middle', 'ghost', () => void this.inBetween(ibPrompt.value, Number(ibFirst.value), Number(ibLast.value)).catch(() => undefined));
    const bodyKeep = el('select');
    bodyKeep.id = 'tl-body-keep';
    bodyKeep.setAttribute('aria-label', 'Which part to keep');
    for (const [v, t] of [['lower', 'Keep legs, new upper body'], ['upper', 'Keep upper body, new legs']] as const) {
      const o = el('option', undefined, t);
      o.value = v;
      bodyKeep.append(o);
    }
    const bodyPrompt = input('tl-body-prompt', 'New part (prompt)', 'a person raises both hands');
    const bodyGo = button('Edit body part', 'ghost', () => void this.bodyEdit(bodyKeep.value as KeptPart, bodyPrompt.value).catch(() => undefined));
    const inPlace = el('input');
    inPlace.type = 'checkbox';
    inPlace.id = 'tl-loop-in-place';
    const inPlaceLabel = el('label', 'tl-check');
    inPlaceLabel.append(inPlace, document.createTextNode(' in place (no travel)'));
    const windowS = fmtSeconds(page.session.limits.maxFrames / page.session.limits.fps);
    const loopGo = button('Make it loop', 'ghost', () => void this.loop(inPlace.checked).catch(() => undefined));
    body.append(
      el('h2', undefined, 'Edit the motion on screen'),
      el('p', 'tl-hint', `In-between and body-part edits work on a motion of one model window (up to ${windowS} s); a loop of a longer timeline regenerates its last ${windowS} s.`),
      group('In-between: keep the start and the end', ibKeep, ibPrompt, ibGo, this.busy.inbetween, this.msgs.inbetween),
      group('Body part', bodyKeep, bodyPrompt, bodyGo, this.busy.body, this.msgs.body),
      group('Loop: last pose = first pose', inPlaceLabel, loopGo, this.busy.loop, this.msgs.loop),
    );

    // ---- restore from the URL (a shared link), else one example row
    const tl = INITIAL.get(TIMELINE_PARAM);
    let restored: TimelineSegment[] | null = null;
    let refused = '';
    if (tl !== null) {
      try {
        restored = decodeTimeline(tl, this.actions);
      } catch (e) {
        refused = e instanceof Error ? e.message : String(e);
      }
    }
    for (const s of restored ?? [{ prompt: 'a person walks forward', seconds: 4, seed: randomSeed() }, { prompt: 'a person raises the right hand', seconds: 3, seed: randomSeed() }]) this.rows.add(s);
    if (tl !== null) details.open = true;
    this.rows.refreshTotal();
    this.restored = restored !== null;
    this.linkRefused = refused;
    this.linkValue = tl;
    if (refused) this.say(refused);
  }

  /** The URL held a timeline that could be read (the page generates it first instead of the single motion). */
  readonly restored: boolean;
  /**
   * Why the URL's timeline could not be read ('' when it could, or there was none): the page then generates
   * nothing on load (not the example rows, not the single motion), and the message stays in the open panel.
   */
  readonly linkRefused: string;
  /** The `tl` value of the link the page was opened with (null: none), as it was: the address keeps it until a motion
   * is shown, so a link refused (here, or when its timeline is planned) can still be seen, copied and mended. */
  readonly linkValue: string | null;

  get restoredFromUrl(): boolean {
    return this.restored;
  }

  /** The list as segments (what planTimeline checks). */
  segments(): TimelineSegment[] {
    return this.rows.segments();
  }

  setSegments(segs: TimelineSegment[]): void {
    this.rows.setSegments(segs);
  }

  // ------------------------------------------------------------ messages
  /** Say `text` next to `kind`'s controls (and clear every other mode's message), marking `segment`'s row: an error. */
  say(text: string, segment: number | null = null, kind: EditKind = 'timeline', tone: 'error' | 'note' = 'error'): void {
    for (const [k, m] of Object.entries(this.msgs)) {
      m.textContent = k === kind ? text : '';
      m.hidden = k !== kind || !text;
      // an error interrupts a screen reader (alert); news about a result waits its turn (status)
      const note = k === kind && tone === 'note';
      m.setAttribute('role', note ? 'status' : 'alert');
      m.classList.toggle('tl-note', note);
    }
    if (text) this.msgs[kind].scrollIntoView?.({ block: 'nearest' });
    this.rows.mark(segment);
  }

  /** Say `text` next to `kind`'s controls as news about the result on screen (not an error); '' says nothing. */
  note(text: string, kind: EditKind): void {
    if (text) this.say(text, null, kind, 'note');
  }

  /** The message shown in the panel ('' when none). */
  message(): string {
    return Object.values(this.msgs).find((m) => !m.hidden)?.textContent ?? '';
  }

  /** The progress line next to `kind`'s controls ('' hides it). */
  working(kind: EditKind, text: string): void {
    this.busy[kind].textContent = text;
    this.busy[kind].hidden = !text;
  }

  // ------------------------------------------------------------ generating
  private limits() {
    return { fps: this.page.session.limits.fps, maxFrames: this.page.session.limits.maxFrames };
  }

  /** The page's model for a condition (text → the text model, action → the action model). */
  modelFor(c: EditCondition): string {
    const m = c.action !== undefined ? this.page.session.models.action : this.page.session.models.text;
    if (!m) throw new EditError(c.action !== undefined ? 'no action model is shipped with this demo' : 'no text model is shipped with this demo: pick an action');
    return m.name;
  }

  private request(kind: EditKind, job: EditJob): Promise<EditSummary> {
    return runEditRequest(this, kind, job);
  }

  /** The result of a request is on screen: later edits start from its motion. */
  showed(s: Shown): void {
    this.current = s.motion;
    this.currentCondition = s.condition;
  }

  /** The page's decoding of joints made here (as generate() does for one motion: σ = 1 frame smoothing, feet on the floor). */
  private decode(features: Float32Array, frames: number, loop = false): Float32Array {
    return decodeJoints(features, frames, this.page.session.manifest.skeleton, { smooth: true, footCleanup: true, loop });
  }

  /** The motion the edit tools start from: the one on screen (the page's or this panel's), and its description. */
  private base(): { motion: EditMotion; condition: EditCondition | null; shown: Described } {
    const shown = this.page.view.shown;
    if (!shown) throw new EditError('there is no motion on screen yet: generate one first');
    const m = shown.result.motion;
    if (this.current && this.current.features === m.features) return { motion: this.current, condition: this.currentCondition, shown: described(shown) };
    const s = shown.state;
    const condition = s.mode === 'text' ? { prompt: s.text } : s.mode === 'action' ? { action: s.action } : null;
    return { motion: { frames: m.frames, fps: m.fps, features: m.features, joints: recoverJoints(m.features, m.frames) }, condition, shown: described(shown) };
  }

  // ------------------------------------------------------------ the four modes
  async generateAll(regenerated: number | null = null): Promise<EditSummary> {
    const segs = this.segments();
    try {
      planTimeline(segs, this.limits());
    } catch (e) {
      if (e instanceof EditError) this.say(e.message, e.segment);
      throw e;
    }
    history.replaceState(null, '', withTimeline(location.search, segs));
    // segments are reused only when made with the same steps and guidance as now
    const st = this.page.controls.readEmdm();
    const settings = `${st.steps}|${st.guidance}`;
    const previous = this.timelineSettings === settings ? this.timeline : null;
    return this.request('timeline', async (_gen, signal, calls) => {
      const { session } = this.page;
      let seg = 0;
      let doneWindows = 0;
      let todo = 1;
      calls.progress = (f) => (doneWindows + f) / todo;
      calls.text = (d, t) => `Segment ${seg + 1} of ${segs.length}${regenerated !== null ? ` (again from ${regenerated + 1})` : ''}: step ${d} / ${t}`;
      // every segment's model (an EditError naming the segment when the demo has none), loaded with the page's progress
      const models = [...new Set(segs.map((s) => this.modelFor(s)))];
      for (const m of models) await session.load(m);
      const r0 = performance.now();
      const r = await session.engine.timeline({
        segments: segs, steps: st.steps, guidance: st.guidance, previous,
        models: { text: session.models.text?.name, action: session.models.action?.name },
      }, {
        pose: true, signal, onStep: calls.step,
        onWindow: (s, done, total) => {
          seg = s;
          doneWindows = done;
          todo = Math.max(1, total);
        },
      });
      calls.worker = { requestMs: performance.now() - r0, totalMs: r.totalMs, beginMs: r.beginMs };
      calls.n = r.windows.length;
      calls.results.push(...r.windows);
      const t = r.timeline;
      this.timeline = t;
      this.timelineSettings = settings;
      const label = segs.map((s) => s.action ?? (s.prompt ?? '').trim()).join(' → ');
      const one = segs.every((s) => s.action === segs[0].action && (s.prompt ?? '').trim() === (segs[0].prompt ?? '').trim());
      return {
        motion: t, display: r.display, pose: r.pose, starts: t.starts, windows: calls.n, results: calls.results,
        label: label.length > 120 ? `${label.slice(0, 117)}…` : label, model: this.modelFor(segs[0]), seed: segs[0].seed,
        condition: one ? (segs[0].action !== undefined ? { action: segs[0].action } : { prompt: segs[0].prompt }) : null,
        source: { kind: 'timeline', segments: segs.map((g) => ({ ...g })), models: segs.map((g) => this.modelFor(g)), steps: st.steps, guidance: st.guidance },
      };
    }).then((r) => {
      // the URL says what is on screen: the page's state and the timeline (a reload restores the segments)
      history.replaceState(null, '', withTimeline(location.search, segs));
      return r;
    });
  }

  async regenerate(i: number): Promise<EditSummary> {
    if (!(i >= 0 && i < this.rows.length)) throw new RangeError(`regenerate: segment ${i + 1} outside 1…${this.rows.length}`);
    this.rows.reseed(i);
    return this.generateAll(i);
  }

  async inBetween(prompt: string, first = 1, last = 1): Promise<EditSummary> {
    return this.request('inbetween', async (gen, _signal, calls) => {
      const { motion, shown } = this.base();
      const c = { prompt };
      const seed = randomSeed();
      const range = inBetweenRange(motion, first, last, this.limits()); // in the fields' seconds where none is left
      const r = await inBetween(motion, c, seed, gen, this.limits(), range);
      return {
        motion: r, display: this.decode(r.features, r.frames), windows: 1, results: calls.results,
        label: `${prompt.trim()} (in-between)`, model: this.modelFor(c), seed, condition: c,
        source: editSource({ type: 'inbetween', keepFirstSeconds: first, keepLastSeconds: last }, c, seed, shown),
      };
    });
  }

  async bodyEdit(part: KeptPart, prompt: string): Promise<EditSummary> {
    return this.request('body', async (gen, _signal, calls) => {
      const { motion, shown } = this.base();
      const c = { prompt };
      const seed = randomSeed();
      const r = await bodyPartEdit(motion, part, c, seed, gen, this.limits());
      return {
        motion: r, display: this.decode(r.features, r.frames), windows: 1, results: calls.results,
        label: `${prompt.trim()} (${part === 'lower' ? 'upper body' : 'legs'} edited)`, model: this.modelFor(c), seed, condition: c,
        source: editSource({ type: 'body', kept: part }, c, seed, shown),
      };
    });
  }

  async loop(inPlace: boolean): Promise<EditSummary> {
    return this.request('loop', async (gen, _signal, calls) => {
      const { motion, condition: own, shown } = this.base();
      // a timeline of several prompts loops its last window with its last segment's prompt (src/edit.ts makeLoop)
      const last = this.timeline && motion.features === this.timeline.features ? this.timeline.segments.at(-1)?.segment : undefined;
      const condition = own ?? (last ? (last.action !== undefined ? { action: last.action } : { prompt: last.prompt }) : null);
      if (!condition) throw new EditError('looping keeps the motion\'s own prompt; this motion has none (a random motion): generate one from a prompt or an action first');
      const seed = randomSeed();
      const r = await makeLoop(motion, condition, seed, gen, this.limits(), { inPlace, decode: (f, n) => recoverJoints(f, n) });
      this.lastLoop = r.full;
      const what = condition.action !== undefined ? String(condition.action) : (condition.prompt ?? '').trim();
      const { fps, maxFrames } = this.limits();
      // longer than one window: only its end was regenerated, with its own prompt or the last segment's
      const note = motion.frames <= maxFrames ? '' : `Only the last ${fmtSeconds(maxFrames / fps)} s were regenerated (with ${quoted(what)}${own ? '' : ', the last segment\'s'}) to lead back to the first pose; the ${fmtSeconds((motion.frames - maxFrames) / fps)} s before them are as they were.`;
      return {
        note,
        motion: r.clip, display: this.decode(r.clip.features, r.clip.frames, true), windows: 1, results: calls.results,
        label: `${what} (loop${inPlace ? ', in place' : ''})`, model: this.modelFor(condition), seed, condition,
        source: editSource({ type: 'loop', inPlace }, condition, seed, shown),
      };
    });
  }

  /** window.emdm.edit */
  testApi(): EditTestApi {
    return {
      segments: () => this.segments(),
      setSegments: (s) => this.setSegments(s),
      generateAll: () => this.generateAll(),
      regenerate: (i) => this.regenerate(i),
      inBetween: (p, first, last) => this.inBetween(p, first, last),
      bodyEdit: (part, p) => this.bodyEdit(part, p),
      loop: (inPlace) => this.loop(inPlace),
      message: () => this.message(),
      current: () => {
        try {
          const { motion } = this.base();
          return { frames: motion.frames, fps: motion.fps, joints: Array.from(motion.joints), features: Array.from(motion.features) };
        } catch {
          return null;
        }
      },
      lastLoopFull: () => (this.lastLoop ? { frames: this.lastLoop.frames, joints: Array.from(this.lastLoop.joints) } : null),
    };
  }
}

/** An edit's source: its inputs, the condition and seed of its window, the motion it edited. */
function editSource(edit: EditInputs, condition: EditCondition, seed: number, base: Described): EditSource {
  return { kind: 'edit', edit, condition: { ...condition }, seed, base };
}

// ---------------------------------------------------------------- small DOM helpers
/** Seconds as the panel writes them: 9.8, 50.2, 4. */
function fmtSeconds(s: number): string {
  return String(Number(s.toFixed(2)));
}

/** A prompt box holding an example (a value, not only a grey placeholder: a visitor can run the tool at once). */
function input(id: string, label: string, example: string): HTMLInputElement {
  const i = el('input');
  i.type = 'text';
  i.id = id;
  i.value = example;
  i.placeholder = example;
  i.setAttribute('aria-label', label);
  return i;
}

function secondsInput(id: string, label: string, value: number): HTMLInputElement {
  const i = el('input', 'tl-seconds');
  i.type = 'number';
  i.id = id;
  i.min = '0.05';
  i.step = '0.05';
  i.value = String(value);
  i.setAttribute('aria-label', label);
  return i;
}

function group(title: string, ...children: HTMLElement[]): HTMLElement {
  const f = el('fieldset', 'tl-tool');
  f.append(el('legend', undefined, title), ...children);
  return f;
}
