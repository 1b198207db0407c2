// The demo page: type a prompt (or pick an action, or nothing), watch the skinned character move.
// Wiring only:
//   - the session (web/ui/session.ts): the manifest's models in the generation worker (src/worker, via
//     web/ui/engine.ts: encoder, sampler and IK run there, never on this thread), newest request wins;
//   - the view (web/ui/view.ts): stage, characters, playback, status line, panels, downloads;
//   - the controls (web/ui/controls.ts) and their URL form (web/ui/state.ts);
//   - live mode (web/ui/live.ts): the Live toggle, a stream that never stops;
//   - the test API (web/ui/testapi.ts, window.emdm).
// A new panel gets `page` (PageContext: session, view, controls, generate) — see the end of main().
import { clearModelCache, loadManifest, ModelFileError, modelCacheUsage, type Manifest } from '../src/index';
import { useModelCache } from '../src/cache/modelCache';
import { loadCapabilities } from '../src/capabilities';
import { compareNote } from './ui/compare';
import { Controls } from './ui/controls';
import { byId } from './ui/dom';
import { isAbort, modelForMode, pageThreads, pageVariant, pickModels } from './ui/engine';
import { examplePrompts } from './ui/examples';
import { CacheControl, FileList } from './ui/files';
import { ErrorPanel, Notices } from './ui/notices';
import type { PageContext } from './ui/page-context';
import { failedModel, limitsFor, Session, type Generation, type SessionGenerateOptions } from './ui/session';
import { pageFlagNotices, parseState, randomSeed, stateToSearch, unknownParamsNotice, type PageState, type StateLimits } from './ui/state';
import { connectTestApi, installTestApi } from './ui/testapi';
import { KnowsPanel, markWeakActions } from './ui/knows';
import { LivePanel } from './ui/live';
import { linkOf } from './ui/provenance';
import { TimelinePanel } from './ui/timeline';
import { withRawTimeline } from './ui/timeline-url';
import { describe, promptNote, View } from './ui/view';

const MODELS_URL = `${import.meta.env.BASE_URL}models/`;
/** Shown when the page is served without COOP/COEP: ORT then runs its WebAssembly on one thread. */
const NOT_ISOLATED = 'This page is not cross-origin isolated, so the model runs on one CPU thread (slower). '
  + 'To use every core, serve it with the headers Cross-Origin-Opener-Policy: same-origin and '
  + 'Cross-Origin-Embedder-Policy: require-corp (as `make demo` and `vite preview` do).';
/** `?noauto` (tests): do not generate a first motion on load. Read before the URL is rewritten. */
const AUTO_GENERATE = !new URLSearchParams(location.search).has('noauto');

// ---------------------------------------------------------------- installed first (the test API sees loading)
const notices = new Notices();
const errorPanel = new ErrorPanel();
const fileList = new FileList();
const cacheControl = new CacheControl(modelCacheUsage, clearModelCache, (e) => notices.show('error', `Clearing the model cache failed: ${describe(e)}`));
const view = new View(notices, errorPanel);
const { api, finish } = installTestApi({
  notices,
  files: () => [...fileList.states.values()].map((f) => ({ path: f.path, state: f.state, cached: f.cached, total: f.total, at: f.at })),
  cache: {
    usage: modelCacheUsage,
    async clear() {
      await clearModelCache();
      await cacheControl.refresh();
    },
  },
  frameTimes: view.frameTimes,
  playback: () => ({ time: view.player.time, playing: view.player.playing, speed: view.player.speed, duration: view.player.duration }),
  quality: () => view.stage.quality,
});

async function main(): Promise<void> {
  const loaded = await loadPageManifest();
  if (!loaded) return;
  const { manifest, models, limits } = loaded;
  const { parsed, variant, threads } = readUrl(manifest, limits);
  const session = startSession(manifest, limits, parsed.state.backend, variant, threads);

  // The first model (and ONNX Runtime) start loading in the worker now, while this thread builds the
  // view: the page is ready sooner on a cold and on a second visit (awaited and reported below).
  const early = modelForMode(models, parsed.state.mode) ?? models.text ?? models.action;
  const earlyLoad = early ? session.load(early.name) : null;
  earlyLoad?.catch(() => undefined);
  // Building the view (characters, materials, the first frames) keeps this thread busy for most of a
  // second, and Chromium starts a module worker's script only when this thread lets it: wait until the
  // worker is running (its first message) before building, at most 1.5 s. Measured (EMDM_BENCH=1
  // page-bench-load.spec.ts, quiet 2-core machine, median of 3): cold ready 4.21 → 2.72 s, second visit
  // 2.71 → 1.92 s; the worker's first cache read moved from ~1.25 s to ~0.35 s after navigation.
  await Promise.race([session.engine.client.environment.catch(() => undefined), new Promise((r) => setTimeout(r, 1500))]);
  view.attach(manifest.skeleton);

  // ------------------------------------------------------------ controls, and generating as the page does
  let generate: PageContext['generate'] = () => Promise.reject(new Error('the page is still starting'));
  const { controls, knows } = buildControls(manifest, models, limits, session, parsed.state, (s) => void generate(s).catch(() => undefined));
  // a motion shown (one generation, a timeline, an edit, a live recording): the address says what the link makes
  view.onShown = () => writeLink(controls.read());
  generate = pageGenerate(session, controls, knows, models);

  // ------------------------------------------------------------ panels and the test API get the page
  const page: PageContext = { session, view, controls, generate };
  connectTestApi(api, page);
  const timeline = new TimelinePanel(page, byId('edit-panel'));
  openedTimeline = timeline.linkValue;
  if (openedTimeline !== null) writeLink(controls.read());
  api.edit = timeline.testApi();
  api.live = new LivePanel(page, knows, notices).testApi();

  // ------------------------------------------------------------ cold start: load the first model
  const first = modelForMode(models, controls.read().mode) ?? (models.text ?? models.action)!;
  if (!(await coldStart(session, controls, models, first, earlyLoad && early?.name === first.name ? earlyLoad : null))) return;
  // Show something right away: the motion the URL (or the defaults) describe.
  // A link whose timeline was refused generates nothing: its message stays in the panel (not replaced by another motion).
  if (AUTO_GENERATE && !timeline.linkRefused) void (timeline.restoredFromUrl ? timeline.generateAll() : generate(controls.read())).catch(() => undefined);
}

type Models = ReturnType<typeof pickModels>;

/** The manifest, its models and their limits; null (the page says why) when there is nothing to run. */
async function loadPageManifest(): Promise<{ manifest: Manifest; models: Models; limits: StateLimits } | null> {
  let manifest: Manifest;
  try {
    manifest = await loadManifest(MODELS_URL);
    api.startup.manifestMs = performance.now();
  } catch (e) {
    view.status.show('error', 'Models unavailable');
    errorPanel.show('The model list could not be loaded', describe(e),
      'The page needs public/models/manifest.json and the files it lists (run `make demo`).');
    finish('error', describe(e));
    return null;
  }
  const models = pickModels(manifest);
  const limits = limitsFor(manifest, models);
  if (!limits) {
    view.attach(manifest.skeleton);
    view.status.show('error', 'No motion model');
    errorPanel.show('No motion model is shipped', 'public/models/manifest.json lists no text or action model.',
      'Export one with `python -m emdm.export` (see README).');
    finish('error', 'manifest lists no models');
    return null;
  }
  return { manifest, models, limits };
}

/** The page's state, model variant and threads from the URL, each problem with it a notice. */
function readUrl(manifest: Manifest, limits: StateLimits) {
  const parsed = parseState(location.search, limits, randomSeed());
  for (const n of parsed.notices) notices.show('warn', n, 14000);
  const unknownParams = unknownParamsNotice(location.search);
  if (unknownParams) notices.show('warn', unknownParams, 14000);
  for (const n of pageFlagNotices(location.search)) notices.show('warn', n, 14000);
  const variant = pageVariant(manifest, location.search);
  if (variant.notice) notices.show('warn', variant.notice, 14000);
  const threads = pageThreads(location.search);
  if (threads.notice) notices.show('warn', threads.notice, 14000);
  return { parsed, variant: variant.variant, threads: threads.threads };
}

/** The session: the models in the worker, its downloads, fallbacks and files shown on the page. */
function startSession(manifest: Manifest, limits: StateLimits, backend: PageState['backend'], variant: ReturnType<typeof pageVariant>['variant'], threads: ReturnType<typeof pageThreads>['threads']): Session {
  const session = new Session(manifest, limits, MODELS_URL, backend, {
    download: (model, loaded, total) => view.status.download(model, loaded, total),
    fallback: (model, reason) => notices.show('info', `${reason}: ${model} runs on WebAssembly (CPU) instead.`, 12000),
    file: (e) => {
      fileList.update(e);
      if (e.state === 'done' && api.ready) void cacheControl.refresh(); // a model loaded later (compare view)
    },
    notice: (kind, text) => notices.show(kind, text, 14000),
  }, api.counters, variant, threads);
  session.onLoad = (model, e) => {
    if (e.phase === 'start') view.status.begin(model);
    else if (e.phase === 'ready') view.status.end(model, 'ready', view.status.last?.kind === 'ready' ? view.status.last.text : `Ready · ${e.info.backend === 'webgpu' ? 'WebGPU' : 'WASM'}`);
    else view.status.end(model, 'error', `${model} unavailable`);
  };
  void session.engine.client.environment.then((env) => {
    api.environment = env;
    if (!env.crossOriginIsolated) {
      const note = byId('isolation-note');
      note.textContent = NOT_ISOLATED;
      note.hidden = false;
      notices.show('warn', NOT_ISOLATED, 20000);
    }
  });
  return session;
}

/** The side bar's controls (set to `state`, their changes in the URL), and what the models do well beside them. */
function buildControls(manifest: Manifest, models: Models, limits: StateLimits, session: Session, state: PageState, generate: (s: PageState) => void) {
  const controls = new Controls(limits, examplePrompts(manifest, models.text?.name ?? null, limits.actions), {
    generate: () => generate(controls.read()),
    cancel: () => session.engine.cancel(),
    change: (s) => {
      writeLink(s);
      if (s.compare) preloadDiffusion();
      else view.leaveCompare();
    },
    stepsNote: (s) => {
      const plan = s.compare ? session.planCompare(s.steps) : null;
      return plan ? compareNote(s.steps, plan) : '';
    },
  });
  /** Start loading the diffusion model as soon as the compare view is turned on; a failure disables it. */
  function preloadDiffusion(): void {
    if (!models.diffusion) return;
    const name = models.diffusion.name;
    session.load(name).catch((e) => {
      view.reportError(e, name);
      controls.setCompareAvailable(`The diffusion model ${name} failed to load: ${describe(e)}`);
    });
  }
  controls.set(state);
  const knows = showCapabilities(manifest, models, controls);
  if (!models.action) controls.setModeAvailable('action', 'No action model is shipped with this demo');
  if (!models.text) {
    controls.setModeAvailable('text', 'No text model is shipped with this demo');
    controls.setModeAvailable('random', 'No text model is shipped with this demo');
    if (state.mode !== 'action') controls.setMode('action');
  }
  history.replaceState(null, '', stateToSearch(controls.read()));
  return { controls, knows };
}

/** The `tl` value of the link the page was opened with (writeLink keeps it until a motion is shown). */
let openedTimeline: string | null = null;

/**
 * The page's address for the controls' state and the motion on screen (web/ui/provenance.ts linkOf): a timeline stays
 * in it across control changes; an edit or a live recording, which a link cannot hold, is named in a note under
 * Copy link (#link-note, which then describes the button).
 */
function writeLink(state: PageState): void {
  const { search, note } = linkOf(state, view.shown);
  // a link with a timeline keeps it, as it was, in the address until a motion is shown (a refused one: the panel says
  // what is wrong, and the visitor can still copy and mend it)
  history.replaceState(null, '', openedTimeline !== null && !view.shown ? withRawTimeline(search, openedTimeline) : search);
  const el = byId('link-note');
  el.textContent = note;
  el.hidden = !note;
  if (note) byId('copy-link').setAttribute('aria-describedby', 'link-note');
  else byId('copy-link').removeAttribute('aria-describedby');
}

/** What the models do well (capabilities files): the list beside the prompt, the weak actions, the far-prompt notice. */
function showCapabilities(manifest: Manifest, models: Models, controls: Controls): KnowsPanel {
  const knows = new KnowsPanel((text) => controls.usePrompt(text));
  // the capabilities files are verified files like the models: listed with them, and served from the same Cache
  // Storage on a second visit
  useModelCache((e) => fileList.update(e), (text) => notices.show('warn', text, 14000));
  const capsOf = (name: string | undefined) => (name ? loadCapabilities(manifest, MODELS_URL, name).catch((e) => {
    notices.show('warn', `What ${name} does well is unknown: ${describe(e)}`, 14000);
    return null;
  }) : Promise.resolve(null));
  void Promise.all([capsOf(models.text?.name), capsOf(models.action?.name)]).then(([t, a]) => {
    fileList.settle();                       // their rows fold away with the models' once they are in
    knows.setCapabilities(t, a);
    view.setTextCapabilities(t);
    markWeakActions(byId('action', HTMLSelectElement), a);
  });
  return knows;
}

/** Generate as the page does (newest request wins): busy controls, progress, previews, the result shown, errors reported. */
function pageGenerate(session: Session, controls: Controls, knows: KnowsPanel, models: Models): PageContext['generate'] {
  return async (s: PageState, o: SessionGenerateOptions = {}): Promise<Generation> => {
    const checked = session.check(s, o.model, controls.compareUnavailable(s.mode));
    const watch = !checked.plan && view.showSteps.checked;
    if (!checked.plan) view.resetPreviews();
    controls.setBusy(true);
    view.showProgress(0, 'Starting…');
    try {
      const g = await session.generate(s, { ...o, watch }, {
        progress: (f, text) => view.showProgress(f, text),
        preview: (p, signal) => view.showPreview(p, signal),
      }, controls.compareUnavailable(s.mode));
      view.show(g);
      if (s.mode === 'text') controls.setPromptNote(s.text, promptNote(g.main.result.prompt));
      if (s.mode === 'text') knows.showCheck(s.text, g.main.result.promptCheck);
      else knows.hideCheck();
      view.stepStrip.reveal();
      history.replaceState(null, '', stateToSearch(g.state));
      const t = g.main.result.timings;
      view.status.show('ready', `Ready · ${t.backend === 'webgpu' ? 'WebGPU' : 'WASM'} · ${t.threads} thread${t.threads === 1 ? '' : 's'}`);
      return g;
    } catch (e) {
      if (!isAbort(e)) {
        const model = failedModel(e) || checked.model;
        view.reportError(e, model);
        if (checked.plan && model === models.diffusion?.name && e instanceof ModelFileError) {
          controls.setCompareAvailable(`The diffusion model ${model} cannot be used: ${describe(e)}`);
        }
      }
      throw e;
    } finally {
      if (!session.busy) {
        controls.setBusy(false);
        view.hideProgress();
      }
    }
  };
}

/** Load the first model (`early`: its load already under way). False when it failed: the other mode is offered and the page is ready without it. */
async function coldStart(session: Session, controls: Controls, models: Models, first: NonNullable<Models['text']>, early: Promise<unknown> | null): Promise<boolean> {
  try {
    await (early ?? session.load(first.name));
    controls.setReady(true);
    finish('ready');
    fileList.settle();
    void cacheControl.refresh();
    return true;
  } catch (e) {
    fileList.settle();
    void cacheControl.refresh();
    view.reportError(e, first.name);
    const other = first === models.text ? models.action : models.text;
    if (first === models.text) {
      controls.setModeAvailable('text', `The text model failed to load: ${describe(e)}`);
      controls.setModeAvailable('random', `The text model failed to load: ${describe(e)}`);
    } else {
      controls.setModeAvailable('action', `The action model failed to load: ${describe(e)}`);
    }
    if (other) controls.setMode(other === models.action ? 'action' : 'text');
    // the URL says what the page now shows (the other mode), not the mode that failed
    history.replaceState(null, '', stateToSearch(controls.read()));
    view.status.show('error', `${first.name} unavailable${other ? ` · ${other === models.action ? 'Action' : 'Text'} mode still works` : ''}`);
    controls.setReady(true);
    finish('ready', describe(e));
    return false;
  }
}

main().catch((e) => {
  view.status.show('error', 'The page failed to start');
  errorPanel.show('The page failed to start', describe(e));
  finish('error', describe(e));
});
