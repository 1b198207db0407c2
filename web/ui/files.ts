// Model files in the side bar: each file's state while the models load (from the cache, bytes from the
// network, verified, failed), and the "clear cached models (N MB)" control.
import type { FileEvent } from '../../src/worker/client';
import { byId, el, formatBytes } from './dom';

const LABEL: Record<FileEvent['state'], string> = { cache: 'from cache', network: 'downloading', done: 'verified', failed: 'failed' };

export class FileList {
  private readonly box = byId('file-list');
  private readonly rows = new Map<string, HTMLElement>();
  /** the last state of every file seen (the test API exposes it) */
  readonly states = new Map<string, FileEvent & { cached: boolean; at: number }>();

  update(e: FileEvent): void {
    const prev = this.states.get(e.path);
    const cached = e.state === 'cache' || (e.state === 'done' && !!prev?.cached);
    this.states.set(e.path, { ...e, cached, at: performance.now() });
    let row = this.rows.get(e.path);
    if (!row) {
      row = el('li', 'file');
      row.append(el('span', 'name', e.path.split('/').pop() ?? e.path), el('span', 'state'));
      row.title = e.path;
      this.rows.set(e.path, row);
      this.box.append(row);
    }
    row.dataset.state = cached ? 'cache' : e.state;
    const bytes = e.state === 'network' ? `${formatBytes(e.loaded)} / ${formatBytes(e.total)}` : formatBytes(e.total);
    const label = e.state === 'failed' && e.reason === 'missing' ? 'missing on the server' : e.state === 'failed' && e.reason === 'sha256' ? 'failed: checksum' : LABEL[e.state];
    row.dataset.reason = e.state === 'failed' ? (e.reason ?? '') : '';
    row.lastElementChild!.textContent = `${bytes} · ${cached && e.state === 'done' ? 'from cache, verified' : label}`;
    this.box.hidden = false;
  }

  /** Fold the list away once nothing is loading (failed files stay visible). */
  settle(): void {
    const busy = [...this.states.values()].some((s) => s.state === 'network' || s.state === 'failed');
    this.box.hidden = !busy;
  }
}

export class CacheControl {
  private readonly button = byId('clear-cache', HTMLButtonElement);

  constructor(private readonly usage: () => Promise<{ files: number; bytes: number }>, clear: () => Promise<void>, onError: (e: unknown) => void) {
    this.button.addEventListener('click', async () => {
      this.button.disabled = true;
      try {
        await clear();
      } catch (e) {
        onError(e);
      }
      await this.refresh();
    });
  }

  async refresh(): Promise<void> {
    try {
      const u = await this.usage();
      this.button.textContent = u.files ? `Clear cached models (${formatBytes(u.bytes)})` : 'No models cached';
      this.button.disabled = u.files === 0;
      this.button.hidden = false;
    } catch {
      this.button.hidden = true; // no Cache Storage here (e.g. an insecure context)
    }
  }
}
