// Test/benchmark page for src/text in the browser (tests/e2e/text.spec.ts, scripts/build/bench-text.mjs).
import { loadManifest } from '../../../../src/manifest';
import { createTextEncoder, type TextEncoder } from '../../../../src/text';

let enc: TextEncoder | null = null;
const status = document.getElementById('status')!;

const api = {
  crossOriginIsolated: globalThis.crossOriginIsolated === true,
  /** Load an encoder; resolves with load timings (ms) or rejects with the error message. */
  async load(id?: string, baseUrl = '/models/'): Promise<{ id: string; dim: number; manifestMs: number; loadMs: number; bytes: number }> {
    const t0 = performance.now();
    const manifest = await loadManifest(baseUrl);
    const t1 = performance.now();
    let bytes = 0;
    enc = await createTextEncoder(manifest, baseUrl, id, { onDownload: (l) => (bytes = l) });
    const t2 = performance.now();
    status.textContent = `loaded ${enc.id} (${enc.dim}-d)`;
    return { id: enc.id, dim: enc.dim, manifestMs: t1 - t0, loadMs: t2 - t0, bytes };
  },
  async encode(text: string): Promise<{ vector: number[]; ms: number }> {
    if (!enc) throw new Error('textPage.encode: call load() first');
    const t0 = performance.now();
    const v = await enc.encode(text);
    return { vector: Array.from(v), ms: performance.now() - t0 };
  },
};

(globalThis as unknown as { textPage: typeof api }).textPage = api;
status.textContent = 'ready';
