// The timeline's segment list (web/ui/timeline.ts): one row per segment (prompt or action, seconds, its
// seed) with move, regenerate and remove buttons, the running total against MAX_TIMELINE_SECONDS, and the
// rows as TimelineSegments. It generates nothing: Enter and ↻ call the panel back.
import { MAX_TIMELINE_SECONDS, type TimelineSegment } from '../../src/index';
import { el } from './dom';
import { randomSeed } from './state';

interface Row {
  li: HTMLLIElement;
  kind: HTMLSelectElement;
  prompt: HTMLInputElement;
  seconds: HTMLInputElement;
  seed: number;
}

/** What the rows ask of their panel. */
export interface RowEvents {
  /** Enter in a prompt or a seconds field: generate the timeline */
  generate(): void;
  /** ↻ on row i */
  regenerate(i: number): void;
  /** a refused change (e.g. removing the last row), said in the panel */
  refuse(text: string): void;
}

/** A button whose `data-k` is its text (the rows find their buttons by it). */
export function button(text: string, cls: string, on: () => void): HTMLButtonElement {
  const b = el('button', cls, text);
  b.type = 'button';
  b.dataset.k = text;
  b.addEventListener('click', on);
  return b;
}

export class TimelineRows {
  readonly list = el('ol', 'tl-list');
  readonly total = el('span', 'tl-total');
  private readonly rows: Row[] = [];

  constructor(private readonly actions: readonly string[], private readonly on: RowEvents) {}

  get length(): number {
    return this.rows.length;
  }

  add(s: TimelineSegment, focus = false): void {
    const row = this.row(s);
    const { li, kind, prompt, seconds } = row;
    const sync = () => {
      prompt.disabled = kind.value !== '';
      this.refreshTotal();
    };
    kind.addEventListener('change', sync);
    seconds.addEventListener('input', () => this.refreshTotal());
    for (const field of [prompt, seconds]) { // Enter in a segment's prompt or its seconds: generate the timeline
      field.addEventListener('keydown', (e) => {
        if (e.key === 'Enter') this.on.generate();
      });
    }
    this.rows.push(row);
    this.list.append(li);
    sync();
    this.relabel();
    if (focus) prompt.focus();
  }

  /** One row's elements, in the reading order. */
  private row(s: TimelineSegment): Row {
    const li = el('li', 'tl-seg');
    const kind = el('select', 'tl-kind');
    const p = el('option', undefined, 'Prompt');
    p.value = '';
    kind.append(p);
    for (const a of this.actions) {
      const o = el('option', undefined, a.replace(/[_-]+/g, ' '));
      o.value = a;
      kind.append(o);
    }
    kind.value = s.action !== undefined ? String(s.action) : '';
    const prompt = el('input', 'tl-prompt');
    prompt.type = 'text';
    prompt.value = s.prompt ?? '';
    prompt.placeholder = 'what the character does';
    const seconds = el('input', 'tl-seconds');
    seconds.type = 'number';
    seconds.min = '0';
    seconds.max = String(MAX_TIMELINE_SECONDS);
    seconds.step = '0.1';
    seconds.value = String(s.seconds);
    const row: Row = { li, kind, prompt, seconds, seed: s.seed >>> 0 };
    const up = button('↑', 'icon', () => this.move(row, -1));
    const down = button('↓', 'icon', () => this.move(row, 1));
    const again = button('↻', 'icon', () => this.on.regenerate(this.rows.indexOf(row)));
    const remove = button('✕', 'icon', () => this.remove(row));
    const unit = el('span', 'tl-unit', 's');
    // the prompt first (its own line), then prompt-or-action, seconds and the buttons: the Tab order is the reading order;
    // the buttons wrap to a line of their own where the selector's longest label and the seconds leave them no room
    const buttons = el('span', 'tl-seg-buttons');
    buttons.append(up, down, again, remove);
    const controls = el('div', 'tl-seg-controls');
    controls.append(kind, seconds, unit, buttons);
    li.append(el('span', 'tl-num'), prompt, controls);
    return row;
  }

  private move(row: Row, d: number): void {
    const i = this.rows.indexOf(row);
    const j = i + d;
    if (j < 0 || j >= this.rows.length) return;
    this.rows.splice(i, 1);
    this.rows.splice(j, 0, row);
    this.list.replaceChildren(...this.rows.map((r) => r.li));
    this.relabel();
    (d < 0 ? row.li.querySelector<HTMLButtonElement>('button[data-k="↑"]') : row.li.querySelector<HTMLButtonElement>('button[data-k="↓"]'))?.focus();
  }

  private remove(row: Row): void {
    if (this.rows.length === 1) {
      this.on.refuse('A timeline needs at least one segment.');
      return;
    }
    const i = this.rows.indexOf(row);
    this.rows.splice(i, 1);
    row.li.remove();
    this.relabel();
    this.refreshTotal();
    this.rows[Math.min(i, this.rows.length - 1)].prompt.focus();
  }

  /** Numbers and accessible names follow the order. */
  private relabel(): void {
    this.rows.forEach((r, i) => {
      const n = i + 1;
      r.li.querySelector('.tl-num')!.textContent = `${n}`;
      r.kind.setAttribute('aria-label', `Segment ${n}: prompt or action`);
      r.prompt.setAttribute('aria-label', `Segment ${n} prompt`);
      r.seconds.setAttribute('aria-label', `Segment ${n} seconds`);
      for (const b of r.li.querySelectorAll<HTMLButtonElement>('button')) {
        const k = b.dataset.k;
        const what = k === '↑' ? 'Move up' : k === '↓' ? 'Move down' : k === '↻' ? 'Regenerate (new take; keeps the segments before it)' : 'Remove';
        b.setAttribute('aria-label', `Segment ${n}: ${what}`);
        b.title = what;
      }
      r.li.classList.remove('invalid');
      r.li.removeAttribute('aria-invalid');
    });
  }

  refreshTotal(): void {
    const s = this.segments().reduce((a, x) => a + (Number.isFinite(x.seconds) ? x.seconds : 0), 0);
    this.total.textContent = `${Number(s.toFixed(2))} s of ${MAX_TIMELINE_SECONDS} s`;
    this.total.classList.toggle('over', s > MAX_TIMELINE_SECONDS);
  }

  /** The list as segments (what planTimeline checks). */
  segments(): TimelineSegment[] {
    return this.rows.map((r) => {
      const seconds = r.seconds.value.trim() === '' ? NaN : Number(r.seconds.value);
      return r.kind.value ? { action: r.kind.value, seconds, seed: r.seed } : { prompt: r.prompt.value, seconds, seed: r.seed };
    });
  }

  setSegments(segs: TimelineSegment[]): void {
    this.rows.length = 0;
    this.list.replaceChildren();
    for (const s of segs) this.add(s);
    this.refreshTotal();
  }

  /** A new take of row i: a new seed. */
  reseed(i: number): void {
    this.rows[i].seed = randomSeed();
  }

  /** Mark row `segment` invalid (null: none). */
  mark(segment: number | null): void {
    this.rows.forEach((r, i) => {
      r.li.classList.toggle('invalid', i === segment);
      if (i === segment) r.li.setAttribute('aria-invalid', 'true');
      else r.li.removeAttribute('aria-invalid');
    });
  }
}
