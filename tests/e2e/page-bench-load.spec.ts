// Load benchmark for the demo page in headless Chromium (WASM backend): a cold visit (fresh profile,
// empty HTTP cache and Cache Storage) and a second visit in the same profile, each to "ready"
// (window.emdm.ready). Prints, per visit, every file the page fetched (bytes on the wire, the
// Content-Encoding the server chose, when it was requested and when it arrived, ms after navigation)
// and the ready time, plus the machine's load average. A benchmark, not a test: it runs only with
// EMDM_BENCH=1 and asserts nothing about speed (it writes bench-load.json to the test output folder).
//
//   EMDM_BENCH=1 npx playwright test tests/e2e/page-bench-load.spec.ts
//
// EMDM_BENCH_LOAD_REPS (default 3) is the number of fresh profiles (cold + second visit each).
import fs from 'node:fs';
import os from 'node:os';
import { expect, test, type BrowserContext, type Page, type Request } from '@playwright/test';

interface FileRow {
  path: string;
  status: number;
  /** body bytes as sent (after Content-Encoding) + headers */
  wireBytes: number;
  encoding: string;
  startMs: number;
  endMs: number;
}

interface Visit {
  readyMs: number;
  manifestMs: number;
  wireBytes: number;
  files: FileRow[];
  /** the page's own per-file record: cache or network, and when each was verified */
  modelFiles: Array<{ path: string; cached: boolean; at: number }>;
  /** the generation worker's `emdm:*` performance marks (src/runtime/ort.ts loadMark), ms after navigation */
  marks: Array<[string, number]>;
}

/** The generation worker's emdm:* marks on the page's clock (ms since the page's time origin). */
async function workerMarks(page: Page): Promise<Array<[string, number]>> {
  const worker = page.workers().find((w) => w.url().includes('generation.worker'));
  if (!worker) return [];
  const pageOrigin = await page.evaluate(() => performance.timeOrigin);
  const w = await worker.evaluate(() => ({
    origin: performance.timeOrigin,
    marks: performance.getEntriesByType('mark').filter((m) => m.name.startsWith('emdm:')).map((m) => [m.name.slice(5), m.startTime] as [string, number]),
  }));
  return w.marks.map(([n, t]) => [n, t + w.origin - pageOrigin] as [string, number]).sort((a, b) => a[1] - b[1]);
}

async function visit(context: BrowserContext): Promise<Visit> {
  const page = await context.newPage();
  const pending: Array<Promise<FileRow | null>> = [];
  let navStart = 0;
  const row = async (r: Request): Promise<FileRow | null> => {
    const res = await r.response();
    if (!res) return null;
    const u = new URL(r.url());
    if (u.protocol !== 'http:' && u.protocol !== 'https:') return null;
    const sizes = await r.sizes();
    const t = r.timing();
    const headers = await res.allHeaders();
    return {
      path: u.pathname, status: res.status(), wireBytes: sizes.responseBodySize + sizes.responseHeadersSize,
      encoding: headers['content-encoding'] ?? '', startMs: t.startTime, endMs: t.startTime + t.responseEnd, // made relative below
    };
  };
  page.on('requestfinished', (r) => pending.push(row(r)));
  const nav = await page.goto('/?noauto=1&backend=wasm');
  navStart = nav!.request().timing().startTime;
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 300_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
  const startup = await page.evaluate(() => window.emdm.startup);
  const modelFiles = await page.evaluate(() => window.emdm.files().map((f) => ({ path: f.path, cached: f.cached, at: f.at })));
  const marks = await workerMarks(page);
  await page.waitForTimeout(300); // let the last requestfinished events arrive
  const files = (await Promise.all(pending)).filter((x): x is FileRow => x !== null)
    .map((f) => ({ ...f, startMs: f.startMs - navStart, endMs: f.endMs - navStart })).sort((a, b) => a.startMs - b.startMs);
  await page.close();
  return { readyMs: startup.readyMs, manifestMs: startup.manifestMs, wireBytes: files.reduce((s, f) => s + f.wireBytes, 0), files, modelFiles, marks };
}

const MB = (b: number) => (b / 2 ** 20).toFixed(2);
const median = (xs: number[]) => [...xs].sort((a, b) => a - b)[Math.floor(xs.length / 2)];

function table(label: string, v: Visit): string {
  const lines = [`${label}: ready ${v.readyMs.toFixed(0)} ms, ${MB(v.wireBytes)} MB on the wire in ${v.files.length} requests`];
  lines.push('  file                                                  status  MB on wire  enc   start ms  end ms');
  for (const f of v.files) {
    if (f.wireBytes < 50_000 && f.status === 200 && !f.path.includes('/models/') && !f.path.includes('/ort')) continue; // small page assets summed below
    lines.push(`  ${f.path.slice(0, 52).padEnd(52)}  ${String(f.status).padStart(6)}  ${MB(f.wireBytes).padStart(10)}  ${(f.encoding || '-').padEnd(4)}  ${f.startMs.toFixed(0).padStart(8)}  ${f.endMs.toFixed(0).padStart(6)}`);
  }
  const small = v.files.filter((f) => f.wireBytes < 50_000 && f.status === 200 && !f.path.includes('/models/') && !f.path.includes('/ort'));
  if (small.length) lines.push(`  (+ ${small.length} small page files, ${MB(small.reduce((s, f) => s + f.wireBytes, 0))} MB: ${small.map((f) => `${f.path.split('/').pop()} ${f.startMs.toFixed(0)}`).join(', ')})`);
  if (v.marks.length) lines.push(`  worker: ${v.marks.map(([n, t]) => `${n.replace(/^(session-\w+):([^#]*).*$/, '$1:$2')} ${t.toFixed(0)}`).join(' · ')}`);
  const cached = v.modelFiles.filter((f) => f.cached).length;
  if (v.modelFiles.length) {
    lines.push(`  model files: ${v.modelFiles.length} (${cached} from Cache Storage), all verified at ${Math.max(...v.modelFiles.map((f) => f.at)).toFixed(0)} ms`);
  }
  return lines.join('\n');
}

test('benchmark: load — cold and second visit, bytes per file and ready time', async ({ browser }) => {
  test.skip(process.env.EMDM_BENCH !== '1', 'benchmark: set EMDM_BENCH=1 to run it');
  test.setTimeout(1_800_000);
  const reps = Number(process.env.EMDM_BENCH_LOAD_REPS ?? 3);
  const runs: Array<{ cold: Visit; second: Visit; load: number }> = [];
  for (let i = 0; i < reps; i++) {
    const load = os.loadavg()[0];
    const context = await browser.newContext(); // a fresh profile: empty HTTP cache and Cache Storage
    try {
      const cold = await visit(context);
      const second = await visit(context);
      runs.push({ cold, second, load });
      console.log(`--- run ${i + 1}/${reps}, load average ${load.toFixed(2)} (${os.cpus().length} cores)\n${table('cold visit', cold)}\n${table('second visit', second)}`);
    } finally {
      await context.close();
    }
  }
  const summary = {
    cpuCores: os.cpus().length,
    loadAverage: runs.map((r) => Number(r.load.toFixed(2))),
    cold: { readyMs: runs.map((r) => Math.round(r.cold.readyMs)), medianReadyMs: Math.round(median(runs.map((r) => r.cold.readyMs))), wireMB: Number(MB(runs[0].cold.wireBytes)) },
    second: { readyMs: runs.map((r) => Math.round(r.second.readyMs)), medianReadyMs: Math.round(median(runs.map((r) => r.second.readyMs))), wireMB: Number(MB(runs[0].second.wireBytes)),
      modelRequests: runs[0].second.files.filter((f) => f.path.includes('/models/') && !f.path.endsWith('/manifest.json')).length },
  };
  console.log(`load benchmark summary: ${JSON.stringify(summary)}`);
  fs.writeFileSync(test.info().outputPath('bench-load.json'), JSON.stringify({ summary, runs }, null, 1));
});
