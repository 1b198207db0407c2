// Transient notices over the 3-D view, and the persistent error panel in the side bar.
import { byId, el } from './dom';

export type NoticeKind = 'info' | 'warn' | 'error';

export class Notices {
  private readonly box = byId('notices');
  /** Every notice shown so far (the test API exposes them). */
  readonly log: Array<{ kind: NoticeKind; text: string }> = [];

  show(kind: NoticeKind, text: string, ttlMs = kind === 'error' ? 0 : 9000): HTMLElement {
    this.log.push({ kind, text });
    const n = el('div', `notice ${kind}`);
    n.setAttribute('role', kind === 'error' ? 'alert' : 'status');
    n.dataset.kind = kind;
    const msg = el('span', 'msg', text);
    const close = el('button', undefined, '×');
    close.type = 'button';
    close.setAttribute('aria-label', 'Dismiss');
    close.addEventListener('click', () => n.remove());
    n.append(msg, close);
    this.box.append(n);
    while (this.box.children.length > 4) this.box.firstElementChild?.remove();
    if (ttlMs > 0) setTimeout(() => n.remove(), ttlMs);
    return n;
  }
}

export class ErrorPanel {
  private readonly panel = byId('error-panel');
  private readonly title = byId('error-title');
  private readonly reason = byId('error-reason');
  private readonly hint = byId('error-hint');

  constructor() {
    byId('error-dismiss').addEventListener('click', () => this.hide());
  }

  show(title: string, reason: string, hint = ''): void {
    this.title.textContent = title;
    this.reason.textContent = reason;
    this.hint.textContent = hint;
    this.hint.hidden = !hint;
    this.panel.hidden = false;
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
