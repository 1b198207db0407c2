// src/cache/modelCache.ts in Node, with an in-memory Cache Storage (Node has none) and a fake server: a hit is verified before use, a corrupt entry is dropped and fetched again with a
// notice, a new sha256 replaces the path's old entry, usage and clear see what is stored.
// (The same in Chromium with the real Cache Storage: tests/e2e/page-cache.spec.ts.)
import { afterAll, afterEach, beforeAll, describe, expect, test } from 'vitest';
import { clearModelCache, modelCacheUsage, useModelCache, type FileEvent } from '../../src/cache/modelCache';
import { fetchVerified, setVerifiedFileSource, sha256Hex, type Manifest } from '../../src/manifest';

/** The part of Cache Storage the module uses, in memory (keys are URLs; `ignoreSearch` as in browsers). */
class MemoryCache {
  readonly entries = new Map<string, { body: Uint8Array; headers: Headers }>();
  async match(key: string | Request) {
    const e = this.entries.get(typeof key === 'string' ? key : key.url);
    return e ? new Response(e.body.slice(), { headers: e.headers }) : undefined;
  }
  async put(key: string, res: Response) {
    this.entries.set(key, { body: new Uint8Array(await res.arrayBuffer()), headers: res.headers });
  }
  async delete(key: string | Request, opts: { ignoreSearch?: boolean } = {}) {
    const url = typeof key === 'string' ? key : key.url;
    let hit = false;
    for (const k of [...this.entries.keys()]) {
      if (k === url || (opts.ignoreSearch && k.split('?')[0] === url.split('?')[0])) hit = this.entries.delete(k) || hit;
    }
    return hit;
  }
  async keys() {
    return [...this.entries.keys()].map((k) => new Request(k));
  }
}
const stores = new Map<string, MemoryCache>();
const fakeCaches = {
  async open(name: string) {
    if (!stores.has(name)) stores.set(name, new MemoryCache());
    return stores.get(name)!;
  },
  async delete(name: string) {
    return stores.delete(name);
  },
  async has(name: string) {
    return stores.has(name);
  },
};

const BASE = 'http://models.test/models/';
const served = new Map<string, Uint8Array>();
const fetched: string[] = [];
let manifest: Manifest;
const realFetch = globalThis.fetch;

async function entryOf(bytes: Uint8Array) {
  return { bytes: bytes.byteLength, sha256: await sha256Hex(bytes) };
}

beforeAll(async () => {
  served.set('a.bin', Uint8Array.from({ length: 4096 }, (_, i) => i % 251));
  served.set('b.bin', Uint8Array.from({ length: 100 }, (_, i) => 255 - i));
  manifest = { schema: 1, skeleton: {} as Manifest['skeleton'], textEncoders: {}, models: {}, files: {} } as Manifest;
  for (const [p, b] of served) manifest.files[p] = await entryOf(b);
  (globalThis as { caches?: unknown }).caches = fakeCaches;
  globalThis.fetch = (async (input: string | URL | Request) => {
    const url = String(input instanceof Request ? input.url : input);
    const rel = url.slice(BASE.length);
    fetched.push(rel);
    const body = served.get(rel);
    return body ? new Response(body.slice(), { status: 200, headers: { 'content-length': String(body.byteLength) } }) : new Response('no', { status: 404 });
  }) as typeof fetch;
});
afterEach(async () => {
  await clearModelCache();
  fetched.length = 0;
});
afterAll(() => {
  setVerifiedFileSource(null);
  delete (globalThis as { caches?: unknown }).caches;
  globalThis.fetch = realFetch;
});

describe('model cache', () => {
  test('the second read comes from the cache, verified, and usage counts it; clear empties it', async () => {
    const events: FileEvent[] = [];
    expect(useModelCache((e) => events.push(e))).toBe(true);
    const first = await fetchVerified(BASE, manifest, 'a.bin');
    expect(fetched).toEqual(['a.bin']);
    expect(events.map((e) => e.state)).toContain('network');
    events.length = 0;
    const again = await fetchVerified(BASE, manifest, 'a.bin');
    expect(fetched).toEqual(['a.bin']); // no second download
    expect(new Uint8Array(again)).toEqual(new Uint8Array(first));
    expect(events.map((e) => e.state)).toEqual(['cache', 'done']);
    expect(await modelCacheUsage()).toEqual({ files: 1, bytes: 4096 });
    await clearModelCache();
    expect(await modelCacheUsage()).toEqual({ files: 0, bytes: 0 });
  });

  test('a file the server does not have is a failed file with reason missing, and nothing is stored', async () => {
    const events: FileEvent[] = [];
    useModelCache((e) => events.push(e));
    const gone = { ...manifest, files: { ...manifest.files, 'gone.bin': { bytes: 10, sha256: '0'.repeat(64) } } };
    await expect(fetchVerified(BASE, gone, 'gone.bin')).rejects.toMatchObject({ name: 'ModelFileError', path: 'gone.bin', reason: 'missing' });
    expect(events).toEqual([{ path: 'gone.bin', state: 'failed', loaded: 0, total: 10, reason: 'missing' }]);
    expect(await modelCacheUsage()).toEqual({ files: 0, bytes: 0 });
  });

  test('a corrupt entry is dropped, fetched again and stored good, with a notice', async () => {
    const notices: string[] = [];
    useModelCache(undefined, (t) => notices.push(t));
    await fetchVerified(BASE, manifest, 'b.bin');
    const cache = await fakeCaches.open('emdm-models-v1');
    const [key] = cache.entries.keys();
    cache.entries.get(key)!.body[10] ^= 0xff;
    const bytes = await fetchVerified(BASE, manifest, 'b.bin');
    expect(await sha256Hex(bytes)).toBe(manifest.files['b.bin'].sha256);
    expect(fetched).toEqual(['b.bin', 'b.bin']);
    expect(notices).toEqual([expect.stringContaining('The cached copy of b.bin was corrupt')]);
    expect(await sha256Hex(cache.entries.get(key)!.body)).toBe(manifest.files['b.bin'].sha256);
  });

  test('a manifest naming a new sha256 downloads the new file and replaces the old entry', async () => {
    useModelCache();
    await fetchVerified(BASE, manifest, 'a.bin');
    const oldSha = manifest.files['a.bin'].sha256;
    const changed = served.get('a.bin')!.slice();
    changed[0] ^= 1;
    served.set('a.bin', changed);
    const next = { ...manifest, files: { ...manifest.files, 'a.bin': await entryOf(changed) } };
    try {
      await fetchVerified(BASE, next, 'a.bin');
      const keys = [...(await fakeCaches.open('emdm-models-v1')).entries.keys()];
      expect(keys).toEqual([`${BASE}a.bin?sha256=${next.files['a.bin'].sha256}`]);
      expect(keys[0]).not.toContain(oldSha);
      expect(fetched).toEqual(['a.bin', 'a.bin']);
    } finally {
      changed[0] ^= 1;
    }
  });
});
