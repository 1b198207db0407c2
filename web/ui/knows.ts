// What the shipped models do well (src/capabilities.ts, from the coverage benchmark): the notice under the prompt
// when a prompt is far from all of it (with the closest prompts that work, as chips), the "What this model knows"
// list one click from the prompt, and the weak labels of the Action tab. The check itself runs in the worker with
// the motion (generate's promptCheck); this module only shows it.
import { type PromptCheck } from '../../src/index';
import { type Capabilities, NAMED, actionName } from '../../src/capabilities';
import { readsAsEnglish } from '../../src/language';
import { byId, el } from './dom';

/** A prompt as the notice quotes it: spaces collapsed, and a long one cut at a word near `max` characters, with "…". */
export function quoted(prompt: string, max = 60): string {
  const t = prompt.trim().replace(/\s+/g, ' ');
  if (t.length <= max) return `“${t}”`;
  const cut = t.slice(0, max + 1);
  const space = cut.lastIndexOf(' ');
  return `“${(space > max / 2 ? cut.slice(0, space) : t.slice(0, max)).replace(/[\s,.;:!?-]+$/, '')}…”`;
}

/** The notice's words for an unknown prompt (`weak`: what a visitor calls the action it reads as, one the model does
 * not do well yet). A prompt that does not read as English is told so first: the model reads English only. */
export function farNote(prompt: string, weak?: string): string {
  const english = readsAsEnglish(prompt);
  const what = !english
    ? `${quoted(prompt)} does not read as English, and the model understands English prompts only`
    : weak
      ? `${quoted(prompt)} reads as ${weak.replace(/[_-]+/g, ' ')}, which this model does not do well yet`
      : `The model has not learned anything close to ${quoted(prompt)}`;
  return `${what}, so the motion will probably be walking, standing or a raised arm. These ${english ? '' : 'English '}prompts are the closest it does well:`;
}

const pct = (r: number) => `${Math.round(r * 100)} %`;

export class KnowsPanel {
  private readonly check = byId('prompt-check');
  private readonly checkText = byId('prompt-check-text');
  private readonly checkChips = byId('prompt-check-chips');
  private readonly open = byId('knows-open', HTMLButtonElement);
  private readonly list = byId('knows');
  private readonly prompt = byId('prompt', HTMLTextAreaElement);
  /** the prompt the notice speaks of (it hides when the prompt changes) */
  private checked = '';
  /** the text model's capabilities (the names of its actions) */
  private caps: Capabilities | null = null;

  constructor(private readonly usePrompt: (text: string) => void) {
    this.open.hidden = true;
    this.open.addEventListener('click', () => this.toggle());
    this.prompt.addEventListener('input', () => {
      if (this.prompt.value !== this.checked) this.check.hidden = true;
    });
  }

  toggle(show = this.list.hidden): void {
    this.list.hidden = !show;
    this.open.setAttribute('aria-expanded', String(show));
  }

  /** Fill the list from the text model's (and the action model's) capabilities. */
  setCapabilities(text: Capabilities | null, action: Capabilities | null): void {
    const caps = text ?? action;
    if (!caps) return;
    this.caps = text;
    const good = byId('knows-good');
    const weak = byId('knows-weak');
    good.replaceChildren();
    weak.replaceChildren();
    for (const a of caps.actions) {
      const li = el('li');
      const name = el('span', 'knows-label', `${actionName(caps, a.label)} `);
      li.append(name, el('span', 'knows-rate', pct(a.rate)));
      const still = caps.thresholds.moving !== undefined && a.moving !== undefined && a.moving < caps.thresholds.moving;
      if (still) li.append(el('span', 'knows-still', ` · holds a pose (${pct(a.moving!)} of its motions move)`));
      if (a.covered && a.prompt && caps.condition === 'text') {
        const chip = el('button', 'chip', a.prompt);
        chip.type = 'button';
        chip.addEventListener('click', () => this.usePrompt(a.prompt!));
        li.append(' ', chip);
      }
      (a.covered ? good : weak).append(li);
    }
    const judges = caps.judge?.classifiers ?? 1;
    byId('knows-source').textContent = `Share of ${caps.steps}-step motions the project's action `
      + (judges > 1 ? `classifiers recognised (${judges}, by their mean probability; ` : 'classifier recognised (')
      + `coverage benchmark, ${caps.model})`
      + `; “does well” is ${pct(caps.thresholds.covered)} or more`
      + (caps.thresholds.moving !== undefined
        ? `, with at least ${pct(caps.thresholds.moving)} of its motions moving as real clips of the action do (realism benchmark).`
        : '.');
    this.open.hidden = false;
  }

  /** After a text generation: the notice for a far prompt, nothing for a known one. */
  showCheck(prompt: string, c: PromptCheck | undefined): void {
    this.checked = prompt;
    if (!c || c.known) {
      this.check.hidden = true;
      return;
    }
    // the uncovered action it reads as, named where the prompt is near it (not gibberish landing nearest one)
    this.checkText.textContent = farNote(prompt, c.covered || c.score < NAMED ? undefined : actionName(this.caps, c.action));
    this.checkChips.replaceChildren(...c.nearest.map((p) => {
      const chip = el('button', 'chip', p);
      chip.type = 'button';
      chip.addEventListener('click', () => {
        // the notice (and this chip) goes when the new prompt is generated: the keyboard focus goes to Generate, not to
        // the page's body (no on-screen keyboard opens on a phone, as the prompt box would)
        if (document.activeElement === chip) byId('generate').focus();
        this.usePrompt(p);
      });
      return chip;
    }));
    this.check.hidden = false;
    // in view in the side panel (on a phone it scrolls on its own, and kept the chips below in place: the notice,
    // added above them, ended up above the panel's top edge)
    this.check.scrollIntoView?.({ block: 'nearest' });
  }

  hideCheck(): void {
    this.check.hidden = true;
  }
}

/** The Action tab's labels the action model does not do yet: "(weak)" after each. */
export function markWeakActions(select: HTMLSelectElement, caps: Capabilities | null): void {
  if (!caps) return;
  const weak = new Set(caps.actions.filter((a) => !a.covered).map((a) => a.label));
  for (const o of Array.from(select.options)) {
    const base = o.value.replace(/[_-]+/g, ' ');
    o.textContent = weak.has(o.value) ? `${base} (weak)` : base;
    o.classList.toggle('weak', weak.has(o.value));
  }
  const hint = byId('action-hint');
  hint.textContent = `The actions the action model was trained on; those marked (weak) it does not make recognisably yet (${weak.size} of ${select.options.length}).`;
}
