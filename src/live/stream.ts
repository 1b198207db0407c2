/**
 * A live stream (issue 33): motion made ahead of playback in short windows (src/live/core.ts), pulled by time.
 *
 * ```ts
 * const stream = await generator.live({ prompt: 'a person walks forward', seed: 1 }); // resolves with its first window
 * stream.prompt('a person waves');        // what comes next: blended in as soon as its window exists
 * const f = stream.frameAt(stream.now()); // never waits: f.joints (22 × 3, stage coordinates), f.pose, f.origin (at t, between frames)
 * stream.stats();                         // windows, dropped, underruns, prompt → first new frame latencies
 * const clip = stream.record();           // the last 60 s as a motion (features, joints)
 * await stream.close();
 * ```
 *
 * Generation runs where the generator's runs (its worker in a page): one window at a time, a prompt aborts the one
 * under way. `frameAt` only reads the buffer; when generation falls behind the motion is played back from its last
 * frame (an underrun, counted) until the next window joins. Bone rotations (IK) are solved once per window for the
 * frames it changed (`solveFrames`: in the worker where there is one; src/live/poses.ts keeps them), so frameAt reads
 * them and interpolates between frames; a frame asked for before its window's solve came back is solved on its own
 * (`solve`, counted in stats().poseFallbacks).
 */
import { type EditCondition, type EditLimits, type EditMotion, type EditRequest, EditError } from '../edit';
import { AbortError } from '../sampler/sampler';
import { type LiveSettings, type LiveWindowRequest, LiveCore, liveCondition } from './core';
import { type FramePose, PoseRing, mixPose } from './poses';

/** One live window as the stream asks for it: src/edit.ts's EditRequest with a signal that drops it. */
export type LiveGenerate = (req: EditRequest & { signal: AbortSignal }) => Promise<EditMotion>;

export interface LiveOptions extends EditCondition, Partial<LiveSettings> {
  /** the first window's seed; window r is seeded seed + r (default 0) */
  seed?: number;
  /** the stream's clock in seconds (default: wall time since the first window was ready) */
  clock?: () => number;
}

export interface LiveFrame {
  /** the frame number on the stream's clock (⌊t · fps⌋) */
  frame: number;
  /** 22 × 3 joint positions as shown (smoothed, feet cleaned up) at t: between `frame` and the next when t falls between
   * them and both are buffered; stage coordinates (world = joints + origin in x/z) */
  joints: Float32Array;
  /** whole metres the stage was moved back under the character so far (x, z) */
  origin: [number, number];
  /** bone rotations at t (IK, solved per window; interpolated as the joints are), when the stream was given a solver */
  pose?: FramePose;
}

export interface LiveStats {
  /** windows joined, dropped (a prompt came, or nothing was left to show) and generated in all */
  windows: number;
  dropped: number;
  /** times playback reached the end of the buffer, and frames played back meanwhile */
  underruns: number;
  coastedFrames: number;
  /** seconds from each prompt() to its first new frame on the clock (the later of its arrival and its cut) */
  latencies: number[];
  /** ms each joined window took to generate */
  windowMs: number[];
  /** frames held: buffered ahead and behind (bounded by record + lead + window) */
  bufferedFrames: number;
  /** the first new frame of each prompt's window (stream frames) */
  blends: number[];
  /** seconds on the stream's clock up to which motion is made (frameAt before it reads it; after it, plays back) */
  bufferedTo: number;
  /** the lead in use (frames): raised when windows come late, lowered when they are early (src/live/core.ts) */
  lead: number;
  /** frames whose pose frameAt solved itself because their window's solve had not come back (or never would: underruns) */
  poseFallbacks: number;
}

export interface LiveStream {
  readonly fps: number;
  /** seconds on the stream's clock */
  now(): number;
  prompt(c: string | EditCondition): void;
  frameAt(t: number): LiveFrame;
  stats(): LiveStats;
  record(): EditMotion;
  close(): Promise<void>;
}

/** The longest a stats list (latencies, windowMs, blends) grows: the last MAX_LOG entries are kept. */
export const MAX_LOG = 1000;
const push = <T>(a: T[], v: T) => {
  a.push(v);
  if (a.length > MAX_LOG) a.shift();
};

/** Start a live stream on `gen` (one window at a time); resolves once its first window is ready. */
export interface LiveHooks {
  /** bone rotations of one frame's joints (IK) for LiveFrame.pose, where no window's solve has it */
  solve?: (joints: Float32Array) => FramePose;
  /** bone rotations of frames × 22 × 3 joints (IK, e.g. in the generation worker): every window's, once */
  solveFrames?: (joints: Float32Array, frames: number) => Promise<FramePose>;
  /** throw (an EditError) for a prompt the model cannot take, e.g. an action not among its labels */
  check?: (c: EditCondition) => void;
}

export async function startLive(gen: LiveGenerate, limits: EditLimits, opts: LiveOptions, hooks: LiveHooks = {}): Promise<LiveStream> {
  const { check: checkCondition } = hooks;
  if (opts === null || typeof opts !== 'object') throw new EditError(`live: options must be an object such as {prompt: 'a person walks'}, got ${String(opts)}`);
  const { seed = 0, clock, window, lead, maxLead, promptLead, recordSeconds, ...cond } = opts;
  const settings = Object.fromEntries(Object.entries({ window, lead, maxLead, promptLead, recordSeconds }).filter(([, v]) => v !== undefined));
  const core = new LiveCore(limits, cond, seed, settings);
  checkCondition?.(core.condition);
  const fps = limits.fps;
  let closed = false;
  let running: { req: LiveWindowRequest; ctl: AbortController; t0: number; promptAt?: number } | null = null;
  let failure: Error | null = null;
  const stats = { windows: 0, dropped: 0, latencies: [] as number[], windowMs: [] as number[], blends: [] as number[] };
  const shown = showFrames(core, hooks, (e) => void (failure ??= e));
  let t0 = 0;
  const now = clock ?? (() => performance.now() / 1000 - t0);
  const playhead = () => Math.max(0, Math.floor(now() * fps + 1e-9));

  const run = async (req: LiveWindowRequest, promptAt?: number): Promise<void> => {
    running?.ctl.abort();
    const job = { req, ctl: new AbortController(), t0: performance.now(), promptAt };
    running = job;
    try {
      const m = await gen({ ...(req.action !== undefined ? { action: req.action } : { prompt: req.prompt }), frames: req.frames, seed: req.seed, ...(req.known ? { known: req.known } : {}), signal: job.ctl.signal });
      if (running !== job || closed) return;
      running = null;
      const at = t0 === 0 && !clock ? 0 : playhead();
      const r = core.accept(req, m.features, at);
      if (r?.dropped) stats.dropped++;
      else if (r) {
        stats.windows++;
        push(stats.windowMs, performance.now() - job.t0);
        if (promptAt !== undefined) {
          push(stats.latencies, Math.max(now(), r.from / fps) - promptAt);
          push(stats.blends, r.from);
        }
      }
    } catch (e) {
      if (running === job) running = null;
      if (!(e instanceof AbortError) && !job.ctl.signal.aborted) failure = e as Error;
    }
    if (!closed && !failure) pump();
  };
  const pump = () => {
    if (running || closed) return;
    const req = core.request(playhead());
    if (req) void run(req);
  };

  await run(core.request(0)!);
  await shown.settled();
  if (failure) throw failure;
  t0 = performance.now() / 1000;
  pump();

  const check = (what: string) => {
    if (closed) throw new EditError(`live: the stream is closed; ${what} needs an open one (generator.live)`);
    if (failure) throw failure;
  };
  return {
    fps,
    now,
    prompt(c) {
      check('prompt()');
      const cond = liveCondition(c);
      checkCondition?.(cond);
      const req = core.prompt(cond, playhead());
      if (running) stats.dropped++;
      void run(req, now());
    },
    frameAt(t) {
      check('frameAt()');
      if (!Number.isFinite(t) || t < 0) throw new EditError(`live: frameAt takes seconds ≥ 0 on the stream's clock, got ${t}`);
      const frame = Math.floor(t * fps + 1e-9);
      // the stage follows the playhead, not the frame asked for: a frame ahead (a retargeted character's piece) is
      // given on the stage of what plays now
      const { joints, pose } = shown.at(frame, t * fps - frame > 1e-6 ? t * fps - frame : 0, playhead());
      if (!running) core.trim(frame);
      pump();
      return { frame, joints, origin: [...core.origin] as [number, number], ...(pose ? { pose } : {}) };
    },
    stats: () => ({
      ...stats, latencies: [...stats.latencies], windowMs: [...stats.windowMs], blends: [...stats.blends],
      underruns: core.underruns, coastedFrames: core.coasted, bufferedFrames: core.frames, bufferedTo: core.end / fps,
      lead: core.lead, poseFallbacks: shown.fallbacks,
    }),
    record() {
      const from = Math.max(core.base, Math.min(playhead() + 1, core.end) - Math.round(core.settings.recordSeconds * fps));
      const to = Math.min(core.end, playhead() + 1);
      const a = from - core.base;
      const b = to - core.base;
      return { frames: b - a, fps, features: core.features.slice(a * 263, b * 263), joints: core.display.slice(a * 66, b * 66) };
    },
    async close() {
      closed = true;
      running?.ctl.abort();
      running = null;
    },
  };
}

/**
 * What frameAt shows of `core`: the display joints at frame + w (w ∈ [0, 1): between that frame and the next when both
 * are buffered) and their pose, read from the windows' solves (`solveFrames`, asked for whenever display frames change)
 * or solved here (`solve`) for a frame whose window's solve is not back. A failed solve goes to `fail`.
 */
function showFrames(core: LiveCore, { solve, solveFrames }: LiveHooks, fail: (e: Error) => void) {
  const poses = new PoseRing();
  const solving = new Set<Promise<void>>();
  let fallbacks = 0;
  const rows = (a: number, b: number) => core.display.slice((a - core.base) * 66, (b - core.base) * 66);
  core.onChange = (from, to) => {
    const epoch = poses.changed(from, to);
    if (!solve || !solveFrames) return;
    const origin = [...core.origin] as [number, number];
    const job = solveFrames(rows(from, to), to - from)
      .then((pose) => poses.put(from, pose, to - from, epoch, origin))
      .catch((e) => fail(e as Error))
      .finally(() => solving.delete(job));
    solving.add(job);
  };
  /** Frame q's pose (buffered): the window's solve, else solved here (`fallback`) or null. */
  const poseOf = (q: number, fallback: boolean): FramePose | null => {
    const got = poses.get(q, core.origin);
    if (got || !fallback || !solve) return got;
    fallbacks++;
    const p = solve(rows(q, q + 1));
    poses.put(q, p, 1, poses.now, core.origin);
    return { rootPos: Float32Array.from(p.rootPos), quats: Float32Array.from(p.quats), ...(p.offsets ? { offsets: p.offsets } : {}) };
  };
  return {
    get fallbacks() {
      return fallbacks;
    },
    /** every solve asked for so far has come back */
    settled: () => Promise.all([...solving]),
    at(frame: number, w: number, centre: number): { joints: Float32Array; pose?: FramePose } {
      let joints = core.frameAt(frame, centre);
      const q = Math.max(frame, core.base);
      let pose = solve ? poseOf(q, true)! : undefined;
      const next = w > 0 && q + 1 < core.end ? (solve ? poseOf(q + 1, false) : true) : null;
      if (next) { // between frames q and q + 1: both buffered (and their poses solved, when there is a solver)
        const b = rows(q + 1, q + 2);
        joints = joints.map((v, i) => v + (b[i] - v) * w);
        if (pose && next !== true) pose = mixPose(pose, next, w);
      }
      return { joints, pose };
    },
  };
}
