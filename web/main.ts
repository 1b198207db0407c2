// The demo page: type a prompt (or pick an action, or nothing), watch the skinned character move.
// Wiring only: motions come from the generation worker (src/worker, through web/ui/engine.ts: encoder,
// sampler and IK run there, never on this thread), the character from src/character, the
// controls/URL/panels/downloads from web/ui.
import { MeshStandardMaterial, Quaternion, Vector3 } from 'three';
import { HEAD_PITCH, applyPose, createCharacter, MotionPlayer, type PoseTrack } from '../src/three';
import { type GenerateResult, type WireStepPreview, assertFinite, NonFiniteMotionError, loadManifest, ModelFileError, type Manifest, clearModelCache, modelCacheUsage } from '../src/index';
import { compareNote, compareStepChoices, planCompare, type ComparePlan } from './ui/compare';
import { Controls } from './ui/controls';
import { byId, formatBytes, formatMs, saveBlob } from './ui/dom';
import { fileStem, motionToBVH, motionToGLB, motionToJSON } from './ui/downloads';
import { Engine, isAbort, modelForMode, pickModels } from './ui/engine';
import { examplePrompts } from './ui/examples';
import { CharacterPicker } from './ui/character-picker';
import { CacheControl, FileList } from './ui/files';
import { ErrorPanel, Notices } from './ui/notices';
import { PlaybackBar } from './ui/playback';
import { Stage } from './ui/stage';
import { StepStrip } from './ui/step-strip';
import {
  framesFor, parseState, randomSeed, stateToSearch, stepChoices, type PageState, type StateLimits,
} from './ui/state';
import { emptyCounters, type CompareResponse, type EmdmTestApi, type GenerateRequest, type GenerateResponse } from './ui/testapi';

const MODELS_URL = `${import.meta.env.BASE_URL}models/`;
/** Shown when the page is served without COOP/COEP: ORT then runs its WebAssembly on one thread. */
const NOT_ISOLATED = 'This page is not cross-origin isolated, so the model runs on one CPU thread (slower). '
  + 'To use every core, serve it with the headers Cross-Origin-Opener-Policy: same-origin and '
  + 'Cross-Origin-Embedder-Policy: require-corp (as `make demo` and `vite preview` do).';
/** `?noauto` (tests): do not generate a first motion on load. Read before the URL is rewritten. */
const AUTO_GENERATE = !new URLSearchParams(location.search).has('noauto');

/** generate() (in the worker) refused NaN/Infinity in a motion; the error crosses the worker by name. */
const isNonFinite = (e: unknown) => e instanceof NonFiniteMotionError || (e instanceof Error && e.name === 'NonFiniteMotionError');

/** The note under the prompt when the text encoder read only its first maxTokens tokens. */
function promptNote(p: GenerateResult['prompt']): string {
  return p?.truncated
    ? `Prompt truncated to ${p.maxTokens} tokens: the text encoder reads at most ${p.maxTokens} and this prompt has ${p.tokens}, so the words after that are ignored.`
    : '';
}

function describe(e: unknown): string {
  return e instanceof Error ? e.message : String(e);
}

interface Shown {
  state: PageState;
  result: GenerateResult;
  track: PoseTrack;
  label: string;
  /** the model and step count that made the (left, in compare mode) motion */
  model: string;
  steps: number;
  ikMs: number;
}

/** One model's finished motion, solved for the character. */
interface Produced {
  model: string;
  result: GenerateResult;
  track: PoseTrack;
  ikMs: number;
}


// ---------------------------------------------------------------- status line
const statusDot = byId('status-dot');
const statusText = byId('status-text');
const downloadBar = byId('download-bar');
const downloadFill = byId('download-fill');
function setStatus(kind: 'loading' | 'ready' | 'error', text: string): void {
  statusDot.className = `dot ${kind}`;
  statusText.textContent = text;
}

// ---------------------------------------------------------------- test API (installed first)
let resolveReady!: () => void;
const readyPromise = new Promise<void>((r) => (resolveReady = r));
const notices = new Notices();
const errorPanel = new ErrorPanel();
const fileList = new FileList();
const cacheControl = new CacheControl(modelCacheUsage, clearModelCache, (e) => notices.show('error', `Clearing the model cache failed: ${describe(e)}`));
const fpsTimes: number[] = [];
const api: EmdmTestApi = {
  ready: false,
  state: 'loading',
  error: '',
  whenReady: () => readyPromise,
  generate: () => Promise.reject(new Error('window.emdm.generate: the page is still loading (await window.emdm.whenReady())')),
  compare: () => Promise.reject(new Error('window.emdm.compare: the page is still loading (await window.emdm.whenReady())')),
  setCompare: () => {
    throw new Error('window.emdm.setCompare: the page is still loading (await window.emdm.whenReady())');
  },
  compareInfo: () => ({ available: false, reason: 'the page is still loading', on: false, steps: [], emdm: null, ddim: null, emdmMaxSteps: 0, panelsVisible: false, ddimCharacterVisible: false, split: false }),
  counters: emptyCounters(),
  backend: '',
  notices: () => notices.log.slice(),
  cspViolations: [],
  playbackFps() {
    if (fpsTimes.length < 2) return 0;
    return ((fpsTimes.length - 1) * 1000) / (fpsTimes[fpsTimes.length - 1] - fpsTimes[0]);
  },
  heapBytes() {
    const m = (performance as { memory?: { usedJSHeapSize: number } }).memory;
    return m ? m.usedJSHeapSize : null;
  },
  seek: () => undefined,
  playback: () => ({ time: player.time, playing: player.playing, speed: player.speed, duration: player.duration }),
  quality: () => stage.quality,
  frame: () => -1,
  startup: { manifestMs: NaN, readyMs: NaN },
  environment: null,
  files: () => [...fileList.states.values()].map((f) => ({ path: f.path, state: f.state, cached: f.cached, total: f.total, at: f.at })),
  previews: () => [],
  cache: {
    usage: modelCacheUsage,
    async clear() {
      await clearModelCache();
      await cacheControl.refresh();
    },
  },
};
window.emdm = api;
document.addEventListener('securitypolicyviolation', (e) => {
  api.cspViolations.push(`${e.violatedDirective}: ${e.blockedURI || 'inline'} (${e.sourceFile}:${e.lineNumber})`);
});

function finishStartup(state: 'ready' | 'error', error = ''): void {
  api.state = state;
  api.error = error;
  api.ready = true;
  api.startup.readyMs = performance.now();
  resolveReady();
}

// ---------------------------------------------------------------- scene
const stage = new Stage(byId('scene', HTMLCanvasElement));
// `?quality=high` keeps full resolution and shadows even when frames are slow (screenshots).
stage.adaptive = new URLSearchParams(location.search).get('quality') !== 'high';
const player = new MotionPlayer();
const playback = new PlaybackBar(player);
/** the DDIM motion of the compare view, kept in step with `player` (null when not comparing) */
const player2 = new MotionPlayer();
let compareShown: Produced | null = null;
let ddimBones: import('three').Bone[] = [];

async function main(): Promise<void> {
  let manifest: Manifest;
  try {
    manifest = await loadManifest(MODELS_URL);
    api.startup.manifestMs = performance.now();
  } catch (e) {
    setStatus('error', 'Models unavailable');
    errorPanel.show('The model list could not be loaded', describe(e),
      'The page needs public/models/manifest.json and the files it lists (run `make demo`).');
    finishStartup('error', describe(e));
    return;
  }
  const skeleton = manifest.skeleton;
  const character = createCharacter(skeleton);
  stage.add(character.object);
  restPose(character.bones, skeleton.offsets[0]);
  // the compare view's second character (DDIM), tinted warm; hidden until a comparison is shown
  const ddimCharacter = createCharacter(skeleton);
  (ddimCharacter.mesh.material as MeshStandardMaterial).color.setHex(0xffc58a);
  ddimCharacter.object.visible = false;
  ddimCharacter.object.name = 'ddim-character';
  stage.add(ddimCharacter.object);
  ddimBones = ddimCharacter.bones;
  // a character the visitor drops replaces the built-in one (web/ui/character-picker.ts)
  const picker = new CharacterPicker({
    add: (o) => stage.add(o), builtIn: character.object, skeleton, time: () => player.time,
    notify: (kind, text) => notices.show(kind, text), before: document.querySelector<HTMLElement>('section.downloads')!,
  });

  const models = pickModels(manifest);
  const base = models.text ?? models.action;
  if (!base) {
    setStatus('error', 'No motion model');
    errorPanel.show('No motion model is shipped', 'public/models/manifest.json lists no text or action model.',
      'Export one with `python -m emdm.export` (see README).');
    startLoop(character.bones);
    finishStartup('error', 'manifest lists no models');
    return;
  }
  const limits: StateLimits = {
    supportedSteps: [...base.entry.supportedSteps].sort((a, b) => a - b),
    defaultSteps: base.entry.defaultSteps,
    defaultGuidance: base.entry.guidance,
    actions: models.action && models.action.entry.condition.type === 'action' ? models.action.entry.condition.labels : [],
    fps: base.entry.fps,
    maxFrames: Math.min(base.entry.maxFrames, skeleton.maxFrames),
    defaultText: '',
    compareSteps: models.text && models.diffusion ? compareStepChoices(models.text.entry, models.diffusion.entry) : [],
  };
  const examples = examplePrompts(manifest, models.text?.name ?? null, limits.actions);
  limits.defaultText = examples[0] ?? '';
  const parsed = parseState(location.search, limits, randomSeed());
  for (const n of parsed.notices) notices.show('warn', n, 14000);

  let shown: Shown | null = null;
  const engine = new Engine(manifest, MODELS_URL, parsed.state.backend, {
    download(model, loaded, total) {
      downloadBar.hidden = loaded >= total;
      downloadFill.style.width = `${total > 0 ? (100 * loaded) / total : 0}%`;
      setStatus('loading', `Downloading ${model}: ${formatBytes(loaded)} / ${formatBytes(total)}`);
    },
    fallback(model, reason) {
      notices.show('info', `${reason}: ${model} runs on WebAssembly (CPU) instead.`, 12000);
    },
    file: (e) => {
      fileList.update(e);
      if (e.state === 'done' && api.ready) void cacheControl.refresh(); // a model loaded later (compare view)
    },
    notice: (kind, text) => notices.show(kind, text, 14000),
  });
  void engine.client.environment.then((env) => {
    api.environment = env;
    if (!env.crossOriginIsolated) {
      const note = byId('isolation-note');
      note.textContent = NOT_ISOLATED;
      note.hidden = false;
      notices.show('warn', NOT_ISOLATED, 20000);
    }
  });

  const controls = new Controls(limits, examples, {
    generate: () => void generate(controls.read()).catch(() => undefined),
    change: (s) => {
      history.replaceState(null, '', stateToSearch(s));
      if (s.compare) preloadDiffusion();
      else if (compareShown && shown) {
        // compare turned off: back to the EMDM character alone
        showCompare(null);
        stage.setPath(shown.track.rootPos, shown.track.frames);
        showTimings(shown.result, shown.ikMs);
      }
    },
    stepsNote: (s) => (s.compare && models.text && models.diffusion
      ? compareNote(s.steps, planCompare(s.steps, models.text.entry.supportedSteps, models.diffusion.entry.supportedSteps)) : ''),
  });
  /** Start loading the diffusion model as soon as the compare view is turned on; a failure disables it. */
  function preloadDiffusion(): void {
    if (!models.diffusion) return;
    const name = models.diffusion.name;
    engine.load(name).catch((e) => {
      reportError(e, name);
      controls.setCompareAvailable(`The diffusion model ${name} failed to load: ${describe(e)}`);
    });
  }
  controls.set(parsed.state);
  if (!models.action) controls.setModeAvailable('action', 'No action model is shipped with this demo');
  if (!models.text) {
    controls.setModeAvailable('text', 'No text model is shipped with this demo');
    controls.setModeAvailable('random', 'No text model is shipped with this demo');
    if (parsed.state.mode !== 'action') controls.setMode('action');
  }
  history.replaceState(null, '', stateToSearch(controls.read()));

  // ------------------------------------------------------------ progress + timings
  const progress = byId('progress');
  const progressFill = byId('progress-fill');
  const progressText = byId('progress-text');
  const showProgress = (fraction: number, text: string) => {
    progress.hidden = false;
    progressFill.style.width = `${Math.round(fraction * 100)}%`;
    progressText.textContent = text;
  };
  const showTimings = (r: GenerateResult, ikMs: number) => {
    const t = r.timings;
    const mean = t.stepMs.length ? t.stepMs.reduce((a, b) => a + b, 0) / t.stepMs.length : NaN;
    byId('t-encode').textContent = formatMs(t.encodeMs);
    byId('t-step').textContent = `${formatMs(mean)} × ${t.stepMs.length}`;
    byId('t-decode').textContent = formatMs(t.decodeMs + ikMs);
    byId('t-total').textContent = formatMs(t.totalMs + ikMs);
    byId('t-backend').textContent = `${t.backend === 'webgpu' ? 'WebGPU' : 'WASM'} · ${t.threads} thread${t.threads === 1 ? '' : 's'}`;
    byId('t-calls').textContent = String(r.modelCalls);
    byId('timings').hidden = false;
  };
  const caption = byId('caption');
  const showCaption = (s: PageState, label: string, plan: ComparePlan | null) => {
    caption.replaceChildren();
    const main = document.createElement('span');
    main.textContent = s.mode === 'text' ? `“${label}”` : label;
    const small = document.createElement('small');
    const steps = plan ? `EMDM ${plan.emdm} vs DDIM ${plan.ddim} steps` : `${s.steps} step${s.steps === 1 ? '' : 's'}`;
    small.textContent = `${s.mode} · seed ${s.seed} · ${steps} · ${s.seconds.toFixed(1)} s`;
    caption.append(main, small);
  };

  // ------------------------------------------------------------ generation (newest request wins)
  const condFor = (s: PageState) =>
    s.mode === 'text' ? { type: 'text' as const, text: s.text }
      : s.mode === 'action' ? { type: 'action' as const, label: limits.actions.indexOf(s.action) }
        : { type: 'none' as const };

  /** One model's motion for a state, checked and solved (WebGPU failures retry on WASM). */
  async function produce(model: string, s: PageState, steps: number, frames: number, signal: AbortSignal,
    progressLabel: (done: number, total: number) => string, watch = false): Promise<Produced> {
    const info = await engine.load(model);
    api.backend = info.backend;
    if (signal.aborted) throw signal.reason;
    // the worker encodes, samples, decodes and solves the bone rotations; this thread only shows them
    const result = await engine.generate(model, {
      condition: condFor(s), frames, steps, guidance: s.guidance, seed: s.seed, signal, smooth: true, footCleanup: true,
      onStep(done: number, total: number) {
        api.counters.stepsRun++;
        showProgressText(done, total, progressLabel(done, total));
      },
      ...(watch ? { previewSteps: true, onPreview: (p: WireStepPreview) => showPreview(p, signal) } : {}),
    });
    api.backend = result.info.backend;
    const pose = result.pose;
    if (!pose) throw new Error('generation worker: the result has no pose track (pose: true was asked)');
    assertFinite(pose.quats, 'the solved joint rotations'); // generate() already refused non-finite joints
    assertFinite(pose.rootPos, 'the solved root positions');
    const track: PoseTrack = { frames: result.motion.frames, fps: result.motion.fps, joints: skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats };
    return { model, result, track, ikMs: pose.ikMs };
  }
  let showProgressText: (done: number, total: number, text: string) => void = () => undefined;

  // ------------------------------------------------------------ show steps: each step's x̂0 on the character and in the strip
  const showSteps = byId('show-steps', HTMLInputElement);
  const stepStrip = new StepStrip(byId('step-strip'), skeleton.parents);
  let previews: ReturnType<EmdmTestApi['previews']> = [];
  api.previews = () => previews.map((p) => ({ ...p, joints: [...p.joints] }));
  showSteps.addEventListener('change', () => {
    if (!showSteps.checked) stepStrip.reset();
  });
  /** A step preview from the worker: into the strip, and onto the character until the next one (or the result). */
  function showPreview(p: WireStepPreview, signal: AbortSignal): void {
    if (signal.aborted) return;
    const entry = { step: p.step, steps: p.steps, frames: p.frames, joints: Array.from(p.joints), ms: p.ms, at: performance.now(), played: false };
    previews.push(entry);
    stepStrip.add(p.step, p.steps, p.joints, p.frames);
    const pose = p.pose;
    // a non-finite prediction is not shown; the final result reports it if it stays so
    if (!pose || !pose.quats.every(Number.isFinite) || !pose.rootPos.every(Number.isFinite)) return;
    player.setTrack({ frames: p.frames, fps: p.fps, joints: skeleton.joints.length, rootPos: pose.rootPos, quats: pose.quats });
    player.playing = true;
    entry.played = true;
    if (p.step === 1) stage.snapTo(pose.rootPos);
  }

  const respond = (s: PageState, p: Produced): GenerateResponse => ({
    state: s, frames: p.track.frames, fps: p.track.fps, joints: Array.from(p.result.motion.joints),
    timings: { ...p.result.timings, stepMs: [...p.result.timings.stepMs], ikMs: p.ikMs },
    modelCalls: p.result.modelCalls, model: p.model, sampler: p.result.sampler, steps: p.result.steps,
  });

  async function generate(requested: PageState, modelOverride?: string): Promise<GenerateResponse> {
    const s = { ...requested };
    api.counters.requests++;
    const compare = s.compare && !modelOverride;
    if (compare) {
      const why = controls.compareUnavailable(s.mode) || (!models.text || !models.diffusion ? 'no EMDM text model or no diffusion model' : '');
      if (why) throw new Error(`compare view unavailable: ${why}`);
    }
    const choice = modelOverride ? { name: modelOverride, entry: manifest.models[modelOverride] } : modelForMode(models, s.mode);
    if (!choice || !choice.entry) throw new Error(modelOverride ? `no model '${modelOverride}' in the manifest` : `no ${s.mode} model is shipped with this demo`);
    if (s.mode === 'text' && s.text.trim() === '') throw new Error('the prompt is empty: type what the character should do');
    if (s.mode === 'action' && !limits.actions.includes(s.action)) throw new Error(`unknown action '${s.action}'`);
    const frames = framesFor(s.seconds, limits);
    const label = s.mode === 'text' ? s.text.trim() : s.mode === 'action' ? s.action.replace(/[_-]+/g, ' ') : 'Random motion';
    const plan = compare ? planCompare(s.steps, models.text!.entry.supportedSteps, models.diffusion!.entry.supportedSteps) : null;
    controls.setBusy(true);
    showProgress(0, 'Starting…');
    const failing = { model: choice.name };
    try {
      const out = await engine.run(async (signal) => {
        showProgress(0, s.mode === 'text' ? 'Encoding the prompt…' : 'Sampling…');
        if (!plan) {
          showProgressText = (d, t, text) => showProgress(d / t, text);
          const watch = showSteps.checked;
          previews = [];
          stepStrip.reset();
          return { main: await produce(choice.name, s, s.steps, frames, signal, (d, t) => `Denoising step ${d} / ${t}`, watch), ddim: null };
        }
        // compare: EMDM first, then DDIM, one after the other (fair timings on a shared CPU)
        const total = plan.emdm + plan.ddim;
        showProgressText = (d, t, text) => showProgress(text.startsWith('EMDM') ? d / total : (plan.emdm + d) / total, text);
        const main = await produce(models.text!.name, s, plan.emdm, frames, signal, (d, t) => `EMDM: denoising step ${d} / ${t}`);
        failing.model = models.diffusion!.name;
        const ddim = await produce(models.diffusion!.name, s, plan.ddim, frames, signal, (d, t) => `DDIM: denoising step ${d} / ${t}`);
        return { main, ddim };
      });
      const { main, ddim } = out;
      player.setTrack(main.track);
      player.playing = true;
      showCompare(ddim);
      stage.setPath(main.track.rootPos, ddim ? 0 : main.track.frames);
      stage.snapTo(main.track.rootPos);
      if (ddim) stage.snapTo2(ddim.track.rootPos);
      shown = { state: s, result: main.result, track: main.track, label, model: main.model, steps: main.result.steps, ikMs: main.ikMs };
      picker.setMotion(main.result.motion, fileStem(label, s.seed));
      if (s.mode === 'text') controls.setPromptNote(s.text, promptNote(main.result.prompt));
      showCaption(s, label, plan);
      if (ddim) showPanels(main, ddim);
      else showTimings(main.result, main.ikMs);
      for (const id of ['dl-bvh', 'dl-glb', 'dl-json']) byId(id, HTMLButtonElement).disabled = false;
      history.replaceState(null, '', stateToSearch(s));
      api.counters.generations++;
      api.counters.modelCalls += main.result.modelCalls + (ddim?.result.modelCalls ?? 0);
      const t = main.result.timings;
      setStatus('ready', `Ready · ${t.backend === 'webgpu' ? 'WebGPU' : 'WASM'} · ${t.threads} thread${t.threads === 1 ? '' : 's'}`);
      const r = respond(s, main);
      if (ddim) r.compare = { emdm: respond(s, main), ddim: respond(s, ddim) };
      return r;
    } catch (e) {
      if (isAbort(e)) {
        api.counters.cancelled++;
      } else {
        api.counters.errors++;
        reportError(e, failing.model);
        if (plan && failing.model === models.diffusion?.name && e instanceof ModelFileError) {
          controls.setCompareAvailable(`The diffusion model ${failing.model} cannot be used: ${describe(e)}`);
        }
      }
      throw e;
    } finally {
      if (!engine.busy) {
        controls.setBusy(false);
        progress.hidden = true;
      }
    }
  }

  // ------------------------------------------------------------ compare view: second character + panels
  const comparePanels = byId('compare-panels');
  const compareDivider = byId('compare-divider');
  const timingsHud = byId('timings');
  function showCompare(ddim: Produced | null): void {
    compareShown = ddim;
    if (ddim) {
      player2.setTrack(ddim.track);
      player2.playing = false;
    }
    ddimCharacter.object.visible = !!ddim;
    // split view: EMDM in the left half, DDIM in the right, each followed by its own camera
    stage.setSplit(ddim ? { left: character.object, right: ddimCharacter.object } : null);
    comparePanels.hidden = !ddim;
    compareDivider.hidden = !ddim;
    if (ddim) timingsHud.hidden = true;
  }
  function showPanels(emdm: Produced, ddim: Produced): void {
    for (const [id, p] of [['emdm', emdm], ['ddim', ddim]] as const) {
      const t = p.result.timings;
      const mean = t.stepMs.length ? t.stepMs.reduce((a, b) => a + b, 0) / t.stepMs.length : NaN;
      byId(`panel-${id}-label`).textContent = id === 'emdm' ? 'EMDM (left)' : 'DDIM (right)';
      byId(`panel-${id}-sub`).textContent = `${p.model} · ${p.result.sampler === 'ddim' ? 'DDIM, η = 0' : 'DDGAN posterior'}`;
      byId(`panel-${id}-steps`).textContent = `${p.result.steps} (${p.result.modelCalls} model call${p.result.modelCalls === 1 ? '' : 's'})`;
      byId(`panel-${id}-step`).textContent = formatMs(mean);
      byId(`panel-${id}-total`).textContent = formatMs(t.totalMs + p.ikMs);
    }
  }

  function reportError(e: unknown, model: string): void {
    if (e instanceof ModelFileError) {
      const why = e.reason === 'sha256' ? 'its checksum does not match the manifest (corrupt or replaced file)'
        : e.reason === 'missing' ? 'the file is missing' : e.reason === 'incompatible' ? 'the file is not a compatible model' : 'it could not be downloaded';
      errorPanel.show(`The model ${model} cannot be used`, `${e.path}: ${why}.`, `Details: ${e.message}`);
    } else if (isNonFinite(e)) {
      notices.show('error', `Generation failed: ${describe(e)}; the character keeps its last good motion.`);
    } else {
      notices.show('error', `Generation failed: ${describe(e)}`);
    }
  }

  // ------------------------------------------------------------ downloads
  const guard = (fn: (s: Shown) => Promise<void> | void) => async () => {
    if (!shown) return;
    try {
      await fn(shown);
    } catch (e) {
      notices.show('error', `Download failed: ${describe(e)}`);
    }
  };
  byId('dl-bvh').addEventListener('click', guard((s) => {
    const { blob, filename } = motionToBVH(skeleton, s.result.motion, fileStem(s.label, s.state.seed), byId('dl-bvh-units', HTMLSelectElement).value);
    saveBlob(blob, filename);
  }));
  byId('dl-glb').addEventListener('click', guard(async (s) => {
    const glb = await motionToGLB(skeleton, s.track);
    saveBlob(new Blob([glb], { type: 'model/gltf-binary' }), `${fileStem(s.label, s.state.seed)}.glb`);
  }));
  byId('dl-json').addEventListener('click', guard((s) => {
    const json = motionToJSON(skeleton, s.result.motion.joints, s.result.motion.frames, s.result.motion.fps, {
      model: s.model, mode: s.state.mode, text: s.state.mode === 'text' ? s.state.text : undefined,
      action: s.state.mode === 'action' ? s.state.action : undefined, steps: s.steps, guidance: s.state.guidance, seed: s.state.seed,
    });
    saveBlob(new Blob([json], { type: 'application/json' }), `${fileStem(s.label, s.state.seed)}.json`);
  }));

  // ------------------------------------------------------------ test API
  api.generate = (req: GenerateRequest = {}) => {
    const s: PageState = { ...controls.read() };
    if (req.mode !== undefined) s.mode = req.mode;
    if (req.text !== undefined) s.text = req.text;
    if (req.action !== undefined) s.action = req.action;
    if (req.steps !== undefined) s.steps = req.steps;
    if (req.seconds !== undefined) s.seconds = req.seconds;
    if (req.guidance !== undefined) s.guidance = req.guidance;
    if (req.seed !== undefined) s.seed = req.seed;
    if (req.compare !== undefined) s.compare = req.compare;
    if (req.model !== undefined) {
      // one named model (benchmarks: e.g. the diffusion model alone), never the compare view
      const entry = manifest.models[req.model];
      if (!entry) return Promise.reject(new Error(`window.emdm.generate: no model '${req.model}' in the manifest (models: ${Object.keys(manifest.models).join(', ')})`));
      if (req.compare) return Promise.reject(new Error('window.emdm.generate: give either model or compare, not both'));
      if (!entry.supportedSteps.includes(s.steps)) return Promise.reject(new RangeError(`steps ${s.steps} is not one of ${req.model}'s ${entry.supportedSteps.join(', ')}`));
      s.compare = false;
      controls.set(s);
      return generate(s, req.model);
    }
    if (s.compare) {
      const why = controls.compareUnavailable(s.mode);
      if (why) return Promise.reject(new Error(`window.emdm.generate: compare view unavailable: ${why}`));
    }
    const choices = stepChoices(limits, s.compare);
    if (!choices.includes(s.steps)) return Promise.reject(new RangeError(`steps ${s.steps} is not one of ${choices.join(', ')}`));
    controls.set(s);
    return generate(s);
  };
  api.compare = async (req: GenerateRequest = {}): Promise<CompareResponse> => {
    const r = await api.generate({ ...req, compare: true });
    if (!r.compare) throw new Error('window.emdm.compare: the page did not produce a comparison');
    return { state: r.state, ...r.compare };
  };
  api.setCompare = (on: boolean) => {
    const why = controls.compareUnavailable();
    if (on && why) throw new Error(`window.emdm.setCompare: compare view unavailable: ${why}`);
    controls.setCompare(on, true);
  };
  api.compareInfo = () => {
    const why = controls.compareUnavailable();
    return {
      available: why === '', reason: why, on: controls.read().compare, steps: [...limits.compareSteps],
      emdm: models.text?.name ?? null, ddim: models.diffusion?.name ?? null,
      emdmMaxSteps: models.text ? Math.max(...models.text.entry.supportedSteps) : 0,
      panelsVisible: !comparePanels.hidden, ddimCharacterVisible: ddimCharacter.object.visible, split: stage.isSplit,
    };
  };
  api.seek = (time: number, play = false) => {
    player.seek(time);
    player.playing = play;
  };
  api.frame = () => (player.track ? player.frame : -1);

  startLoop(character.bones);

  // ------------------------------------------------------------ cold start: load the first model
  const first = modelForMode(models, controls.read().mode) ?? base;
  setStatus('loading', `Loading ${first.name}…`);
  try {
    const gen = await engine.load(first.name);
    api.backend = gen.backend;
    setStatus('ready', `Ready · ${gen.backend === 'webgpu' ? 'WebGPU' : 'WASM'}`);
    downloadBar.hidden = true;
    controls.setReady(true);
    finishStartup('ready');
    fileList.settle();
    void cacheControl.refresh();
  } catch (e) {
    downloadBar.hidden = true;
    fileList.settle();
    void cacheControl.refresh();
    reportError(e, first.name);
    setStatus('error', `${first.name} unavailable`);
    const other = first === models.text ? models.action : models.text;
    if (first === models.text) {
      controls.setModeAvailable('text', `The text model failed to load: ${describe(e)}`);
      controls.setModeAvailable('random', `The text model failed to load: ${describe(e)}`);
    } else {
      controls.setModeAvailable('action', `The action model failed to load: ${describe(e)}`);
    }
    if (other) controls.setMode(other === models.action ? 'action' : 'text');
    controls.setReady(true);
    finishStartup('ready', describe(e));
    return;
  }
  // Show something right away: the motion the URL (or the defaults) describe.
  if (AUTO_GENERATE) void generate(controls.read()).catch(() => undefined);
}

/** Arms relaxed down (A-pose) until the first motion arrives. */
function restPose(bones: import('three').Bone[], pelvis: number[]): void {
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

function startLoop(bones: import('three').Bone[]): void {
  let last = performance.now();
  const tick = (now: number) => {
    const dt = Math.min(0.1, Math.max(0, (now - last) / 1000));
    last = now;
    let second: ArrayLike<number> | null = null;
    if (player.track) {
      player.update(dt);
      applyPose(bones, player.root, player.quats);
      playback.sync();
      if (compareShown && player2.track) {
        player2.seek(player.time); // same length and clock: the two motions play in step
        applyPose(ddimBones, player2.root, player2.quats);
        second = player2.root;
      }
    }
    stage.frame(dt, player.track ? player.root : null, second);
    fpsTimes.push(now);
    while (fpsTimes.length > 2 && now - fpsTimes[0] > 2000) fpsTimes.shift();
    requestAnimationFrame(tick);
  };
  requestAnimationFrame(tick);
}

main().catch((e) => {
  setStatus('error', 'The page failed to start');
  errorPanel.show('The page failed to start', describe(e));
  finishStartup('error', describe(e));
});
