// Compressed delivery of the built site (a Vite plugin, used by vite.config.ts):
// - build: after `vite build` has written the output folder (public/ copied in), every file the page
//   downloads that compresses by at least 10 % (ORT's .wasm, the .onnx models, JSON, JS, CSS, HTML)
//   gets a `<file>.br` (brotli) and `<file>.gz` (gzip) beside it, for static hosts that serve
//   precompressed files (nginx `brotli_static`/`gzip_static`, Caddy `precompressed`, …; README
//   "Hosting"). Compressing 100+ MB takes a while on a small machine, so the results are kept in
//   node_modules/.cache/emdm-precompress/ by sha256: a rebuild with unchanged files copies them.
// - preview (`vite preview`, `make demo`, Playwright's server): a request whose `<file>.br` / `.gz`
//   exists and whose Accept-Encoding allows it is answered with that file and `Content-Encoding`,
//   the original Content-Type, an ETag (304 on revalidation) and the preview headers (COOP/COEP);
//   content-hashed /assets/ files are cacheable for a year, the rest revalidate (`no-cache`).
import { createHash } from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import zlib from 'node:zlib';

const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
const CACHE_DIR = path.join(ROOT, 'node_modules', '.cache', 'emdm-precompress');

/** Files worth compressing, by extension, and the Content-Type each is served with. */
export const TYPES = {
  '.wasm': 'application/wasm',
  '.onnx': 'application/octet-stream',
  '.f32': 'application/octet-stream',
  '.json': 'application/json',
  '.js': 'text/javascript',
  '.mjs': 'text/javascript',
  '.css': 'text/css',
  '.html': 'text/html',
  '.svg': 'image/svg+xml',
};
const MIN_BYTES = 1024;
/** keep a compressed copy only if it is at most this fraction of the original */
const MAX_RATIO = 0.9;
const BROTLI_QUALITY = 5; // q11 saves another ~15 % on the .wasm but takes minutes per file here

const sha256 = (buf) => createHash('sha256').update(buf).digest('hex');

function compress(buf, kind) {
  if (kind === 'br') {
    return zlib.brotliCompressSync(buf, {
      params: { [zlib.constants.BROTLI_PARAM_QUALITY]: BROTLI_QUALITY, [zlib.constants.BROTLI_PARAM_SIZE_HINT]: buf.length },
    });
  }
  return zlib.gzipSync(buf, { level: 9 });
}

/**
 * Write `<file>.br` and `<file>.gz` beside every compressible file under `dir` (skipped where they do
 * not save 10 %). Returns {files, bytes, br, gz}: what was looked at and the sizes after compression
 * (the smaller of original and each encoding).
 */
export function precompressDir(dir, { cacheDir = CACHE_DIR, log = () => undefined } = {}) {
  fs.mkdirSync(cacheDir, { recursive: true });
  const totals = { files: 0, bytes: 0, br: 0, gz: 0 };
  const rels = fs.readdirSync(dir, { recursive: true, encoding: 'utf8' }).sort();
  for (const rel of rels) {
    const file = path.join(dir, rel);
    const ext = path.extname(rel).toLowerCase();
    if (!(ext in TYPES)) continue;
    // ORT's .wasm copies that Vite emits into assets/ are never fetched (src/runtime/ort.ts points ORT at ort/)
    if (ext === '.wasm' && rel.split(path.sep)[0] === 'assets') continue;
    const st = fs.statSync(file);
    if (!st.isFile() || st.size < MIN_BYTES) continue;
    const buf = fs.readFileSync(file);
    const hash = sha256(buf);
    totals.files++;
    totals.bytes += buf.length;
    for (const kind of ['br', 'gz']) {
      const cached = path.join(cacheDir, `${hash}.${kind}`);
      const skip = path.join(cacheDir, `${hash}.${kind}.skip`);
      let out = null;
      if (fs.existsSync(cached)) out = fs.readFileSync(cached);
      else if (!fs.existsSync(skip)) {
        const t0 = Date.now();
        out = compress(buf, kind);
        if (out.length > buf.length * MAX_RATIO) {
          fs.writeFileSync(skip, '');
          out = null;
        } else {
          const tmp = `${cached}.${process.pid}.tmp`; // builds running at once each write their own
          fs.writeFileSync(tmp, out);
          fs.renameSync(tmp, cached);
        }
        log(`precompress: ${rel} ${kind} ${(buf.length / 2 ** 20).toFixed(2)} -> ${out ? (out.length / 2 ** 20).toFixed(2) : 'skipped'} MB (${Date.now() - t0} ms)`);
      }
      totals[kind] += out ? out.length : buf.length;
      const dest = `${file}.${kind}`;
      if (out) fs.writeFileSync(dest, out);
      else fs.rmSync(dest, { force: true });
    }
  }
  return totals;
}

/** The encoding to answer with: br before gzip, as the request's Accept-Encoding allows (q=0 refuses). */
export function pickEncoding(acceptEncoding) {
  const allowed = new Map();
  for (const part of String(acceptEncoding ?? '').split(',')) {
    const [name, ...params] = part.trim().toLowerCase().split(';');
    if (!name) continue;
    const q = params.map((p) => p.trim()).find((p) => p.startsWith('q='));
    allowed.set(name, q ? Number(q.slice(2)) : 1);
  }
  for (const [enc, name] of [['br', 'br'], ['gz', 'gzip']]) {
    const q = allowed.get(name) ?? (allowed.has('*') ? allowed.get('*') : 0);
    if (q > 0) return { ext: enc, name };
  }
  return null;
}

/** Connect middleware: serve `<file>.br` / `.gz` from `distDir` when they exist and the client takes them. */
export function compressedStatic(distDir, headers = {}) {
  return (req, res, next) => {
    if (req.method !== 'GET' && req.method !== 'HEAD') return next();
    let pathname;
    try {
      pathname = decodeURIComponent(new URL(req.url ?? '/', 'http://x').pathname);
    } catch {
      return next();
    }
    const ext = path.extname(pathname).toLowerCase();
    if (!(ext in TYPES) || ext === '.html') return next(); // pages go through Vite's own HTML handling
    const file = path.join(distDir, pathname);
    if (!file.startsWith(path.resolve(distDir) + path.sep)) return next();
    const enc = pickEncoding(req.headers['accept-encoding']);
    if (!enc) return next();
    let st;
    try {
      st = fs.statSync(`${file}.${enc.ext}`);
      if (!st.isFile()) return next();
    } catch {
      return next();
    }
    const etag = `W/"${enc.ext}-${st.size}-${Math.round(st.mtimeMs)}"`;
    for (const [k, v] of Object.entries(headers)) res.setHeader(k, v);
    res.setHeader('Vary', 'Accept-Encoding');
    res.setHeader('ETag', etag);
    res.setHeader('Cache-Control', pathname.startsWith('/assets/') ? 'public, max-age=31536000, immutable' : 'no-cache');
    if (req.headers['if-none-match'] === etag) {
      res.statusCode = 304;
      return res.end();
    }
    res.setHeader('Content-Type', TYPES[ext]);
    res.setHeader('Content-Encoding', enc.name);
    res.setHeader('Content-Length', String(st.size));
    res.statusCode = 200;
    if (req.method === 'HEAD') return res.end();
    fs.createReadStream(`${file}.${enc.ext}`).pipe(res);
  };
}

/** @returns {import('vite').Plugin} the build step and the preview middleware above */
export function precompress() {
  let outDir = '';
  let headers = {};
  let logger = null;
  return {
    name: 'emdm-precompress',
    configResolved(config) {
      outDir = path.resolve(config.root, config.build.outDir);
      headers = config.preview.headers ?? {};
      logger = config.logger;
    },
    closeBundle: {
      order: 'post',
      sequential: true,
      handler() {
        if (!outDir || !fs.existsSync(outDir)) return;
        const t0 = Date.now();
        const t = precompressDir(outDir, { log: (m) => logger?.info(m) });
        const mb = (b) => (b / 2 ** 20).toFixed(1);
        logger?.info(`precompress: ${t.files} files, ${mb(t.bytes)} MB -> br ${mb(t.br)} MB, gzip ${mb(t.gz)} MB (${Date.now() - t0} ms)`);
      },
    },
    configurePreviewServer(server) {
      server.middlewares.use(compressedStatic(outDir, headers));
    },
  };
}
