// The page's view: the 3-D stage with the character (and the compare view's DDIM character), the
// playback clock, the status line, progress, caption, timings and compare panels, the step strip, the
// downloads of the motion on screen and the error reports. It shows what the session produced and
// never runs a model itself.
//
// A panel that shows a motion calls `view.show(generation)` (or `view.play(track)` for a track of its
// own); the character on screen is `view.character` (the visitor's own, once dropped, is swapped in by
// web/ui/character-picker.ts through `view.picker`).
import { type Bone, MeshStandardMaterial, Quaternion, Vector3 } from 'three';
import { HEAD_PITCH, applyPose, createCharacter, MotionPlayer, motionToGLB, placeBones, type PoseTrack } from '../../src/three';
import { ModelFileError, motionToJSON, NonFiniteMotionError, type Manifest } from '../../src/index';
import type { GenerateResult } from '../../src/openModel';
import type { WireStepPreview } from '../../src/worker/client';
import type { Capabilities } from '../../src/capabilities';
import { CharacterPicker } from './character-picker';
import { byId, formatBytes, formatMs, saveBlob } from './dom';
import { LIVE_DOWNLOAD_NOTE, fileStem, motionToBVH, setDownloads } from './downloads';
import type { ErrorPanel, Notices } from './notices';
import { PlaybackBar } from './playback';
import type { Generation, Produced } from './session';
import { realSpeedOf, showFigures } from './compare-figures';
import { Stage } from './stage';
import { generatorOf, seedOf, type MotionSource } from './provenance';
import type { PageState } from './state';
import { StepStrip } from './step-strip';
import { timingCells } from './timings';

type Skeleton = Manifest['skeleton'];
type Character = ReturnType<typeof createCharacter>;

export function describe(e: unknown): string {
  return e instanceof Error ? e.message : String(e);
}

/** generate() (in the worker) refused NaN/Infinity in a motion; the error crosses the worker by name. */
const isNonFinite = (e: unknown) => e instanceof NonFiniteMotionError || (e instanceof Error && e.name === 'NonFiniteMotionError');

/** The note under the prompt when the text encoder read only its first maxTokens tokens. */
export function promptNote(p: GenerateResult['prompt']): string {
  return p?.truncated
    ? `Prompt truncated to ${p.maxTokens} tokens: the text encoder reads at most ${p.maxTokens} and this prompt has ${p.tokens}, so the words after that are ignored.`
    : '';
}

export type StatusKind = 'loading' | 'ready' | 'error';

/**
 * The status line (dot + text) and the download bar: ONE state, loading → ready or error. Download
 * progress is shown only for a model whose load is under way (`begin`), so late progress events of a
 * load that already failed or finished never put "Downloading…" back over an error or a ready state.
 */
export class StatusLine {
  private readonly dot = byId('status-dot');
  private readonly text = byId('status-text');
  private readonly say = byId('status-say');
  private readonly bar = byId('download-bar');
  private readonly fill = byId('download-fill');
  private readonly loading = new Set<string>();
  private settled: { kind: 'ready' | 'error'; text: string } | null = null;
  kind: StatusKind = 'loading';

  private set(kind: StatusKind, text: string): void {
    // announced once per state (loading, then ready or an error), never per download tick (170 a cold load)
    if (kind !== this.kind || kind !== 'loading' || !this.say.textContent) this.say.textContent = text;
    this.kind = kind;
    this.dot.className = `dot ${kind}`;
    this.text.textContent = text;
  }

  get message(): string {
    return this.text.textContent ?? '';
  }

  /** A model starts loading: its download progress is shown until end(). */
  begin(model: string, text = `Loading ${model}…`): void {
    this.loading.add(model);
    this.set('loading', text);
  }

  /** Download progress of a model (ignored unless that model's load is under way). */
  download(model: string, loaded: number, total: number): void {
    if (!this.loading.has(model)) return;
    this.bar.hidden = loaded >= total;
    this.fill.style.width = `${total > 0 ? (100 * loaded) / total : 0}%`;
    this.set('loading', `Downloading ${model}: ${formatBytes(loaded)} / ${formatBytes(total)}`);
  }

  /** A model's load ended: ready (text = the ready line) or failed (text = what failed). */
  end(model: string, kind: 'ready' | 'error', text: string): void {
    this.loading.delete(model);
    if (this.loading.size === 0) this.bar.hidden = true;
    this.show(kind, text);
  }

  /** The page's state outside any load (a generation finished: ready; startup failed: error). */
  show(kind: 'ready' | 'error', text: string): void {
    this.settled = { kind, text };
    if (this.loading.size === 0) this.set(kind, text);
  }

  /** The settled state (null while the first load runs). */
  get last(): { kind: 'ready' | 'error'; text: string } | null {
    return this.settled;
  }
}

/** Arms relaxed down (A-pose) until the first motion arrives. */
function restPose(bones: Bone[], pelvis: number[]): void {
  const quats = new Float32Array(bones.length * 4);
  for (let j = 0; j < bones.length; j++) quats[j * 4 + 3] = 1;
  const set = (name: string, axis: Vector3, angle: number) => {
    const j = bones.findIndex((b) => b.name === name);
    if (j >= 0) new Quaternion().setFromAxisAngle(axis, angle).toArray(quats as unknown as number[], j * 4);
  };
  set('l_shoulder', new Vector3(0, 0, 1), -1.2);
  set('r_shoulder', new Vector3(0, 0, 1), 1.2);
  set('l_elbow', new Vector3(0, 1, 0), -0.15);
  set('r_elbow', new Vector3(0, 1, 0), 0.15);
  set('neck', new Vector3(1, 0, 0), -HEAD_PITCH); // the head geometry is pitched for the data's neck angle
  applyPose(bones, pelvis, quats);
}

/** A step preview as the test API lists it. */
export interface PreviewEntry { step: number; steps: number; frames: number; joints: number[]; ms: number; at: number; played: boolean }

/** The motion on screen (what the downloads export). */
export interface Shown {
  state: PageState;
  result: GenerateResult;
  track: PoseTrack;
  label: string;
  /** the model and step count that made the (left, in compare mode) motion */
  model: string;
  steps: number;
  ikMs: number;
  /** what made it, when not one generation of `state` (web/ui/provenance.ts) */
  source?: MotionSource;
}

/**
 * What poses the character instead of the player (live mode, web/ui/live.ts): each displayed frame's pose (null: none
 * yet, the player's motion is shown) and its clock, which the visitor's character follows too.
 */
export interface PoseDriver {
  pose(dt: number): { root: ArrayLike<number>; quats: ArrayLike<number>; offsets?: Float32Array } | null;
  time(): number;
}

export class View {
  readonly stage = new Stage(byId('scene', HTMLCanvasElement));
  readonly player = new MotionPlayer();
  readonly playback = new PlaybackBar(this.player);
  /** the DDIM motion of the compare view, kept in step with `player` (null when not comparing) */
  readonly player2 = new MotionPlayer();
  readonly status = new StatusLine();
  /** times of the last ~2 s of drawn frames (the test API's playbackFps) */
  readonly frameTimes: number[] = [];
  /** the motion on screen, null before the first */
  shown: Shown | null = null;
  /** what the caption says of the motion on screen (restored when live mode ends) */
  private captionShown: Pick<Generation, 'state' | 'label' | 'plan'> | null = null;
  /** the compare view's DDIM motion on screen, null when not comparing */
  compareShown: Produced | null = null;
  /** the step previews of the last generation (show steps) */
  previews: PreviewEntry[] = [];
  // set by attach()
  skeleton!: Skeleton;
  character!: Character;
  ddimCharacter!: Character;
  picker!: CharacterPicker;
  stepStrip!: StepStrip;
  private loopBones: Bone[] = [];
  /** the rest offsets the built-in character's bones are at (undefined: the skeleton's reference offsets) */
  private placed: Float32Array | undefined;
  /** poses the character instead of the player (live mode), null otherwise */
  private driver: PoseDriver | null = null;
  /** live mode with no recording of it shown yet: the downloads would write a motion that is not on screen */
  private liveUnrecorded = false;
  /** called after each show() (the page rewrites its link: web/main.ts) */
  onShown: (() => void) | null = null;

  private readonly progress = byId('progress');
  private readonly progressFill = byId('progress-fill');
  private readonly progressText = byId('progress-text');
  private readonly progressBar = byId('progress-bar');
  private readonly caption = byId('caption');
  private readonly timingsHud = byId('timings');
  readonly comparePanels = byId('compare-panels');
  private readonly compareFigures = byId('compare-figures');
  /** the text model's capabilities (setTextCapabilities): the real speed range beside the compare figures */
  private textCapabilities: Capabilities | null = null;
  private readonly compareDivider = byId('compare-divider');
  readonly showSteps = byId('show-steps', HTMLInputElement);

  constructor(private readonly notices: Notices, private readonly errorPanel: ErrorPanel) {
    // `?quality=high` keeps full resolution and shadows even when frames are slow (screenshots); `?quality=low` starts
    // at the lowest quality the page drops to when frames are slow (half resolution, no shadows).
    const quality = new URLSearchParams(location.search).get('quality');
    this.stage.adaptive = quality !== 'high';
    if (quality === 'low') this.stage.lowest();
  }

  /** Put the characters of a manifest's skeleton on the stage (rest pose), wire the downloads, start drawing. */
  attach(skeleton: Skeleton): void {
    this.skeleton = skeleton;
    this.character = createCharacter(skeleton);
    this.stage.add(this.character.object);
    restPose(this.character.bones, skeleton.offsets[0]);
    // the compare view's second character (DDIM), tinted warm; hidden until a comparison is shown
    this.ddimCharacter = createCharacter(skeleton);
    (this.ddimCharacter.mesh.material as MeshStandardMaterial).color.setHex(0xffc58a);
    this.ddimCharacter.object.visible = false;
    this.ddimCharacter.object.name = 'ddim-character';
    this.stage.add(this.ddimCharacter.object);
    // a character the visitor drops replaces the built-in one (web/ui/character-picker.ts)
    this.picker = new CharacterPicker({
      add: (o) => this.stage.add(o), builtIn: this.character.object, skeleton, time: () => this.driver?.time() ?? this.player.time,
      notify: (kind, text) => this.notices.show(kind, text), before: byId('panel-actions'),
      changed: () => this.showCompare(this.compareShown),
    });
    this.stepStrip = new StepStrip(byId('step-strip'), skeleton.parents);
    this.showSteps.addEventListener('change', () => {
      if (!this.showSteps.checked) this.stepStrip.reset();
    });
    this.bindDownloads();
    this.startLoop(this.character.bones);
  }

  // ------------------------------------------------------------ motions
  /** Play a pose track on the character (from its start), e.g. a panel's own motion. */
  play(track: PoseTrack, snap = true): void {
    this.player.setTrack(track);
    this.player.playing = true;
    this.place(track.offsets);                                        // the motion's own proportions
    if (snap) this.stage.snapTo(track.rootPos);
  }

  /** Put the built-in character's bones at `offsets` (the ones its pose was solved for), when they are not there. */
  private place(offsets: Float32Array | undefined): void {
    if (offsets === this.placed) return;
    placeBones(this.character.bones, this.skeleton, offsets);
    this.placed = offsets;
  }

  /**
   * Pose the character from `driver` on every frame instead of the player (live mode; its playback bar and path are
   * hidden), or from the player again (null).
   */
  drive(driver: PoseDriver | null): void {
    // entering live mode (not a restarted stream): nothing of it is recorded yet
    if (!driver || !this.driver) this.liveUnrecorded = !!driver;
    // the DDIM character has no stream to play: the split view would show the last comparison beside the stream
    if (driver) this.leaveCompare();
    else this.picker.leaveLive();
    this.driver = driver;
    this.syncDownloads();
    byId('playback').hidden = !!driver;
    // the last generation's caption and timings do not describe a live stream: liveCaption names what plays
    this.timingsHud.hidden = !!driver || !this.shown || !!this.compareShown;
    if (!driver && this.captionShown) this.showCaption(this.captionShown);
    const t = this.shown?.track;
    this.stage.setPath(t?.rootPos ?? new Float32Array(0), driver || !t ? 0 : t.frames);
    if (!driver && t) this.play(t);
  }

  /** Show a finished generation: the character(s), path, caption, timings or compare panels, downloads (while a
   * driver poses the character, only the motion behind the downloads changes: it plays once the driver is gone). */
  show(g: Generation): void {
    const { main, ddim, state: s, label } = g;
    this.play(main.track, false);
    this.showCompare(ddim);
    this.stage.setPath(main.track.rootPos, ddim || this.driver ? 0 : main.track.frames);
    if (!this.driver) this.stage.snapTo(main.track.rootPos);
    if (ddim) this.stage.snapTo2(ddim.track.rootPos);
    this.shown = { state: s, result: main.result, track: main.track, label, model: main.model, steps: main.result.steps, ikMs: main.ikMs, ...(g.source ? { source: g.source } : {}) };
    if (this.driver && g.source?.kind === 'live') this.liveUnrecorded = false; // a recording of live mode: the downloads write it
    this.picker.setMotion(main.result.motion, fileStem(label, s.seed));
    this.showCaption(g);
    if (ddim) this.showPanels(main, ddim, realSpeedOf(this.textCapabilities, main.result.promptCheck));
    else this.showTimings(main.result, main.ikMs);
    this.syncDownloads();
    this.onShown?.();
  }

  /** The download buttons: enabled with a motion to write, except in live mode before a recording (#dl-note says why). */
  private syncDownloads(): void {
    setDownloads(!!this.shown && !this.liveUnrecorded, this.liveUnrecorded ? LIVE_DOWNLOAD_NOTE : '');
  }

  /** The text model's capabilities, once loaded (they arrive after the models): a compare view already on screen gets
   * its real speed range now. */
  setTextCapabilities(caps: Capabilities | null): void {
    this.textCapabilities = caps;
    if (this.compareShown && this.shown) {
      showFigures(this.shown.result.motion, this.compareShown.result.motion, realSpeedOf(caps, this.shown.result.promptCheck));
    }
  }

  /** The compare view was turned off: back to the EMDM character alone. */
  leaveCompare(): void {
    if (!this.compareShown || !this.shown) return;
    this.showCompare(null);
    this.stage.setPath(this.shown.track.rootPos, this.shown.track.frames);
    this.showTimings(this.shown.result, this.shown.ikMs);
    // one character now: the caption names its motion's steps, not the comparison's "EMDM n vs DDIM m"
    if (this.captionShown?.plan) this.showCaption({ ...this.captionShown, plan: null });
  }

  /** Start of a generation: clear the step previews (and the strip when they will be shown). */
  resetPreviews(): void {
    this.previews = [];
    this.stepStrip.reset();
  }

  /** A step preview from the worker: into the strip, and onto the character until the next one (or the result). */
  showPreview(p: WireStepPreview, signal: AbortSignal): void {
    if (signal.aborted) return;
    const entry: PreviewEntry = { step: p.step, steps: p.steps, frames: p.frames, joints: Array.from(p.joints), ms: p.ms, at: performance.now(), played: false };
    this.previews.push(entry);
    this.stepStrip.add(p.step, p.steps, p.joints, p.frames);
    const pose = p.pose;
    // a non-finite prediction is not shown; the final result reports it if it stays so
    if (!pose || !pose.quats.every(Number.isFinite) || !pose.rootPos.every(Number.isFinite)) return;
    this.play({ frames: p.frames, fps: p.fps, joints: this.skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats, offsets: pose.offsets }, p.step === 1);
    entry.played = true;
  }

  // ------------------------------------------------------------ panels
  showProgress(fraction: number, text: string): void {
    this.progress.hidden = false;
    this.progressFill.style.width = `${Math.round(fraction * 100)}%`;
    this.progressBar.setAttribute('aria-valuenow', String(Math.round(fraction * 100)));   // read on demand, not announced
    this.progressText.textContent = text;
  }

  hideProgress(): void {
    this.progress.hidden = true;
  }

  private showTimings(r: GenerateResult, ikMs: number): void {
    const c = timingCells(r, ikMs);
    for (const [id, text] of [['t-encode', c.encode], ['t-step', c.step], ['t-decode', c.decode], ['t-total', c.total], ['t-backend', c.backend], ['t-calls', c.calls]]) {
      byId(id).textContent = text;
    }
    this.timingsHud.hidden = false;
  }

  /** The caption in live mode: the prompt now playing and the stream's settings. */
  liveCaption(prompt: string, steps: number): void {
    this.setCaption(`“${prompt}”`, `live · ${stepsText(steps)} · Enter in the prompt box sends the next`);
  }

  private showCaption(g: Pick<Generation, 'state' | 'label' | 'plan'>): void {
    this.captionShown = g;
    const { state: s, label, plan } = g;
    const steps = plan ? `EMDM ${plan.emdm} vs DDIM ${plan.ddim} steps` : stepsText(s.steps);
    this.setCaption(s.mode === 'text' ? `“${label}”` : label, `${s.mode} · seed ${s.seed} · ${steps} · ${s.seconds.toFixed(1)} s`);
  }

  /** The caption over the stage: its main line and the small line under it. */
  private setCaption(mainText: string, smallText: string): void {
    const main = document.createElement('span');
    main.textContent = mainText;
    const small = document.createElement('small');
    small.textContent = smallText;
    this.caption.replaceChildren(main, small);
  }

  private showCompare(ddim: Produced | null): void {
    this.compareShown = ddim;
    if (ddim) {
      this.player2.setTrack(ddim.track);
      placeBones(this.ddimCharacter.bones, this.skeleton, ddim.track.offsets);
      this.player2.playing = false;
    }
    // the visitor's character, when one is shown, performs both motions (a second copy for DDIM)
    const theirs = this.picker.compare(ddim ? ddim.result.motion : null);
    this.ddimCharacter.object.visible = !!ddim && !theirs;
    // the stage's own labels (EMDM left, DDIM right) take a band under the caption; set before the split reads it
    byId('stage').classList.toggle('comparing', !!ddim);
    byId('stage-label-emdm').hidden = !ddim;
    byId('stage-label-ddim').hidden = !ddim;
    this.compareFigures.hidden = !ddim;
    // split view: EMDM in the left half, DDIM in the right, each followed by its own camera
    this.stage.setSplit(ddim ? theirs ?? { left: this.character.object, right: this.ddimCharacter.object } : null);
    this.comparePanels.hidden = !ddim;
    this.compareDivider.hidden = !ddim;
    if (ddim) this.timingsHud.hidden = true;
  }

  private showPanels(emdm: Produced, ddim: Produced, real: ReturnType<typeof realSpeedOf>): void {
    for (const [id, p] of [['emdm', emdm], ['ddim', ddim]] as const) {
      const t = p.result.timings;
      const mean = t.stepMs.length ? t.stepMs.reduce((a, b) => a + b, 0) / t.stepMs.length : NaN;
      byId(`panel-${id}-label`).textContent = id === 'emdm' ? 'EMDM (left)' : 'DDIM (right)';
      byId(`panel-${id}-sub`).textContent = `${p.model} · ${p.result.sampler === 'ddim' ? 'DDIM, η = 0' : 'DDGAN posterior'}`;
      byId(`panel-${id}-steps`).textContent = `${p.result.steps} (${p.result.modelCalls} model call${p.result.modelCalls === 1 ? '' : 's'})`;
      byId(`panel-${id}-step`).textContent = formatMs(mean);
      byId(`panel-${id}-total`).textContent = formatMs(t.totalMs + p.ikMs);
      byId(`stage-label-${id}`).textContent = `${id === 'emdm' ? 'EMDM' : 'DDIM'} · ${p.result.steps} step${p.result.steps === 1 ? '' : 's'}`;
    }
    showFigures(emdm.result.motion, ddim.result.motion, real);
  }

  /** Say what failed: a model file in the error panel, a bad generation in a notice. */
  reportError(e: unknown, model: string): void {
    if (e instanceof ModelFileError) {
      const why = e.reason === 'sha256' ? 'its checksum does not match the manifest (corrupt or replaced file)'
        : e.reason === 'missing' ? 'the file is missing' : e.reason === 'incompatible' ? 'the file is not a compatible model' : 'it could not be downloaded';
      this.errorPanel.show(`The model ${model} cannot be used`, `${e.path}: ${why}.`, `Details: ${e.message}`);
    } else if (isNonFinite(e)) {
      this.notices.show('error', `Generation failed: ${describe(e)}; the character keeps its last good motion.`);
    } else {
      this.notices.show('error', `Generation failed: ${describe(e)}`);
    }
  }

  // ------------------------------------------------------------ downloads
  private bindDownloads(): void {
    const skeleton = this.skeleton;
    const guard = (fn: (s: Shown) => Promise<void> | void) => async () => {
      if (!this.shown) return;
      try {
        await fn(this.shown);
      } catch (e) {
        this.notices.show('error', `Download failed: ${describe(e)}`);
      }
    };
    byId('dl-bvh').addEventListener('click', guard((s) => {
      const { blob, filename } = motionToBVH(skeleton, s.result.motion, fileStem(s.label, seedOf(s)), byId('dl-bvh-units', HTMLSelectElement).value);
      saveBlob(blob, filename);
    }));
    byId('dl-glb').addEventListener('click', guard(async (s) => {
      const glb = await motionToGLB(skeleton, s.track);
      saveBlob(new Blob([glb], { type: 'model/gltf-binary' }), `${fileStem(s.label, seedOf(s))}.glb`);
    }));
    byId('dl-json').addEventListener('click', guard((s) => {
      // what made the motion on screen: one generation, a timeline's segments, an edit and its base, a live recording's prompts
      const json = motionToJSON(skeleton, s.result.motion.joints, s.result.motion.frames, s.result.motion.fps, generatorOf(s));
      saveBlob(new Blob([json], { type: 'application/json' }), `${fileStem(s.label, seedOf(s))}.json`);
    }));
  }

  // ------------------------------------------------------------ drawing
  private startLoop(bones: Bone[]): void {
    this.loopBones = bones;
    let last = performance.now();
    const tick = (now: number) => {
      const dt = Math.min(0.1, Math.max(0, (now - last) / 1000));
      last = now;
      let second: ArrayLike<number> | null = null;
      const player = this.player;
      const driven = this.driver?.pose(dt) ?? null;
      if (driven) {
        // the bones where this frame's solve put them (they change when a new window's solve comes into play)
        if (driven.offsets) this.place(driven.offsets);
        applyPose(this.loopBones, driven.root, driven.quats);
      }
      else if (player.track) {
        player.update(dt);
        applyPose(this.loopBones, player.root, player.quats);
        this.playback.sync();
        if (this.compareShown && this.player2.track) {
          this.player2.seek(player.time); // same length and clock: the two motions play in step
          applyPose(this.ddimCharacter.bones, this.player2.root, this.player2.quats);
          second = this.player2.root;
        }
      }
      this.stage.frame(dt, driven ? driven.root : player.track ? player.root : null, second);
      const times = this.frameTimes;
      times.push(now);
      while (times.length > 2 && now - times[0] > 2000) times.shift();
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }
}

function stepsText(n: number): string {
  return `${n} step${n === 1 ? '' : 's'}`;
}
