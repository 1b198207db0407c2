// Live mode (issue 33): the Live toggle turns the page into one endless motion. A live stream of the library
// (src/createGenerator.ts liveOn, src/live/stream.ts) runs on the page's own worker session; every displayed frame
// poses the character from stream.frameAt(now) (the view's PoseDriver: the built-in character's pose path, and the
// visitor's character, which is handed the stream's buffered frames as short pieces to retarget, as any motion); the
// camera follows it. Enter in the prompt box and the example chips send their prompt to the stream (the prompt box
// keeps the focus); the strip lists the last prompts with their times on the live clock; "Record" makes the last 60 s
// the page's motion (its downloads). Steps or guidance changed while live start a new stream (the old one plays until
// it is ready); another mode turns live mode off, saying so. Nothing here runs a model: the worker does.
import { type LiveFrame, type LiveStats, type LiveStream } from '../../src/index';
import { type LiveHost, liveOn } from '../../src/createGenerator';
import type { GenerateResult } from '../../src/openModel';
import { resolveRequest } from '../../src/requests';
import { samplePose, type PoseTrack } from '../../src/three';
import { byId, el } from './dom';
import { fileStem } from './downloads';
import type { KnowsPanel } from './knows';
import type { Notices } from './notices';
import type { PageContext } from './page-context';
import { liveSource } from './provenance';
import type { Generation } from './session';
import type { PoseDriver } from './view';
import { describe } from './view';

/** Prompts listed in the strip (the newest last). */
export const STRIP_PROMPTS = 8;
/** How often the strip and the visitor's character's piece of the stream are brought up to date, ms. */
const POLL_MS = 200;
/** A new piece for the visitor's character when the one it plays has less than this left, s. */
const PIECE_MARGIN_S = 0.6;

/** One prompt sent in live mode: its text, when (live clock, s) and its latency to the first new frame (s; null until it plays). */
export interface LivePrompt {
  text: string;
  at: number;
  latency: number | null;
}

/** What the page's tests read (window.emdm.live). */
export interface LiveTestApi {
  /** a stream is playing (false while the first one starts) */
  readonly active: boolean;
  /** the toggle is on (a stream is playing or starting) */
  readonly on: boolean;
  /** the stream's figures (null when no stream plays) */
  stats(): LiveStats | null;
  /** frames the page displayed from the stream, and how many showed exactly the pose of the one before */
  readonly displayed: number;
  readonly repeated: number;
  /** ms this thread spent posing displayed frames from the stream (frameAt, IK, interpolation), in all */
  readonly poseMs: number;
  /** the pose shown last: the live clock (s), the root (stage coordinates) */
  last(): { time: number; root: [number, number, number] } | null;
  /** the stream frame under the pose shown last (the earlier of the two it was interpolated from): its number and
   * its 22 × 3 joints (stage coordinates, metres; the pelvis is joints 0–2) */
  shownFrame(): { frame: number; joints: number[] } | null;
  prompts(): LivePrompt[];
  /** streams started and closed this visit */
  readonly started: number;
  readonly closed: number;
}

export class LivePanel implements PoseDriver {
  private readonly toggle = byId('live', HTMLButtonElement);
  private readonly panel = byId('live-panel');
  private readonly hint = byId('live-hint');
  private readonly strip = byId('live-prompts', HTMLOListElement);
  private readonly recordButton = byId('live-record', HTMLButtonElement);
  private readonly prompt = byId('prompt', HTMLTextAreaElement);
  private stream: LiveStream | null = null;
  /** requests to start a stream (a newer one or leaving live mode makes an older start close its stream) */
  private starts = 0;
  private on = false;
  private readonly log: LivePrompt[] = [];
  private latencies = 0;
  /** the sent prompt whose "unknown prompt" notice is still to be shown */
  private unchecked: string | null = null;
  /** the recording that stays when live mode is left */
  private recorded: Generation | null = null;
  /** the playing stream's seed, steps and guidance (a recording's JSON names them: web/ui/provenance.ts) */
  private made = { seed: 0, steps: 0, guidance: 0 };
  private displayed = 0;
  private repeated = 0;
  private poseMs = 0;
  private readonly root = new Float32Array(3);
  private quats = new Float32Array(0);
  private readonly prev = { root: new Float32Array(3), quats: new Float32Array(0), shown: false, time: 0 };
  /** the stream frame under the pose shown last (a reference to the stream's frame, not a copy) */
  private shownFrame: { frame: number; joints: Float32Array } | null = null;
  /** the piece of the stream the visitor's character was given: from/to on the live clock, windows seen then */
  private piece: { from: number; to: number; windows: number; origin: readonly [number, number] } | null = null;
  private timer = 0;
  private counts = { started: 0, closed: 0 };

  constructor(private readonly page: PageContext, private readonly knows: KnowsPanel, private readonly notices: Notices) {
    const text = page.session.models.text;
    this.toggle.disabled = !text;
    if (!text) this.toggle.title = 'Live mode needs a text model, and this demo ships none';
    this.toggle.addEventListener('click', () => (this.on ? this.stop() : void this.start()));
    this.recordButton.addEventListener('click', () => void this.record());
    // steps or guidance changed while live: a new stream with them (the old one plays until it is ready)
    for (const id of ['steps', 'guidance']) byId(id).addEventListener('change', () => {
      if (this.on) void this.start(`Restarting with ${page.controls.readEmdm().steps} steps, guidance ${page.controls.readEmdm().guidance.toFixed(1)}…`);
    });
    for (const tab of Array.from(document.querySelectorAll<HTMLButtonElement>('.modes [data-mode]'))) {
      tab.addEventListener('click', () => {
        if (this.on && tab.dataset.mode !== 'text') {
          this.stop();
          this.notices.show('info', 'Live mode takes text prompts: it was turned off when you chose another mode.');
        }
      });
    }
  }

  // ------------------------------------------------------------ the stream
  /** Turn live mode on (or start a new stream with the controls' settings): the current prompt plays first. */
  private async start(note = 'Starting the live stream…'): Promise<void> {
    const { controls, session, view } = this.page;
    const model = session.models.text;
    if (!model) return;
    const token = ++this.starts;
    this.setOn(true);
    this.say(note);
    controls.setMode('text');
    const s = controls.readEmdm();
    const first = s.text.trim() || session.limits.defaultText;
    session.engine.cancel(); // a generation under way gives way to the stream
    let stream: LiveStream;
    try {
      await session.load(model.name);
      this.unchecked = first;
      const client = this.page.session.engine.client;
      stream = await liveOn(this.host(), { prompt: first, seed: s.seed, steps: s.steps, guidance: s.guidance },
        (joints, frames) => client.solve(joints, frames));
    } catch (e) {
      if (token !== this.starts) return;
      this.notices.show('error', `Live mode could not start: ${describe(e)}`);
      if (!this.stream) this.stop();
      else this.say(`The live stream goes on with its old settings: ${describe(e)}`);
      return;
    }
    if (token !== this.starts) {
      await stream.close();
      return;
    }
    const old = this.stream;
    this.stream = stream;
    this.made = { seed: s.seed, steps: s.steps, guidance: s.guidance };
    this.counts.started++;
    if (old) this.closeStream(old);
    this.piece = null;
    this.prev.shown = false;
    this.log.length = 0;
    this.latencies = 0;
    this.add({ text: first, at: 0, latency: null });
    view.drive(this);
    view.liveCaption(first, this.page.controls.readEmdm().steps);
    clearInterval(this.timer);
    this.timer = window.setInterval(() => this.poll(), POLL_MS);
    // the compare view's DDIM character has no stream of its own: live mode is EMDM's alone
    const alone = controls.read().compare ? ' Compare is off while live: the stream is EMDM\'s alone.' : '';
    this.say(`Live: type a prompt and press Enter; the character blends into it.${alone}`);
    this.prompt.focus();
  }

  /** Leave live mode: the stream closes; the last recording (else the motion shown before) plays again. */
  private stop(): void {
    this.starts++;
    clearInterval(this.timer);
    if (this.stream) this.closeStream(this.stream);
    this.stream = null;
    this.setOn(false);
    this.page.view.drive(null);
    const shown = this.page.view.shown;
    if (this.recorded) this.page.view.show(this.recorded);
    else if (shown) this.page.view.picker.setMotion(shown.result.motion, fileStem(shown.label, shown.state.seed));
    this.say('');
  }

  private closeStream(s: LiveStream): void {
    this.counts.closed++;
    void s.close();
  }

  private setOn(on: boolean): void {
    this.on = on;
    this.toggle.setAttribute('aria-pressed', String(on));
    this.toggle.textContent = on ? 'Live · on' : 'Live';
    this.panel.hidden = !on;
    this.page.controls.setLive(on ? (text) => this.send(text) : null);
  }

  /** The page's worker session as the stream's generator: each window a generate on the text model, its prompt checked. */
  private host(): LiveHost {
    const { session } = this.page;
    return {
      manifest: session.manifest, skeleton: session.manifest.skeleton,
      generate: async (req) => {
        const { model, options } = resolveRequest(session.manifest, req);
        const r = await session.engine.generate(model, { ...options, pose: false, signal: req.signal });
        if (req.prompt !== undefined && req.prompt === this.unchecked) {
          this.unchecked = null;
          this.knows.showCheck(req.prompt, r.promptCheck);
        }
        return r.motion;
      },
    };
  }

  /** A prompt for the stream (Enter, an example chip): what comes next. */
  send(raw: string): void {
    const text = raw.trim();
    const s = this.stream;
    if (!s) return this.say(this.on ? 'The live stream is still starting: send the prompt once it plays.' : '');
    if (!text) return this.say('Type what the character should do next, then press Enter.');
    try {
      s.prompt(text);
    } catch (e) {
      this.say(`That prompt was not sent: ${describe(e)}`);
      return;
    }
    this.unchecked = text;
    this.knows.hideCheck();
    this.add({ text, at: s.now(), latency: null });
    this.say(`Sent “${text}”.`);
    this.prompt.focus();
  }

  // ------------------------------------------------------------ every displayed frame (PoseDriver)
  time(): number {
    return this.stream?.now() ?? 0;
  }

  /** The pose at the live clock's now: the stream's two frames around it, interpolated as the player does. */
  pose(): { root: ArrayLike<number>; quats: ArrayLike<number>; offsets?: Float32Array } | null {
    const s = this.stream;
    if (!s) return null;
    let track: PoseTrack;
    const t0 = performance.now();
    const t = s.now();
    const f = Math.floor(t * s.fps);
    try {
      const pair = framePair(s, f);
      track = pair.track;
      this.shownFrame = pair.shown;
      // the stage moved under the playhead (whole metres, as a walk goes on): the visitor's character's piece is on
      // the old one, so it gets a new piece now rather than walk a metre or more off the camera until the next poll
      // until that piece is on it, the one it plays is drawn moved onto the stage shown
      this.page.view.picker.stageAt(pair.origin);
      const o = this.piece?.origin;
      if (o && (o[0] !== pair.origin[0] || o[1] !== pair.origin[1])) this.feedCharacter(s, s.stats(), true);
    } catch (e) {
      this.notices.show('error', `Live mode stopped: ${describe(e)}`);
      this.stop();
      return null;
    }
    if (this.quats.length !== track.quats.length / 2) this.quats = new Float32Array(track.quats.length / 2);
    samplePose(track, t - f / s.fps, this.root, this.quats);
    this.count(t);
    this.poseMs += performance.now() - t0;
    return { root: this.root, quats: this.quats, ...(track.offsets ? { offsets: track.offsets } : {}) };
  }

  /** Count a displayed frame, and whether it showed exactly the pose of the one before. */
  private count(t: number): void {
    const p = this.prev;
    if (p.shown && sameValues(p.root, this.root) && sameValues(p.quats, this.quats)) this.repeated++;
    this.displayed++;
    p.root.set(this.root);
    if (p.quats.length !== this.quats.length) p.quats = new Float32Array(this.quats.length);
    p.quats.set(this.quats);
    p.shown = true;
    p.time = t;
  }

  // ------------------------------------------------------------ strip, visitor's character
  private poll(): void {
    const s = this.stream;
    if (!s) return;
    const st = s.stats();
    // a latency that arrives belongs to the newest prompt: a newer prompt drops the window of the one before
    if (st.latencies.length !== this.latencies) {
      this.latencies = st.latencies.length;
      const last = this.log[this.log.length - 1];
      if (last && last.latency === null && this.log.length > 1) {
        last.latency = st.latencies[st.latencies.length - 1];
        this.render();
        this.page.view.liveCaption(last.text, this.page.controls.readEmdm().steps);
      }
    }
    this.feedCharacter(s, st);
  }

  /** The visitor's character, when one is on the stage: the stream's frames from now to what is made, retargeted as a piece. */
  private feedCharacter(s: LiveStream, st: LiveStats, moved = false): void {
    const picker = this.page.view.picker;
    if (!picker.active) {
      this.piece = null;
      return;
    }
    const now = s.now();
    const made = st.windows + st.dropped;
    const p = this.piece;
    if (!moved && p && p.windows === made && p.to - now > PIECE_MARGIN_S) return;
    const from = Math.floor(now * s.fps);
    const to = Math.floor(st.bufferedTo * s.fps);
    if (to - from < 2) return;
    const joints = new Float32Array((to - from) * 66);
    const frames = framesOnOneStage(s, from, to);
    frames.forEach((g, k) => joints.set(g.joints, k * 66));
    this.piece = { from: from / s.fps, to: to / s.fps, windows: made, origin: frames[0].origin };
    picker.setMotion({ frames: to - from, fps: s.fps, joints, features: new Float32Array(0) }, 'emdm-live', from / s.fps, frames[0].origin);
  }

  private add(p: LivePrompt): void {
    this.log.push(p);
    if (this.log.length > 100) this.log.shift();
    this.render();
  }

  private render(): void {
    const items = this.log.slice(-STRIP_PROMPTS).map((p) => {
      const li = el('li');
      li.append(el('span', 'live-at', clock(p.at)), ` “${p.text}”`);
      if (p.latency !== null) li.append(el('span', 'live-latency', ` · in ${p.latency.toFixed(2)} s`));
      return li;
    });
    this.strip.replaceChildren(...items);
  }

  private say(text: string): void {
    this.hint.textContent = text;
  }

  // ------------------------------------------------------------ record
  /** The last 60 s as the page's motion (bone rotations solved in the worker): the downloads write it. */
  private async record(): Promise<void> {
    const s = this.stream;
    if (!s) return;
    const m = s.record();
    const end = s.now(); // where the recording ends on the live clock (its prompts' times: liveSource)
    if (m.frames < 2) return this.say('Nothing to record yet.');
    const hadFocus = document.activeElement === this.recordButton;
    this.recordButton.disabled = true;
    try {
      const { session, controls, view } = this.page;
      const t0 = performance.now();
      const pose = await session.engine.client.solve(m.joints, m.frames);
      const track: PoseTrack = {
        frames: m.frames, fps: m.fps, joints: session.manifest.skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats, offsets: pose.offsets,
      };
      const ms = performance.now() - t0;
      const result: GenerateResult = {
        motion: { frames: m.frames, fps: m.fps, joints: m.joints, features: m.features },
        timings: { encodeMs: 0, stepMs: [], decodeMs: 0, totalMs: ms, backend: session.backend === 'webgpu' ? 'webgpu' : 'wasm', threads: 0 },
        modelCalls: 0, sampler: 'ddgan', steps: controls.readEmdm().steps,
      };
      const last = this.log[this.log.length - 1]?.text ?? controls.readEmdm().text;
      const state = { ...controls.readEmdm(), mode: 'text' as const, text: last, seconds: m.frames / m.fps, compare: false };
      this.recorded = { state, label: `live recording (${(m.frames / m.fps).toFixed(1)} s)`, plan: null, main: { model: session.models.text!.name, result, track, ikMs: ms }, ddim: null,
        source: liveSource(this.log, end, m.frames / m.fps, this.made) };
      view.show(this.recorded);
      this.piece = null; // the visitor's character takes the stream again at the next poll
      this.say(`Recorded the last ${(m.frames / m.fps).toFixed(1)} s: the downloads write it.`);
    } catch (e) {
      this.notices.show('error', `Recording failed: ${describe(e)}`);
    } finally {
      this.recordButton.disabled = false;
      // a disabled button drops the keyboard focus to the page: give it back to the button pressed
      if (hadFocus && (document.activeElement === document.body || document.activeElement === null)) this.recordButton.focus();
    }
  }

  testApi(): LiveTestApi {
    const self = this;
    return {
      get active() {
        return !!self.stream;
      },
      get on() {
        return self.on;
      },
      stats: () => self.stream?.stats() ?? null,
      get displayed() {
        return self.displayed;
      },
      get repeated() {
        return self.repeated;
      },
      get poseMs() {
        return self.poseMs;
      },
      last: () => (self.prev.shown ? { time: self.prev.time, root: [self.prev.root[0], self.prev.root[1], self.prev.root[2]] } : null),
      shownFrame: () => (self.shownFrame ? { frame: self.shownFrame.frame, joints: Array.from(self.shownFrame.joints) } : null),
      prompts: () => self.log.map((p) => ({ ...p })),
      get started() {
        return self.counts.started;
      },
      get closed() {
        return self.counts.closed;
      },
    };
  }
}

/**
 * Stream frames from…to − 1, all on the stage of the last: reading a frame may move the stage back under the character
 * (whole metres, src/live/core.ts) after earlier frames were read on the stage before; those are moved onto the last
 * one's (world = stage + origin; joints and the pose's root), so nothing made of them jumps by those metres.
 */
export function framesOnOneStage(s: Pick<LiveStream, 'fps' | 'frameAt'>, from: number, to: number): LiveFrame[] {
  const got: LiveFrame[] = [];
  for (let f = from; f < to; f++) got.push(s.frameAt(f / s.fps));
  const last = got[got.length - 1]?.origin;
  for (const g of got) {
    const dx = last[0] - g.origin[0];
    const dz = last[1] - g.origin[1];
    if (!dx && !dz) continue;
    const moved = [Float32Array.from(g.joints), ...(g.pose ? [Float32Array.from(g.pose.rootPos)] : [])];
    for (const a of moved) {
      for (let i = 0; i < a.length; i += 3) {
        a[i] -= dx;
        a[i + 2] -= dz;
      }
    }
    g.joints = moved[0];
    if (g.pose) g.pose = { ...g.pose, rootPos: moved[1] };
    g.origin = [last[0], last[1]];
  }
  return got;
}

/** Stream frames f and f + 1 (on one stage) as a two-frame track; `shown` is frame f's joints on that stage. */
export function framePair(s: Pick<LiveStream, 'fps' | 'frameAt'>, f: number): { track: PoseTrack; shown: { frame: number; joints: Float32Array }; origin: readonly [number, number] } {
  const [a, b] = framesOnOneStage(s, f, f + 2);
  if (!a.pose || !b.pose) throw new Error('the live stream gave a frame without its pose (the stream has no solver)');
  const n = a.pose.quats.length / 4;
  return {
    track: {
      frames: 2, fps: s.fps, joints: n, rootPos: concat(a.pose.rootPos, b.pose.rootPos), quats: concat(a.pose.quats, b.pose.quats),
      ...(a.pose.offsets ? { offsets: a.pose.offsets } : {}),
    },
    shown: { frame: a.frame, joints: a.joints },
    origin: a.origin,
  };
}

function concat(a: Float32Array, b: Float32Array): Float32Array {
  const out = new Float32Array(a.length + b.length);
  out.set(a, 0);
  out.set(b, a.length);
  return out;
}

function sameValues(a: ArrayLike<number>, b: ArrayLike<number>): boolean {
  for (let i = 0; i < a.length; i++) if (a[i] !== b[i]) return false;
  return a.length === b.length;
}

/** Seconds on the live clock as m:ss.s. */
export function clock(t: number): string {
  const m = Math.floor(t / 60);
  const s = t - m * 60;
  return `${m}:${s < 10 ? '0' : ''}${s.toFixed(1)}`;
}
