// "Beyond one prompt" on the page (issue 14): a prompt timeline (segments of prompt or action + seconds,
// generated window by window far past the model's 196 frames, one segment regenerated without touching the
// ones before it, kept in the URL), and edits of the motion on screen: in-betweening (keep the first and
// last second, a new middle), body-part edits (keep the lower or upper body) and seamless loops (+ in place).
// The bookkeeping is src/edit.ts's; every generation runs in the generation worker through the page's
// session (progress, and the newest request wins: a new one cancels the running one at its next step). A
// timeline is one request: its windows, seam easing, stitching, decoding and IK all run in the worker
// (GenerationHost.timeline); the edits send their one window and decode here.
// The panel builds its DOM inside one container (#edit-panel in index.html) and styles it in timeline.css.
import { EditError, MAX_TIMELINE_SECONDS, bodyPartEdit, inBetween, makeLoop, type EditCondition, type EditGenerate, type EditMotion, type KeptPart, type Timeline, type TimelineSegment } from '../../src/index';
import { planTimeline } from '../../src/edit';
import { decodeJoints } from '../../src/motion/decode';
import { recoverJoints } from '../../src/motion/recover';
import type { GenerateResult } from '../../src/openModel';
import type { RemoteResult, WirePose } from '../../src/worker/client';
import type { WireBeginOptions } from '../../src/worker/protocol';
import type { PoseTrack } from '../../src/three';
import { el } from './dom';
import { isAbort } from './engine';
import type { Generation, PageContext } from './session';
import { randomSeed, type PageState } from './state';
import { TIMELINE_PARAM, decodeTimeline, withTimeline } from './timeline-url';
import './timeline.css';

/** Read before the page rewrites its URL (web/main.ts replaces it with the controls' state on start). */
const INITIAL = new URLSearchParams(location.search);

/** What the test API reports about the panel's last result. */
export interface EditSummary {
  kind: 'timeline' | 'inbetween' | 'body' | 'loop';
  frames: number;
  fps: number;
  /** timeline: the first frame of each segment */
  starts?: number[];
  /** wall time of the whole request on the page, ms */
  ms: number;
  /** model calls (one per denoising step and window) */
  windows: number;
  /** where `ms` went, ms: the worker's text encoding, denoising steps and decoding (summed over the windows), the
   * windows' early steps begun together (a timeline), the worker's own edit work (a timeline: seam easing,
   * stitching, decoding), the round trips beyond them (messages, copies, queueing), this thread's edit work (an
   * edit's easing and decoding; nothing else runs meanwhile), the IK solve (worker) and showing the result */
  parts: { encodeMs: number; stepMs: number; decodeMs: number; beginMs: number; workerEditMs: number; roundTripMs: number; mainMs: number; ikMs: number; showMs: number; windowStepMs: number[]; windowFrames: number[] };
}

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

interface Row {
  li: HTMLLIElement;
  kind: HTMLSelectElement;
  prompt: HTMLInputElement;
  seconds: HTMLInputElement;
  seed: number;
}

const PROMPT = '';

export class TimelinePanel {
  private readonly list = el('ol', 'tl-list');
  private readonly total = el('span', 'tl-total');
  /** each mode's message (errors) and progress line, shown next to that mode's controls */
  private readonly msgs: Record<EditSummary['kind'], HTMLElement> = { timeline: el('p', 'tl-message'), inbetween: el('p', 'tl-message'), body: el('p', 'tl-message'), loop: el('p', 'tl-message') };
  private readonly busy: Record<EditSummary['kind'], HTMLElement> = { timeline: el('p', 'tl-progress'), inbetween: el('p', 'tl-progress'), body: el('p', 'tl-progress'), loop: el('p', 'tl-progress') };
  private readonly rows: Row[] = [];
  /** the last generated timeline (its segments are reused when regenerating a later one) and the steps/guidance it ran with */
  private timeline: Timeline | null = null;
  private timelineSettings = '';
  /** the full N frames of the last loop */
  private lastLoop: EditMotion | null = null;
  /** the last motion this panel showed, with raw decoded joints, and its condition (null: several) */
  private current: EditMotion | null = null;
  private currentCondition: EditCondition | null = null;
  private readonly actions: readonly string[];

  constructor(private readonly page: PageContext, container: HTMLElement) {
    this.actions = page.session.limits.actions;
    const details = el('details', 'tl-panel');
    const summary = el('summary', undefined, 'Timeline & editing');
    const body = el('div', 'tl-body');
    details.append(summary, body);
    container.replaceChildren(details);

    // ---- timeline
    const intro = el('p', 'tl-hint', `Chain prompts up to ${MAX_TIMELINE_SECONDS} s: each segment continues from the last second of the one before.`);
    const add = this.button('Add segment', 'ghost', () => this.addRow({ prompt: PROMPT, seconds: 4, seed: randomSeed() }, true));
    const genAll = this.button('Generate timeline', 'primary tl-generate', () => void this.generateAll().catch(() => undefined));
    const bar = el('div', 'tl-row-actions');
    bar.append(add, this.total);
    for (const k of Object.keys(this.msgs) as EditSummary['kind'][]) {
      this.msgs[k].setAttribute('role', 'alert');
      this.msgs[k].hidden = true;
      this.busy[k].setAttribute('aria-live', 'polite');
      this.busy[k].hidden = true;
    }
    body.append(el('h2', undefined, 'Timeline'), intro, this.list, bar, genAll, this.busy.timeline, this.msgs.timeline);

    // ---- edits of the motion on screen
    const ibPrompt = this.input('tl-ib-prompt', 'New middle (prompt)', 'a person jumps up');
    const ibFirst = this.seconds('tl-ib-first', 'Keep the first seconds', 1);
    const ibLast = this.seconds('tl-ib-last', 'Keep the last seconds', 1);
    const ibKeep = el('span', 'tl-check');
    ibKeep.append(document.createTextNode('keep first '), ibFirst, document.createTextNode(' s, last '), ibLast, document.createTextNode(' s'));
    const ibGo = this.button('Regenerate the middle', 'ghost', () => void this.inBetween(ibPrompt.value, Number(ibFirst.value), Number(ibLast.value)).catch(() => undefined));
    const bodyKeep = el('select');
    bodyKeep.id = 'tl-body-keep';
    bodyKeep.setAttribute('aria-label', 'Which part to keep');
    for (const [v, t] of [['lower', 'Keep legs, new upper body'], ['upper', 'Keep upper body, new legs']] as const) {
      const o = el('option', undefined, t);
      o.value = v;
      bodyKeep.append(o);
    }
    const bodyPrompt = this.input('tl-body-prompt', 'New part (prompt)', 'a person waves with both hands');
    const bodyGo = this.button('Edit body part', 'ghost', () => void this.bodyEdit(bodyKeep.value as KeptPart, bodyPrompt.value).catch(() => undefined));
    const inPlace = el('input');
    inPlace.type = 'checkbox';
    inPlace.id = 'tl-loop-in-place';
    const inPlaceLabel = el('label', 'tl-check');
    inPlaceLabel.append(inPlace, document.createTextNode(' in place (no travel)'));
    const loopGo = this.button('Make it loop', 'ghost', () => void this.loop(inPlace.checked).catch(() => undefined));
    body.append(
      el('h2', undefined, 'Edit the motion on screen'),
      el('p', 'tl-hint', 'Works on a motion of one model window (up to 9.8 s).'),
      this.group('In-between: keep the start and the end', ibKeep, ibPrompt, ibGo, this.busy.inbetween, this.msgs.inbetween),
      this.group('Body part', bodyKeep, bodyPrompt, bodyGo, this.busy.body, this.msgs.body),
      this.group('Loop: last pose = first pose', inPlaceLabel, loopGo, this.busy.loop, this.msgs.loop),
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
    for (const s of restored ?? [{ prompt: 'a person walks forward', seconds: 4, seed: randomSeed() }, { prompt: 'a person waves with the right hand', seconds: 3, seed: randomSeed() }]) this.addRow(s);
    if (tl !== null) details.open = true;
    this.refreshTotal();
    this.restored = restored !== null;
    this.linkRefused = refused;
    if (refused) this.say(refused);
  }

  /** The URL held a timeline that could be read (the page generates it first instead of the single motion). */
  readonly restored: boolean;
  /**
   * Why the URL's timeline could not be read ('' when it could, or there was none): the page then generates
   * nothing on load (not the example rows, not the single motion), and the message stays in the open panel.
   */
  readonly linkRefused: string;

  get restoredFromUrl(): boolean {
    return this.restored;
  }

  // ------------------------------------------------------------ rows
  private addRow(s: TimelineSegment, focus = false): void {
    const li = el('li', 'tl-seg');
    const kind = el('select', 'tl-kind');
    const p = el('option', undefined, 'Prompt');
    p.value = '';
    kind.append(p);
    for (const a of this.actions) {
      const o = el('option', undefined, a.replace(/[_-]+/g, ' '));
      o.value = a;
      kind.append(o);
    }
    kind.value = s.action !== undefined ? String(s.action) : '';
    const prompt = el('input', 'tl-prompt');
    prompt.type = 'text';
    prompt.value = s.prompt ?? '';
    prompt.placeholder = 'what the character does';
    const seconds = el('input', 'tl-seconds');
    seconds.type = 'number';
    seconds.min = '0';
    seconds.max = String(MAX_TIMELINE_SECONDS);
    seconds.step = '0.1';
    seconds.value = String(s.seconds);
    const row: Row = { li, kind, prompt, seconds, seed: s.seed >>> 0 };
    const up = this.button('↑', 'icon', () => this.move(row, -1));
    const down = this.button('↓', 'icon', () => this.move(row, 1));
    const again = this.button('↻', 'icon', () => void this.regenerate(this.rows.indexOf(row)).catch(() => undefined));
    const remove = this.button('✕', 'icon', () => this.remove(row));
    const unit = el('span', 'tl-unit', 's');
    // the prompt first (its own line), then prompt-or-action, seconds and the buttons: the Tab order is the reading order;
    // the buttons wrap to a line of their own where the selector's longest label and the seconds leave them no room
    const buttons = el('span', 'tl-seg-buttons');
    buttons.append(up, down, again, remove);
    const controls = el('div', 'tl-seg-controls');
    controls.append(kind, seconds, unit, buttons);
    li.append(el('span', 'tl-num'), prompt, controls);
    const sync = () => {
      prompt.disabled = kind.value !== '';
      this.refreshTotal();
    };
    kind.addEventListener('change', sync);
    seconds.addEventListener('input', () => this.refreshTotal());
    prompt.addEventListener('keydown', (e) => {
      if (e.key === 'Enter') void this.generateAll().catch(() => undefined);
    });
    this.rows.push(row);
    this.list.append(li);
    sync();
    this.relabel();
    if (focus) prompt.focus();
  }

  private move(row: Row, d: number): void {
    const i = this.rows.indexOf(row);
    const j = i + d;
    if (j < 0 || j >= this.rows.length) return;
    this.rows.splice(i, 1);
    this.rows.splice(j, 0, row);
    this.list.replaceChildren(...this.rows.map((r) => r.li));
    this.relabel();
    (d < 0 ? row.li.querySelector<HTMLButtonElement>('button[data-k="↑"]') : row.li.querySelector<HTMLButtonElement>('button[data-k="↓"]'))?.focus();
  }

  private remove(row: Row): void {
    if (this.rows.length === 1) {
      this.say('A timeline needs at least one segment.');
      return;
    }
    const i = this.rows.indexOf(row);
    this.rows.splice(i, 1);
    row.li.remove();
    this.relabel();
    this.refreshTotal();
    this.rows[Math.min(i, this.rows.length - 1)].prompt.focus();
  }

  /** Numbers and accessible names follow the order. */
  private relabel(): void {
    this.rows.forEach((r, i) => {
      const n = i + 1;
      r.li.querySelector('.tl-num')!.textContent = `${n}`;
      r.kind.setAttribute('aria-label', `Segment ${n}: prompt or action`);
      r.prompt.setAttribute('aria-label', `Segment ${n} prompt`);
      r.seconds.setAttribute('aria-label', `Segment ${n} seconds`);
      for (const b of r.li.querySelectorAll<HTMLButtonElement>('button')) {
        const k = b.dataset.k;
        const what = k === '↑' ? 'Move up' : k === '↓' ? 'Move down' : k === '↻' ? 'Regenerate (new take; keeps the segments before it)' : 'Remove';
        b.setAttribute('aria-label', `Segment ${n}: ${what}`);
        b.title = what;
      }
      r.li.classList.remove('invalid');
      r.li.removeAttribute('aria-invalid');
    });
  }

  private refreshTotal(): void {
    const s = this.segments().reduce((a, x) => a + (Number.isFinite(x.seconds) ? x.seconds : 0), 0);
    this.total.textContent = `${Number(s.toFixed(2))} s of ${MAX_TIMELINE_SECONDS} s`;
    this.total.classList.toggle('over', s > MAX_TIMELINE_SECONDS);
  }

  /** The list as segments (what planTimeline checks). */
  segments(): TimelineSegment[] {
    return this.rows.map((r) => {
      const seconds = r.seconds.value.trim() === '' ? NaN : Number(r.seconds.value);
      return r.kind.value ? { action: r.kind.value, seconds, seed: r.seed } : { prompt: r.prompt.value, seconds, seed: r.seed };
    });
  }

  setSegments(segs: TimelineSegment[]): void {
    this.rows.length = 0;
    this.list.replaceChildren();
    for (const s of segs) this.addRow(s);
    this.refreshTotal();
  }

  // ------------------------------------------------------------ messages
  /** Say `text` next to `kind`'s controls (and clear every other mode's message), marking `segment`'s row. */
  private say(text: string, segment: number | null = null, kind: EditSummary['kind'] = 'timeline'): void {
    for (const [k, m] of Object.entries(this.msgs)) {
      m.textContent = k === kind ? text : '';
      m.hidden = k !== kind || !text;
    }
    if (text) this.msgs[kind].scrollIntoView?.({ block: 'nearest' });
    this.rows.forEach((r, i) => {
      r.li.classList.toggle('invalid', i === segment);
      if (i === segment) r.li.setAttribute('aria-invalid', 'true');
      else r.li.removeAttribute('aria-invalid');
    });
  }

  /** The message shown in the panel ('' when none). */
  message(): string {
    return Object.values(this.msgs).find((m) => !m.hidden)?.textContent ?? '';
  }

  /** The progress line next to `kind`'s controls ('' hides it). */
  private working(kind: EditSummary['kind'], text: string): void {
    this.busy[kind].textContent = text;
    this.busy[kind].hidden = !text;
  }

  // ------------------------------------------------------------ generating
  private limits() {
    return { fps: this.page.session.limits.fps, maxFrames: this.page.session.limits.maxFrames };
  }

  /** A window's condition, frames and seed with the page's steps and guidance, as the worker takes them. */
  private wire(r: EditCondition & { frames: number; seed: number }, state: PageState): Pick<WireBeginOptions, 'condition' | 'frames' | 'steps' | 'guidance' | 'seed'> {
    const label = r.action !== undefined ? this.actions.indexOf(String(r.action)) : -1;
    return {
      condition: r.action !== undefined ? { type: 'action', label } : { type: 'text', text: r.prompt ?? '' },
      frames: r.frames, steps: state.steps, guidance: state.guidance, seed: r.seed,
    };
  }

  /** The page's model for a condition (text → the text model, action → the action model). */
  private modelFor(c: EditCondition): string {
    const m = c.action !== undefined ? this.page.session.models.action : this.page.session.models.text;
    if (!m) throw new EditError(c.action !== undefined ? 'no action model is shipped with this demo' : 'no text model is shipped with this demo: pick an action');
    return m.name;
  }

  /**
   * Run `job` as the page's newest request (cancelling a running one), with progress, the busy button and
   * errors said in the panel; the result is shown on the character.
   */
  private async request(kind: EditSummary['kind'], job: (gen: EditGenerate, signal: AbortSignal, calls: Calls) => Promise<Shown>): Promise<EditSummary> {
    const { session, view, controls } = this.page;
    const state = controls.read();
    const t0 = performance.now();
    this.say('', null, kind);
    for (const k of Object.keys(this.busy) as EditSummary['kind'][]) this.working(k, '');
    this.working(kind, 'Starting…');
    controls.setBusy(true);
    view.showProgress(0, 'Starting…');
    session.counters.requests++;
    try {
      let genMs = 0;
      let jobMs = 0;
      const calls: Calls = {
        n: 0, results: [], progress: (f) => f, text: (d, t) => `Denoising step ${d} / ${t}`,
        beginText: (w, d, t) => `${w} window${w === 1 ? '' : 's'} together: step ${d} / ${t}`,
        step: (d, t, together) => {
          if (!together) session.counters.stepsRun++;
          const text = together ? calls.beginText(together, d, t) : calls.text(d, t);
          view.showProgress(calls.progress(d / t), text);
          this.working(kind, `${text} (${Math.round(100 * calls.progress(d / t))} %)`);
        },
        worker: null,
      };
      const shown = await session.engine.run(async (signal) => {
        const gen: EditGenerate = async (r) => {
          const g0 = performance.now();
          const model = this.modelFor(r);
          await session.load(model);
          // through the engine: the file the page's own generations run (the manifest's default variant, e.g. int8);
          // no pose track per window (the stitched motion is solved once, below)
          const res: RemoteResult = await session.engine.generate(model, {
            pose: false, ...this.wire(r, state), signal,
            // copies: the client transfers these buffers to the worker, and src/edit.ts reads `keep` again after
            ...(r.known ? { known: { ...r.known, features: r.known.features.slice(), keep: r.known.keep.slice() } } : {}),
            ...(r.resume ? { resume: r.resume } : {}),
            onStep: (d, t) => calls.step(d, t, 0),
          });
          calls.n++;
          calls.results.push({ ...res, frames: res.motion.frames });
          genMs += performance.now() - g0;
          return { frames: res.motion.frames, fps: res.motion.fps, features: res.motion.features, joints: res.motion.joints };
        };
        const j0 = performance.now();
        const out = await job(gen, signal, calls);
        jobMs = performance.now() - j0;
        return out;
      });
      const s0 = performance.now();
      const track = shown.pose ? this.track(shown.pose, shown.motion) : await this.solve(shown.display, shown.motion);
      const s1 = performance.now();
      this.show(state, shown, track, s1 - t0);
      const s2 = performance.now();
      session.counters.generations++;
      const sum = (f: (r: Run) => number) => shown.results.reduce((a, r) => a + f(r), 0);
      const windowsMs = sum((r) => r.timings.totalMs);
      // a timeline ran whole in the worker (calls.worker); an edit's window came back here to be eased and decoded
      const w = calls.worker;
      const parts = {
        encodeMs: sum((r) => r.timings.encodeMs), stepMs: sum((r) => r.timings.stepMs.reduce((a, b) => a + b, 0)), decodeMs: sum((r) => r.timings.decodeMs),
        beginMs: w?.beginMs ?? 0, workerEditMs: w ? w.totalMs - w.beginMs - windowsMs : 0,
        roundTripMs: w ? w.requestMs - w.totalMs : genMs - windowsMs, mainMs: jobMs - (w ? w.requestMs : genMs),
        ikMs: shown.pose ? shown.pose.ikMs : s1 - s0, showMs: s2 - s1,
        windowStepMs: shown.results.map((r) => r.timings.stepMs.reduce((a, b) => a + b, 0)), windowFrames: shown.results.map((r) => r.frames),
      };
      return { kind, frames: shown.motion.frames, fps: shown.motion.fps, starts: shown.starts, ms: performance.now() - t0, windows: shown.windows, parts };
    } catch (e) {
      if (isAbort(e)) session.counters.cancelled++;
      else {
        session.counters.errors++;
        this.say(e instanceof EditError || e instanceof Error ? e.message : String(e), e instanceof EditError ? e.segment : null, kind);
      }
      throw e;
    } finally {
      this.working(kind, '');
      if (!session.busy) {
        controls.setBusy(false);
        view.hideProgress();
      }
    }
  }

  /** The pose track of bone rotations the worker solved with the motion. */
  private track(p: WirePose, m: EditMotion): PoseTrack {
    return { frames: m.frames, fps: m.fps, joints: this.page.session.manifest.skeleton.joints.length, rootPos: p.rootPos, quats: p.quats };
  }

  /** Bone rotations (the worker's IK) for the joints shown. */
  private async solve(joints: Float32Array, m: EditMotion): Promise<PoseTrack> {
    const p = await this.page.session.engine.client.solve(joints, m.frames);
    return { frames: m.frames, fps: m.fps, joints: this.page.session.manifest.skeleton.joints.length, rootPos: p.rootPos, quats: p.quats };
  }

  /** The page's decoding of joints made here (as generate() does for one motion: σ = 1 frame smoothing, feet on the floor). */
  private decode(features: Float32Array, frames: number): Float32Array {
    return decodeJoints(features, frames, this.page.session.manifest.skeleton, { smooth: true, footCleanup: true });
  }

  private show(state: PageState, s: Shown, track: PoseTrack, ms: number): void {
    // the timings of everything this request generated (nothing, when an unchanged timeline is shown again)
    const results = s.results;
    const first = results[0];
    const sum = (f: (r: Run) => number) => results.reduce((a, r) => a + f(r), 0);
    const result: GenerateResult = {
      motion: { frames: s.motion.frames, fps: s.motion.fps, joints: s.display, features: s.motion.features },
      timings: {
        encodeMs: sum((r) => r.timings.encodeMs), stepMs: results.flatMap((r) => r.timings.stepMs), decodeMs: sum((r) => r.timings.decodeMs),
        totalMs: ms, backend: first?.timings.backend ?? (this.page.session.backend === 'webgpu' ? 'webgpu' : 'wasm'), threads: first?.timings.threads ?? 0,
      },
      modelCalls: sum((r) => r.modelCalls), sampler: first?.sampler ?? 'ddgan', steps: first?.steps ?? state.steps,
    };
    const g: Generation = {
      state: { ...state, seconds: s.motion.frames / s.motion.fps, compare: false, seed: s.seed },
      label: s.label, plan: null,
      main: { model: s.model, result, track, ikMs: 0 },
      ddim: null,
    };
    this.page.view.show(g);
    this.current = s.motion;
    this.currentCondition = s.condition;
  }

  /** The motion the edit tools start from: the one on screen (the page's or this panel's). */
  private base(): { motion: EditMotion; condition: EditCondition | null } {
    const shown = this.page.view.shown;
    if (!shown) throw new EditError('there is no motion on screen yet: generate one first');
    const m = shown.result.motion;
    if (this.current && this.current.features === m.features) return { motion: this.current, condition: this.currentCondition };
    const s = shown.state;
    const condition = s.mode === 'text' ? { prompt: s.text } : s.mode === 'action' ? { action: s.action } : null;
    return { motion: { frames: m.frames, fps: m.fps, features: m.features, joints: recoverJoints(m.features, m.frames) }, condition };
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
    const st = this.page.controls.read();
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
      };
    }).then((r) => {
      // the URL says what is on screen: the page's state and the timeline (a reload restores the segments)
      history.replaceState(null, '', withTimeline(location.search, segs));
      return r;
    });
  }

  async regenerate(i: number): Promise<EditSummary> {
    if (!(i >= 0 && i < this.rows.length)) throw new RangeError(`regenerate: segment ${i + 1} outside 1…${this.rows.length}`);
    this.rows[i].seed = randomSeed();
    return this.generateAll(i);
  }

  async inBetween(prompt: string, first = 1, last = 1): Promise<EditSummary> {
    return this.request('inbetween', async (gen, _signal, calls) => {
      const { motion } = this.base();
      const c = { prompt };
      const seed = randomSeed();
      const fps = motion.fps;
      if (!(first > 0) || !(last > 0)) throw new EditError(`in-betweening: keep more than 0 s at each end (got first ${first} s, last ${last} s)`);
      // keep frames 0…a and b…N−1
      const range = { a: Math.round(first * fps) - 1, b: motion.frames - Math.round(last * fps) };
      const r = await inBetween(motion, c, seed, gen, this.limits(), range);
      return {
        motion: r, display: this.decode(r.features, r.frames), windows: 1, results: calls.results,
        label: `${prompt.trim()} (in-between)`, model: this.modelFor(c), seed, condition: c,
      };
    });
  }

  async bodyEdit(part: KeptPart, prompt: string): Promise<EditSummary> {
    return this.request('body', async (gen, _signal, calls) => {
      const { motion } = this.base();
      const c = { prompt };
      const seed = randomSeed();
      const r = await bodyPartEdit(motion, part, c, seed, gen, this.limits());
      return {
        motion: r, display: this.decode(r.features, r.frames), windows: 1, results: calls.results,
        label: `${prompt.trim()} (${part === 'lower' ? 'upper body' : 'legs'} edited)`, model: this.modelFor(c), seed, condition: c,
      };
    });
  }

  async loop(inPlace: boolean): Promise<EditSummary> {
    return this.request('loop', async (gen, _signal, calls) => {
      const { motion, condition: own } = this.base();
      // a timeline of several prompts loops its last window with its last segment's prompt (src/edit.ts makeLoop)
      const last = this.timeline && motion.features === this.timeline.features ? this.timeline.segments.at(-1)?.segment : undefined;
      const condition = own ?? (last ? (last.action !== undefined ? { action: last.action } : { prompt: last.prompt }) : null);
      if (!condition) throw new EditError('looping keeps the motion\'s own prompt; this motion has none (a random motion): generate one from a prompt or an action first');
      const seed = randomSeed();
      const r = await makeLoop(motion, condition, seed, gen, this.limits(), { inPlace, decode: (f, n) => recoverJoints(f, n) });
      this.lastLoop = r.full;
      const what = condition.action !== undefined ? String(condition.action) : (condition.prompt ?? '').trim();
      return {
        motion: r.clip, display: this.decode(r.clip.features, r.clip.frames), windows: 1, results: calls.results,
        label: `${what} (loop${inPlace ? ', in place' : ''})`, model: this.modelFor(condition), seed, condition,
      };
    });
  }

  // ------------------------------------------------------------ small DOM helpers
  private button(text: string, cls: string, on: () => void): HTMLButtonElement {
    const b = el('button', cls, text);
    b.type = 'button';
    b.dataset.k = text;
    b.addEventListener('click', on);
    return b;
  }

  /** A prompt box holding an example (a value, not only a grey placeholder: a visitor can run the tool at once). */
  private input(id: string, label: string, example: string): HTMLInputElement {
    const i = el('input');
    i.type = 'text';
    i.id = id;
    i.value = example;
    i.placeholder = example;
    i.setAttribute('aria-label', label);
    return i;
  }

  private seconds(id: string, label: string, value: number): HTMLInputElement {
    const i = el('input', 'tl-seconds');
    i.type = 'number';
    i.id = id;
    i.min = '0.05';
    i.step = '0.05';
    i.value = String(value);
    i.setAttribute('aria-label', label);
    return i;
  }

  private group(title: string, ...children: HTMLElement[]): HTMLElement {
    const f = el('fieldset', 'tl-tool');
    f.append(el('legend', undefined, title), ...children);
    return f;
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

/** What a mode hands back to be shown. */
interface Shown {
  /** the motion as src/edit.ts made it (raw decoded joints: what later edits start from) */
  motion: EditMotion;
  /** the joints shown and exported (smoothed, feet cleaned up as the page does) */
  display: Float32Array;
  starts?: number[];
  windows: number;
  results: Run[];
  /** bone rotations of `display`, when the worker solved them with the motion (a timeline) */
  pose?: WirePose;
  label: string;
  model: string;
  seed: number;
  condition: EditCondition | null;
}

/** What one window's generation took (a GenerateResult without its motion). */
type Run = Pick<GenerateResult, 'timings' | 'modelCalls' | 'sampler' | 'steps'> & { frames: number };

/** The generations of one request, and how its progress and label read (a timeline sets them per window). */
interface Calls {
  n: number;
  results: Run[];
  progress(f: number): number;
  text(done: number, total: number): string;
  /** while `windows` windows are begun together (a timeline) */
  beginText(windows: number, done: number, total: number): string;
  /** a denoising step: progress bar and line (`together` windows begun at once, or 0: one window) */
  step(done: number, total: number, together: number): void;
  /** a timeline run whole in the worker: the request's time here, the worker's, and its windows begun together */
  worker: { requestMs: number; totalMs: number; beginMs: number } | null;
}
