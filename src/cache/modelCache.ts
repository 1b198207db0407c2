/**
 * Model files kept for the next visit, in Cache Storage (browser page or worker; absent in Node).
 *
 * - One entry per file, keyed by its URL and its sha256 (`<models>/<path>?sha256=<hex>`): a manifest
 *   that names a new sha256 misses, downloads the new file and replaces the old entry for that path.
 * - Every read is verified again (size + sha256 against the manifest) before it is used; a corrupt
 *   entry is dropped, downloaded again, and a notice says so.
 * - Writes that fail (storage full, private mode) are reported once and the page goes on from the network.
 *
 * `useModelCache()` plugs this in front of the network for every `fetchVerified` of its JS context;
 * the page reads its size and clears it with `modelCacheUsage()` / `clearModelCache()`.
 */
import { loadMark } from '../runtime/ort';
import { joinUrl, ModelFileError, setVerifiedFileSource, verifyBytes, type FileTable, type ModelFileErrorReason } from '../manifest';

/** A download or cache read of one model file. */
export interface FileEvent {
  path: string;
  /** 'cache': read from Cache Storage; 'network': bytes arriving; 'done': verified; 'failed' */
  state: 'network' | 'cache' | 'done' | 'failed';
  loaded: number;
  total: number;
  /** with 'failed': why (ModelFileError's reason: 'missing' when the server does not have the file) */
  reason?: ModelFileErrorReason;
}

export const MODEL_CACHE = 'emdm-models-v1';

const SHA_HEADER = 'x-emdm-sha256';

interface CacheStorageLike {
  open(name: string): Promise<Cache>;
  delete(name: string): Promise<boolean>;
  has(name: string): Promise<boolean>;
}

function storage(): CacheStorageLike | null {
  const c = (globalThis as { caches?: CacheStorageLike }).caches;
  return c ?? null;
}

/** The Cache Storage key of a file: its URL with the sha256 the manifest gives it. */
export function cacheKey(baseUrl: string, path: string, sha256: string): string {
  return `${joinUrl(baseUrl, path)}?sha256=${sha256}`;
}

/**
 * Serve verified files from Cache Storage, fetching (and storing) what is missing. `onFile` hears
 * each file's state (cache / network bytes / done / failed), `onNotice` what the user should know
 * (a corrupt entry replaced, a cache that cannot be written). A no-op where Cache Storage is absent.
 */
export function useModelCache(onFile: (e: FileEvent) => void = () => undefined, onNotice: (text: string) => void = () => undefined): boolean {
  const store = storage();
  if (!store) return false;
  let warnedWrite = false;
  setVerifiedFileSource(async (baseUrl: string, manifest: FileTable, path: string, onProgress, network) => {
    const meta = manifest.files[path];
    const total = meta.bytes;
    const key = cacheKey(baseUrl, path, meta.sha256);
    let cache: Cache | null = null;
    try {
      cache = await store.open(MODEL_CACHE);
    } catch {
      cache = null; // storage disabled for this origin: the network alone
    }
    if (cache) {
      const hit = await cache.match(key);
      if (hit) {
        const bytes = await hit.arrayBuffer();
        try {
          await verifyBytes(manifest, path, bytes);
          onFile({ path, state: 'cache', loaded: total, total });
          loadMark(`file-verified:${path}`);
          onProgress?.(total, total);
          onFile({ path, state: 'done', loaded: total, total });
          return bytes;
        } catch (e) {
          await cache.delete(key);
          onNotice(`The cached copy of ${path} was corrupt (${(e as Error).message.replace(`${path}: `, '')}); it was dropped and is downloaded again.`);
        }
      }
    }
    let bytes: ArrayBuffer;
    try {
      bytes = await network((loaded) => {
        onFile({ path, state: 'network', loaded, total });
        onProgress?.(loaded, total);
      });
    } catch (e) {
      onFile({ path, state: 'failed', loaded: 0, total, reason: e instanceof ModelFileError ? e.reason : 'network' });
      throw e;
    }
    onFile({ path, state: 'done', loaded: total, total });
    loadMark(`file-verified:${path}`);
    if (cache) {
      try {
        await cache.delete(joinUrl(baseUrl, path), { ignoreSearch: true }); // the entry of an older sha256
        await cache.put(key, new Response(bytes, { headers: { 'content-type': 'application/octet-stream', 'content-length': String(bytes.byteLength), [SHA_HEADER]: meta.sha256 } }));
      } catch (e) {
        if (!warnedWrite) onNotice(`Model files cannot be kept for the next visit (${(e as Error).message}); they will be downloaded again.`);
        warnedWrite = true;
      }
    }
    return bytes;
  });
  return true;
}

/** Files and bytes in the model cache (0 / 0 where there is none). */
export async function modelCacheUsage(): Promise<{ files: number; bytes: number }> {
  const store = storage();
  if (!store || !(await store.has(MODEL_CACHE))) return { files: 0, bytes: 0 };
  const cache = await store.open(MODEL_CACHE);
  let bytes = 0;
  const keys = await cache.keys();
  for (const k of keys) {
    const r = await cache.match(k);
    bytes += Number(r?.headers.get('content-length') ?? 0);
  }
  return { files: keys.length, bytes };
}

/** Drop every cached model file (the next load downloads them again). */
export async function clearModelCache(): Promise<void> {
  await storage()?.delete(MODEL_CACHE);
}
