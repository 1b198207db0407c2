// One request of the timeline panel (web/ui/timeline.ts), from the click to the character: run a mode's job
// as the page's newest request (cancelling a running one) with its windows generated in the worker, report
// progress next to the mode's controls, solve and show the result, and sum up where the time went
// (EditSummary, for the test API). Errors are said in the panel and rethrown.
import { EditError, type EditCondition, type EditGenerate, type EditMotion } from '../../src/index';
import type { GenerateResult } from '../../src/openModel';
import type { RemoteResult, WirePose } from '../../src/worker/client';
import type { WireBeginOptions } from '../../src/worker/protocol';
import type { PoseTrack } from '../../src/three';
import { isAbort } from './engine';
import type { PageContext } from './page-context';
import type { MotionSource } from './provenance';
import type { Generation } from './session';
import type { PageState } from './state';

export type EditKind = 'timeline' | 'inbetween' | 'body' | 'loop';

/** What the test API reports about the panel's last result. */
export interface EditSummary {
  kind: EditKind;
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

/** What a mode hands back to be shown. */
export interface Shown {
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
  /** what made it (the segments, or the edit, its inputs and the motion it edited): the JSON download and the link */
  source: MotionSource;
  /** what the visitor should know about the result (e.g. a loop of a long timeline regenerated only its end): said next to the mode's controls */
  note?: string;
}

/** Said with a result when the compare view is on: the panel's results are EMDM's alone. */
export const COMPARE_NOTE = 'Compare is for one generation: this result is EMDM\'s alone (no diffusion run beside it).';

/** What one window's generation took (a GenerateResult without its motion). */
type Run = Pick<GenerateResult, 'timings' | 'modelCalls' | 'sampler' | 'steps'> & { frames: number };

/** The generations of one request, and how its progress and label read (a timeline sets them per window). */
export interface Calls {
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

/** What a request needs of its panel. */
export interface RequestPanel {
  readonly page: PageContext;
  readonly actions: readonly string[];
  /** say `text` next to `kind`'s controls, marking `segment`'s row (an error) */
  say(text: string, segment: number | null, kind: EditKind): void;
  /** say `text` next to `kind`'s controls as news about a result, not an error ('' says nothing) */
  note(text: string, kind: EditKind): void;
  /** the progress line next to `kind`'s controls ('' hides it) */
  working(kind: EditKind, text: string): void;
  /** the page's model for a condition (an EditError when the demo has none) */
  modelFor(c: EditCondition): string;
  /** the result is on screen */
  showed(s: Shown): void;
}

/** What the Generate button says it stops while a panel's request runs. */
const RUNNING: Record<EditKind, string> = { timeline: 'the timeline', inbetween: 'the in-between', body: 'the body-part edit', loop: 'the loop' };

export type EditJob = (gen: EditGenerate, signal: AbortSignal, calls: Calls) => Promise<Shown>;

/**
 * Run `job` as the page's newest request (cancelling a running one), with progress, the busy button and
 * errors said in the panel; the result is shown on the character.
 */
export async function runEditRequest(p: RequestPanel, kind: EditKind, job: EditJob): Promise<EditSummary> {
  const { session, view, controls } = p.page;
  if (controls.liveOn) { // its result would play under the stream, unseen (Generate is off in live mode too)
    const e = new EditError('Live mode is on: stop it with the Live button first, then make a timeline or an edit.');
    p.say(e.message, null, kind);
    throw e;
  }
  const state = controls.readEmdm(); // the compare view's DDIM counts (20/50/100) are not EMDM's
  const t0 = performance.now();
  p.say('', null, kind);
  for (const k of ['timeline', 'inbetween', 'body', 'loop'] as const) p.working(k, '');
  p.working(kind, 'Starting…');
  controls.setBusy(true, RUNNING[kind]);
  view.showProgress(0, 'Starting…');
  session.counters.requests++;
  try {
    const calls = newCalls(p, kind);
    const spent = { genMs: 0, jobMs: 0 };
    const shown = await session.engine.run(async (signal) => {
      const j0 = performance.now();
      const out = await job(windowGenerator(p, state, signal, calls, spent), signal, calls);
      spent.jobMs = performance.now() - j0;
      return out;
    });
    const s0 = performance.now();
    const track = shown.pose ? trackOf(p.page, shown.pose, shown.motion) : await solve(p.page, shown.display, shown.motion);
    const s1 = performance.now();
    p.page.view.show(generationOf(p.page, state, shown, track, s1 - t0));
    p.showed(shown);
    p.note([shown.note ?? '', state.compare ? COMPARE_NOTE : ''].filter(Boolean).join(' '), kind);
    const s2 = performance.now();
    session.counters.generations++;
    const parts = partsOf(shown, calls, spent, { ikMs: shown.pose ? shown.pose.ikMs : s1 - s0, showMs: s2 - s1 });
    return { kind, frames: shown.motion.frames, fps: shown.motion.fps, starts: shown.starts, ms: performance.now() - t0, windows: shown.windows, parts };
  } catch (e) {
    if (isAbort(e)) session.counters.cancelled++;
    else {
      session.counters.errors++;
      p.say(e instanceof EditError || e instanceof Error ? e.message : String(e), e instanceof EditError ? e.segment : null, kind);
    }
    throw e;
  } finally {
    p.working(kind, '');
    if (!session.busy) {
      controls.setBusy(false);
      view.hideProgress();
    }
  }
}

/** A request's Calls: one window's progress and text until a mode says otherwise. */
function newCalls(p: RequestPanel, kind: EditKind): Calls {
  const { session, view } = p.page;
  const calls: Calls = {
    n: 0, results: [], progress: (f) => f, text: (d, t) => `Denoising step ${d} / ${t}`,
    beginText: (w, d, t) => `${w} window${w === 1 ? '' : 's'} together: step ${d} / ${t}`,
    step: (d, t, together) => {
      if (!together) session.counters.stepsRun++;
      const text = together ? calls.beginText(together, d, t) : calls.text(d, t);
      view.showProgress(calls.progress(d / t), text);
      p.working(kind, `${text} (${Math.round(100 * calls.progress(d / t))} %)`);
    },
    worker: null,
  };
  return calls;
}

/** A window's condition, frames and seed with the page's steps and guidance, as the worker takes them. */
function wire(actions: readonly string[], r: EditCondition & { frames: number; seed: number }, state: PageState): Pick<WireBeginOptions, 'condition' | 'frames' | 'steps' | 'guidance' | 'seed'> {
  const label = r.action !== undefined ? actions.indexOf(String(r.action)) : -1;
  return {
    condition: r.action !== undefined ? { type: 'action', label } : { type: 'text', text: r.prompt ?? '' },
    frames: r.frames, steps: state.steps, guidance: state.guidance, seed: r.seed,
  };
}

/** The edits' window generator: one window in the worker, counted in `calls`, its time in `spent.genMs`. */
function windowGenerator(p: RequestPanel, state: PageState, signal: AbortSignal, calls: Calls, spent: { genMs: number }): EditGenerate {
  const { session } = p.page;
  return async (r) => {
    const g0 = performance.now();
    const model = p.modelFor(r);
    await session.load(model);
    // through the engine: the file the page's own generations run (the manifest's default variant, e.g. int8);
    // no pose track per window (the stitched motion is solved once, below)
    const res: RemoteResult = await session.engine.generate(model, {
      pose: false, ...wire(p.actions, r, state), signal,
      // copies: the client transfers these buffers to the worker, and src/edit.ts reads `keep` again after
      ...(r.known ? { known: { ...r.known, features: r.known.features.slice(), keep: r.known.keep.slice() } } : {}),
      ...(r.resume ? { resume: r.resume } : {}),
      onStep: (d, t) => calls.step(d, t, 0),
    });
    calls.n++;
    calls.results.push({ ...res, frames: res.motion.frames });
    spent.genMs += performance.now() - g0;
    return { frames: res.motion.frames, fps: res.motion.fps, features: res.motion.features, joints: res.motion.joints };
  };
}

/** Where the request's time went (EditSummary.parts). */
function partsOf(shown: Shown, calls: Calls, spent: { genMs: number; jobMs: number }, here: { ikMs: number; showMs: number }): EditSummary['parts'] {
  const sum = (f: (r: Run) => number) => shown.results.reduce((a, r) => a + f(r), 0);
  const windowsMs = sum((r) => r.timings.totalMs);
  // a timeline ran whole in the worker (calls.worker); an edit's window came back here to be eased and decoded
  const w = calls.worker;
  return {
    encodeMs: sum((r) => r.timings.encodeMs), stepMs: sum((r) => r.timings.stepMs.reduce((a, b) => a + b, 0)), decodeMs: sum((r) => r.timings.decodeMs),
    beginMs: w?.beginMs ?? 0, workerEditMs: w ? w.totalMs - w.beginMs - windowsMs : 0,
    roundTripMs: w ? w.requestMs - w.totalMs : spent.genMs - windowsMs, mainMs: spent.jobMs - (w ? w.requestMs : spent.genMs),
    ikMs: here.ikMs, showMs: here.showMs,
    windowStepMs: shown.results.map((r) => r.timings.stepMs.reduce((a, b) => a + b, 0)), windowFrames: shown.results.map((r) => r.frames),
  };
}

/** The pose track of bone rotations the worker solved with the motion. */
function trackOf(page: PageContext, p: WirePose, m: EditMotion): PoseTrack {
  return { frames: m.frames, fps: m.fps, joints: page.session.manifest.skeleton.joints.length, rootPos: p.rootPos, quats: p.quats, offsets: p.offsets };
}

/** Bone rotations (the worker's IK) for the joints shown. */
async function solve(page: PageContext, joints: Float32Array, m: EditMotion): Promise<PoseTrack> {
  const p = await page.session.engine.client.solve(joints, m.frames);
  return trackOf(page, p, m);
}

/** The request's result as the page's Generation (what the view shows and the downloads write). */
function generationOf(page: PageContext, state: PageState, s: Shown, track: PoseTrack, ms: number): Generation {
  // the timings of everything this request generated (nothing, when an unchanged timeline is shown again)
  const results = s.results;
  const first = results[0];
  const sum = (f: (r: Run) => number) => results.reduce((a, r) => a + f(r), 0);
  const result: GenerateResult = {
    motion: { frames: s.motion.frames, fps: s.motion.fps, joints: s.display, features: s.motion.features },
    timings: {
      encodeMs: sum((r) => r.timings.encodeMs), stepMs: results.flatMap((r) => r.timings.stepMs), decodeMs: sum((r) => r.timings.decodeMs),
      // threads 0: no window ran (the view says nothing was regenerated, not "0 threads")
      totalMs: ms, backend: first?.timings.backend ?? (page.session.backend === 'webgpu' ? 'webgpu' : 'wasm'), threads: first?.timings.threads ?? 0,
    },
    modelCalls: sum((r) => r.modelCalls), sampler: first?.sampler ?? 'ddgan', steps: first?.steps ?? state.steps,
  };
  // the mode and prompt or action of what was generated (one condition), not the main prompt box's
  const c = s.condition;
  const made = !c ? {} : c.action !== undefined ? { mode: 'action' as const, action: String(c.action) } : { mode: 'text' as const, text: c.prompt ?? '' };
  return {
    state: { ...state, ...made, seconds: s.motion.frames / s.motion.fps, compare: false, seed: s.seed },
    label: s.label, plan: null,
    main: { model: s.model, result, track, ikMs: 0 },
    ddim: null,
    source: s.source,
  };
}
