// The side-bar form: mode tabs, prompt + examples, action list, the compare toggle, sliders, seed +
// dice, Generate. It owns the DOM of the controls and turns it into a PageState; it never runs a model itself.
import { byId, el } from './dom';
import {
  MAX_GUIDANCE, MAX_SECONDS, MAX_SEED, MIN_GUIDANCE, MIN_SECONDS, emdmSteps, nearestSteps, randomSeed,
  stepChoices, type Mode, type PageState, type StateLimits,
} from './state';

/**
 * The note under a prompt with no English word in it ('' otherwise): the text encoder and the captions the
 * model was trained on are English, so such a prompt (一个人在跳舞, 🕺) still makes a motion, but not one that follows it.
 */
export function promptLanguageNote(text: string): string {
  const t = text.trim();
  return t !== '' && !/[A-Za-z]/.test(t)   // one Latin letter will do: "a", typed first, is no cause for the note
    ? 'The model was trained on English descriptions: this prompt has no English words, so the motion will not follow it.'
    : '';
}

/** Copy the page's address (it always says the current state) and say so on the button for a moment. */
async function copyLink(button: HTMLButtonElement): Promise<void> {
  const label = 'Copy link';
  try {
    await navigator.clipboard.writeText(location.href);
    button.textContent = 'Link copied';
  } catch {
    button.textContent = 'Copy the address bar';
  }
  setTimeout(() => (button.textContent = label), 2500);
}

export interface ControlsEvents {
  generate(): void;
  change(state: PageState): void;
  /** stop the running generation */
  cancel?(): void;
  /** the note under the steps slider for a state ('' = none), e.g. what each model runs in compare mode */
  stepsNote?(state: PageState): string;
}

const COMPARE_ACTION_REASON = 'The diffusion (DDIM) model takes a text prompt or nothing: switch to Text or Random to compare.';

export class Controls {
  private readonly prompt = byId('prompt', HTMLTextAreaElement);
  private readonly promptHint = byId('prompt-hint');
  private readonly action = byId('action', HTMLSelectElement);
  private readonly steps = byId('steps', HTMLInputElement);
  private readonly seconds = byId('seconds', HTMLInputElement);
  private readonly guidance = byId('guidance', HTMLInputElement);
  private readonly seed = byId('seed', HTMLInputElement);
  private readonly button = byId('generate', HTMLButtonElement);
  private readonly cancel = byId('cancel', HTMLButtonElement);
  private readonly compare = byId('compare', HTMLInputElement);
  private readonly compareParam = byId('compare-param');
  private readonly compareHint = byId('compare-hint');
  private readonly stepsNote = byId('steps-note');
  private readonly compareText = this.compareHint.textContent ?? '';
  /** why compare mode cannot be used (no diffusion model, it failed to load), null when it can */
  private compareBlocked: string | null = null;
  private readonly tabs = Array.from(document.querySelectorAll<HTMLButtonElement>('.modes [data-mode]'));
  private mode: Mode = 'text';
  private ready = false;
  private backend: PageState['backend'] = 'auto';
  private readonly unavailable = new Map<Mode, string>();
  /** live mode (web/ui/live.ts): Enter and the example chips send their prompt here instead of generating */
  private live: ((text: string) => void) | null = null;
  /** what the text encoder said about a prompt it cut, shown under the prompt while it reads `text` */
  private promptNote: { text: string; note: string } | null = null;

  constructor(private readonly limits: StateLimits, examples: string[], private readonly on: ControlsEvents) {
    this.steps.min = '0';
    this.steps.max = String(limits.supportedSteps.length - 1);
    if (!limits.compareSteps.length) this.setCompareAvailable('This demo ships no diffusion (DDIM) model to compare with (manifest model diffusion-t2m-web).');
    this.compare.addEventListener('change', () => this.setCompare(this.compare.checked, true));
    this.seconds.min = String(MIN_SECONDS);
    this.seconds.max = String(MAX_SECONDS);
    this.guidance.min = String(MIN_GUIDANCE);
    this.guidance.max = String(MAX_GUIDANCE);
    this.seed.max = String(MAX_SEED);
    for (const label of limits.actions) {
      const o = el('option', undefined, label.replace(/[_-]+/g, ' '));
      o.value = label;
      this.action.append(o);
    }
    const box = byId('examples');
    for (const ex of examples) {
      const chip = el('button', 'chip', ex);
      chip.type = 'button';
      chip.addEventListener('click', () => this.usePrompt(ex));
      box.append(chip);
    }
    byId('examples').hidden = examples.length === 0;

    for (const tab of this.tabs) {
      tab.addEventListener('click', () => this.setMode(tab.dataset.mode as Mode, true));
      tab.addEventListener('keydown', (e) => this.tabKey(e, tab));
    }
    this.prompt.addEventListener('input', () => this.refresh(true));
    this.selectOnTab();
    this.prompt.addEventListener('keydown', (e) => {
      if (e.key === 'Enter' && !e.shiftKey && !e.isComposing) {
        e.preventDefault();
        if (this.live) this.live(this.prompt.value);
        else if (!this.button.disabled) this.on.generate();
      }
    });
    for (const input of [this.steps, this.seconds, this.guidance, this.seed, this.action]) {
      input.addEventListener('input', () => this.refresh(true));
    }
    this.seed.addEventListener('change', () => {
      this.seed.value = String(this.readSeed());
      this.refresh(true);
    });
    byId('dice').addEventListener('click', () => {
      this.seed.value = String(randomSeed());
      this.refresh(true);
      if (!this.button.disabled) this.on.generate();
    });
    this.button.addEventListener('click', () => this.on.generate());
    this.cancel.addEventListener('click', () => this.on.cancel?.());
    byId('copy-link').addEventListener('click', (e) => void copyLink(e.currentTarget as HTMLButtonElement));
  }

  /**
   * Tabbing into the prompt box while it holds text the visitor has not typed (the page's example, a link's or a chip's
   * prompt) selects it, so typing replaces it: a visitor's words were added to the example's end ("a person walksa
   * person waves"). A click still puts the caret where it lands (to edit the prompt).
   */
  private selectOnTab(): void {
    let typed = false;
    let tabbed = false;
    this.prompt.addEventListener('input', (e) => {
      if ((e as InputEvent).isTrusted) typed = true;
    });
    document.addEventListener('keydown', (e) => {
      if (e.key === 'Tab') tabbed = true;
    }, true);
    document.addEventListener('pointerdown', () => {
      tabbed = false;
    }, true);
    this.prompt.addEventListener('focus', () => {
      if (tabbed && !typed) this.prompt.select();
    });
  }

  /** Put `text` in the prompt box (Text mode) and generate it, as an example chip does (in live mode: send it to the stream). */
  usePrompt(text: string): void {
    this.prompt.value = text;
    this.setMode('text');
    this.refresh(true);
    if (this.live) this.live(text);
    else if (!this.button.disabled) this.on.generate();
  }

  /**
   * Live mode on (`send` takes the prompts that Enter and the chips would generate; Generate is disabled, saying why)
   * or off (null).
   */
  /** Whether live mode plays (what the prompt box sends goes to the stream). */
  get liveOn(): boolean {
    return this.live !== null;
  }

  setLive(send: ((text: string) => void) | null): void {
    this.live = send;
    this.refresh();
  }

  /** Show a state in the controls (no events fired). */
  set(s: PageState): void {
    this.prompt.value = s.text;
    if (s.action) this.action.value = s.action;
    this.steps.value = String(Math.max(0, this.limits.supportedSteps.indexOf(nearestSteps(s.steps, this.limits.supportedSteps))));
    this.seconds.value = String(s.seconds);
    this.guidance.value = String(s.guidance);
    this.seed.value = String(s.seed >>> 0);
    this.backend = s.backend;
    this.compare.checked = s.compare && this.compareUsable(s.mode);
    this.syncSteps(s.steps);
    this.setMode(s.mode);
  }

  /** Turn the compare view on or off (as the toggle does); the slider keeps the nearest step count. */
  setCompare(on: boolean, user = false): void {
    const steps = this.read().steps;
    this.compare.checked = on && this.compareUsable(this.mode);
    this.syncSteps(steps);
    this.refresh(user);
  }

  /** Disable the compare view with the reason shown under it (null: available again). */
  setCompareAvailable(reason: string | null): void {
    this.compareBlocked = reason;
    // turning a checked toggle off is a change (the URL and the view follow it, as for a click)
    if (reason) this.setCompare(false, this.compare.checked);
    else this.refresh();
  }

  /** Why compare mode cannot be used now ('' when it can). */
  compareUnavailable(mode: Mode = this.mode): string {
    return this.compareBlocked ?? (mode === 'action' ? COMPARE_ACTION_REASON : '');
  }

  private compareUsable(mode: Mode): boolean {
    return this.compareUnavailable(mode) === '';
  }

  /** Point the slider at the choices of the current compare state, at the count nearest `steps`. */
  private syncSteps(steps: number): void {
    const choices = stepChoices(this.limits, this.compare.checked);
    this.steps.max = String(choices.length - 1);
    this.steps.value = String(Math.max(0, choices.indexOf(nearestSteps(steps, choices))));
  }

  /** The state the controls show. */
  /** The state with the step count the EMDM model runs (the slider may show DDIM's 20/50/100 in the compare view):
   * what a timeline, an edit and live mode run, which have no DDIM side. */
  readEmdm(): PageState {
    const s = this.read();
    return { ...s, steps: emdmSteps(s.steps, this.limits.supportedSteps) };
  }

  read(): PageState {
    const compare = this.compare.checked;
    return {
      mode: this.mode,
      text: this.prompt.value,
      action: this.action.value,
      steps: stepChoices(this.limits, compare)[Number(this.steps.value)] ?? this.limits.defaultSteps,
      seconds: Number(Number(this.seconds.value).toFixed(2)),
      guidance: Number(Number(this.guidance.value).toFixed(2)),
      seed: this.readSeed(),
      backend: this.backend,
      compare,
    };
  }

  setReady(ready: boolean): void {
    this.ready = ready;
    this.refresh();
  }

  /** Show `note` under the prompt while the prompt still reads `text` ('' clears it). */
  setPromptNote(text: string, note: string): void {
    this.promptNote = note ? { text, note } : null;
    this.refresh();
  }

  /** The Generate button while a request runs: `running` names a panel's request (e.g. 'the timeline'), which a
   * click replaces with one motion of these controls, not restarts. */
  setBusy(busy: boolean, running = ''): void {
    this.button.classList.toggle('busy', busy);
    this.button.textContent = !busy ? 'Generate' : running ? `Generate (stops ${running})` : 'Generating… (click to restart)';
    this.cancel.hidden = !busy;
  }

  /** Disable a mode (e.g. its model failed to load) with the reason as tooltip. */
  setModeAvailable(mode: Mode, reason: string | null): void {
    if (reason) this.unavailable.set(mode, reason);
    else this.unavailable.delete(mode);
    const tab = this.tabs.find((t) => t.dataset.mode === mode);
    if (tab) {
      tab.disabled = !!reason;
      tab.title = reason ?? '';
    }
    this.refresh();
  }

  /** The tab list's keys (WAI-ARIA tabs): the arrows, Home and End move to another mode and select it, as a click
   * does; Tab leaves the list from the selected tab (the others are out of the Tab order). Disabled tabs are skipped. */
  private tabKey(e: KeyboardEvent, tab: HTMLButtonElement): void {
    const order = this.tabs.filter((t) => !t.disabled);
    const i = order.indexOf(tab);
    const step = { ArrowRight: 1, ArrowDown: 1, ArrowLeft: -1, ArrowUp: -1 }[e.key];
    const to = step !== undefined ? order[(i + step + order.length) % order.length]
      : e.key === 'Home' ? order[0] : e.key === 'End' ? order[order.length - 1] : undefined;
    if (!to || i < 0) return;
    e.preventDefault();
    to.focus();
    to.click();
  }

  setMode(mode: Mode, user = false): void {
    this.mode = mode;
    if (this.compare.checked && !this.compareUsable(mode)) {
      const steps = this.read().steps;
      this.compare.checked = false;
      this.syncSteps(steps);
    }
    for (const tab of this.tabs) {
      tab.setAttribute('aria-selected', String(tab.dataset.mode === mode));
      tab.tabIndex = tab.dataset.mode === mode ? 0 : -1;    // one tab stop for the list: the selected mode
    }
    for (const pane of Array.from(document.querySelectorAll<HTMLElement>('[data-pane]'))) pane.hidden = pane.dataset.pane !== mode;
    byId('guidance-param').hidden = mode === 'random';
    this.refresh(user);
  }

  private readSeed(): number {
    const v = Math.trunc(Number(this.seed.value));
    return Number.isFinite(v) ? Math.min(MAX_SEED, Math.max(0, v)) : 0;
  }

  /** Update outputs, hints and the Generate button; optionally report the change. */
  private refresh(changed = false): void {
    const s = this.read();
    byId('steps-out').textContent = String(s.steps);
    const note = this.on.stepsNote?.(s) ?? '';
    this.stepsNote.textContent = note;
    this.stepsNote.hidden = note === '';
    const why = this.compareUnavailable(s.mode);
    this.compare.disabled = why !== '';
    this.compareParam.classList.toggle('unavailable', why !== '');
    this.compareHint.textContent = why || this.compareText;
    this.compareHint.classList.toggle('warn', why !== '' && this.compareBlocked !== null);
    this.compare.title = why;
    byId('seconds-out').textContent = `${s.seconds.toFixed(1)} s`;
    byId('guidance-out').textContent = s.guidance.toFixed(1);
    // screen readers announce these instead of the sliders' positions ("5", "0.593")
    this.steps.setAttribute('aria-valuetext', `${s.steps} step${s.steps === 1 ? '' : 's'}`);
    this.seconds.setAttribute('aria-valuetext', `${s.seconds.toFixed(1)} s`);
    this.guidance.setAttribute('aria-valuetext', `guidance ${s.guidance.toFixed(1)}`);
    const empty = s.text.trim() === '';
    let hint = '';
    let warn = false;
    if (s.mode === 'text' && empty) hint = 'Type a prompt (or pick an example) to generate.';
    else if (s.mode === 'text' && this.promptNote?.text === s.text) {
      hint = this.promptNote.note;
      warn = true;
    } else if (s.mode === 'text' && promptLanguageNote(s.text)) {
      hint = promptLanguageNote(s.text);
      warn = true;
    }
    this.promptHint.textContent = hint;
    this.promptHint.classList.toggle('warn', warn);
    const blocked = this.unavailable.get(s.mode);
    this.button.disabled = !this.ready || !!blocked || !!this.live || (s.mode === 'text' && empty) || (s.mode === 'action' && !s.action);
    this.button.title = blocked ?? (this.live ? 'Live mode is on: press Enter in the prompt box to send a prompt' : s.mode === 'text' && empty ? 'Type a prompt first' : '');
    if (changed) this.on.change(s);
  }
}
