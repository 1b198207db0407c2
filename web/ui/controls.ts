// The side-bar form: mode tabs, prompt + examples, action list, sliders, seed + dice, Generate.
// It owns the DOM of the controls and turns it into a PageState; it never runs a model itself.
import { byId, el } from './dom';
import {
  MAX_GUIDANCE, MAX_PROMPT_CHARS, MAX_SECONDS, MAX_SEED, MIN_GUIDANCE, MIN_SECONDS, nearestSteps, randomSeed,
  truncatePrompt, type Mode, type PageState, type StateLimits,
} from './state';

export interface ControlsEvents {
  generate(): void;
  change(state: PageState): void;
}

export class Controls {
  private readonly prompt = byId('prompt', HTMLTextAreaElement);
  private readonly promptHint = byId('prompt-hint');
  private readonly promptCount = byId('prompt-count');
  private readonly action = byId('action', HTMLSelectElement);
  private readonly steps = byId('steps', HTMLInputElement);
  private readonly seconds = byId('seconds', HTMLInputElement);
  private readonly guidance = byId('guidance', HTMLInputElement);
  private readonly seed = byId('seed', HTMLInputElement);
  private readonly button = byId('generate', HTMLButtonElement);
  private readonly tabs = Array.from(document.querySelectorAll<HTMLButtonElement>('.modes [data-mode]'));
  private mode: Mode = 'text';
  private ready = false;
  private backend: PageState['backend'] = 'auto';
  private readonly unavailable = new Map<Mode, string>();

  constructor(private readonly limits: StateLimits, examples: string[], private readonly on: ControlsEvents) {
    this.steps.min = '0';
    this.steps.max = String(limits.supportedSteps.length - 1);
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
      chip.addEventListener('click', () => {
        this.prompt.value = ex;
        this.setMode('text');
        this.refresh();
        if (!this.button.disabled) this.on.generate();
      });
      box.append(chip);
    }
    byId('examples').hidden = examples.length === 0;

    for (const tab of this.tabs) tab.addEventListener('click', () => this.setMode(tab.dataset.mode as Mode, true));
    this.prompt.addEventListener('input', () => this.refresh(true));
    this.prompt.addEventListener('keydown', (e) => {
      if (e.key === 'Enter' && !e.shiftKey && !e.isComposing) {
        e.preventDefault();
        if (!this.button.disabled) this.on.generate();
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
    this.setMode(s.mode);
  }

  /** The state the controls show (prompt NOT truncated: see truncatePrompt). */
  read(): PageState {
    return {
      mode: this.mode,
      text: this.prompt.value,
      action: this.action.value,
      steps: this.limits.supportedSteps[Number(this.steps.value)] ?? this.limits.defaultSteps,
      seconds: Number(Number(this.seconds.value).toFixed(2)),
      guidance: Number(Number(this.guidance.value).toFixed(2)),
      seed: this.readSeed(),
      backend: this.backend,
    };
  }

  setReady(ready: boolean): void {
    this.ready = ready;
    this.refresh();
  }

  setBusy(busy: boolean): void {
    this.button.classList.toggle('busy', busy);
    this.button.textContent = busy ? 'Generating… (click to restart)' : 'Generate';
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

  setMode(mode: Mode, user = false): void {
    this.mode = mode;
    for (const tab of this.tabs) tab.setAttribute('aria-selected', String(tab.dataset.mode === mode));
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
    byId('seconds-out').textContent = `${s.seconds.toFixed(1)} s`;
    byId('guidance-out').textContent = s.guidance.toFixed(1);
    const chars = Array.from(s.text).length;
    this.promptCount.textContent = chars ? `${chars} / ${MAX_PROMPT_CHARS}` : '';
    const empty = s.text.trim() === '';
    let hint = '';
    let warn = false;
    if (s.mode === 'text' && empty) hint = 'Type a prompt (or pick an example) to generate.';
    else if (s.mode === 'text' && truncatePrompt(s.text).truncated) {
      hint = `Too long: only the first ${MAX_PROMPT_CHARS} characters will be used.`;
      warn = true;
    }
    this.promptHint.textContent = hint;
    this.promptHint.classList.toggle('warn', warn);
    const blocked = this.unavailable.get(s.mode);
    this.button.disabled = !this.ready || !!blocked || (s.mode === 'text' && empty) || (s.mode === 'action' && !s.action);
    this.button.title = blocked ?? (s.mode === 'text' && empty ? 'Type a prompt first' : '');
    if (changed) this.on.change(s);
  }
}
