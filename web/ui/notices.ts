// Notices beside the 3-D view (never over it), and the persistent error panel in the side bar.
// The newest FRESH notices show in full, newest first; older ones, and any whose time ran out, fold
// behind a "N more" button that opens them all: nothing is dropped unseen, and each can be dismissed.
import { byId, el } from './dom';

export type NoticeKind = 'info' | 'warn' | 'error';

/** How many notices show unfolded at once. */
export const FRESH = 3;

export class Notices {
  private readonly box = byId('notices');
  private readonly stack = el('div', 'notices-stack');
  private readonly row = el('div', 'notices-more-row');
  private readonly more = el('button', 'notices-more');
  private readonly clear = el('button', 'notices-clear', 'Dismiss all');
  private open = false;
  /** Every notice shown so far (the test API exposes them). */
  readonly log: Array<{ kind: NoticeKind; text: string }> = [];

  constructor() {
    this.more.type = 'button';
    this.clear.type = 'button';
    this.more.setAttribute('aria-expanded', 'false');
    this.more.addEventListener('click', () => {
      this.open = !this.open;
      this.render();
    });
    this.clear.addEventListener('click', () => {
      this.stack.replaceChildren();
      this.render();
    });
    this.row.append(this.more, this.clear);
    this.box.replaceChildren(this.stack, this.row);
    this.render();
  }

  /** Show a notice; after ttlMs (0 = never) it folds behind "N more" instead of vanishing. */
  show(kind: NoticeKind, text: string, ttlMs = kind === 'error' ? 0 : 9000): HTMLElement {
    this.log.push({ kind, text });
    const n = el('div', `notice ${kind}`);
    n.setAttribute('role', kind === 'error' ? 'alert' : 'status');
    n.dataset.kind = kind;
    const msg = el('span', 'msg', text);
    const close = el('button', undefined, '×');
    close.type = 'button';
    close.setAttribute('aria-label', 'Dismiss');
    close.addEventListener('click', () => {
      n.remove();
      this.render();
    });
    n.append(msg, close);
    this.stack.prepend(n);
    if (ttlMs > 0) {
      setTimeout(() => {
        n.classList.add('expired');
        this.render();
      }, ttlMs);
    }
    this.render();
    return n;
  }

  /** Fold all but the FRESH newest unexpired notices; label the button with how many are folded. */
  private render(): void {
    let shown = 0;
    let folded = 0;
    for (const n of this.stack.children) {
      const fold = n.classList.contains('expired') || shown >= FRESH;
      n.classList.toggle('folded', fold);
      if (fold) folded++;
      else shown++;
    }
    if (folded === 0) this.open = false;
    this.box.classList.toggle('open', this.open);
    this.box.hidden = this.stack.children.length === 0;
    this.row.hidden = folded === 0;
    this.more.textContent = this.open ? `Fold away ${folded}` : `${folded} more notice${folded === 1 ? '' : 's'}`;
    this.more.setAttribute('aria-expanded', String(this.open));
  }
}

export class ErrorPanel {
  private readonly panel = byId('error-panel');
  private readonly title = byId('error-title');
  private readonly reason = byId('error-reason');
  private readonly hint = byId('error-hint');

  constructor() {
    byId('error-dismiss').addEventListener('click', () => {
      const hadFocus = this.panel.contains(document.activeElement);
      this.hide();
      // a keyboard user who dismissed it goes on where the work is, not at the top of the page
      if (hadFocus) (document.getElementById('generate') as HTMLButtonElement | null)?.focus();
    });
  }

  show(title: string, reason: string, hint = ''): void {
    this.title.textContent = title;
    this.reason.textContent = reason;
    this.hint.textContent = hint;
    this.hint.hidden = !hint;
    this.panel.hidden = false;
    // the panel sits at the top of the controls, which may be scrolled far down (on a phone: under the stage)
    this.panel.scrollIntoView({ block: 'nearest' });
  }

  hide(): void {
    this.panel.hidden = true;
  }

  get visible(): boolean {
    return !this.panel.hidden;
  }

  get text(): string {
    return this.panel.hidden ? '' : `${this.title.textContent}: ${this.reason.textContent} ${this.hint.textContent}`.trim();
  }
}
