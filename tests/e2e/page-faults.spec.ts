// Bad input and faults on the demo page: each behaves as the issue states, and the page stays usable.
import { createHash } from 'node:crypto';
import { expect, test, type Page, type Route } from '@playwright/test';
import { watchPage } from './helpers';

const PROMPT = 'a person walks forward';

/**
 * A valid step model (inputs x_t, z, cond, t, mask; output x0) that returns NaN everywhere:
 * x0 = x_t * NaN. Built with onnx.helper (opset 18, 218 bytes):
 *   Mul(['x_t', 'nan'], ['x0']) with a scalar float initializer 'nan'.
 */
const NAN_STEP_MODEL = Buffer.from(
  'CAgSCGVtZG0tZTJlOsUBChMKA3hfdAoDbmFuEgJ4MCIDTXVsEghuYW5fc3RlcCoNEAEiBAAAwH9CA25hblocCgN4X3QSFQoTCAESDwoDEgFCCgMSAUwKAwiHAloUCgF6Eg8KDQgBEgkKAxIBQgoCCEBaGAoEY29uZBIQCg4IARIKCgMSAUIKAxIBQ1oQCgF0EgsKCQgBEgUKAxIBQloYCgRtYXNrEhAKDggBEgoKAxIBQgoDEgFMYhsKAngwEhUKEwgBEg8KAxIBQgoDEgFMCgMIhwJCBAoAEBI=',
  'base64',
);

interface ModelInfo { task: string; objective?: string; onnx: string; variants?: Record<string, string>; condition: { labels?: string[] } }

/** The EMDM text model (not the diffusion baseline the compare view uses). */
const isEmdmText = (x: ModelInfo) => x.task === 'text' && x.objective !== 'diffusion';

async function readManifest(page: Page): Promise<{ models: Record<string, ModelInfo>; files: Record<string, { bytes: number; sha256: string }> }> {
  const r = await page.request.get('/models/manifest.json');
  return r.json();
}

function onnxFiles(m: ModelInfo): string[] {
  return [m.onnx, ...Object.values(m.variants ?? {})];
}

/**
 * Remembers every WebAssembly memory created in the realm it runs in (ORT-web's emscripten glue creates its
 * shared memory with `new WebAssembly.Memory`; a module that exports its own memory is caught at
 * instantiation), labelled with the script that made it; `globalThis.__wasmMemories()` lists their sizes.
 * ORT keeps its module private (no handle in `ort.env`), and CDP's JS heap does not include wasm memory.
 */
function trackWasmMemory(): void {
  type Listed = { by: string; bytes: number };
  const g = globalThis as unknown as { __wasmMemories?: () => Listed[] };
  if (g.__wasmMemories) return;
  const OrigMemory = WebAssembly.Memory;
  const seen: { memory: WebAssembly.Memory; by: string }[] = [];
  // the script that called (stack: message, by, the wrapper, then the caller)
  const by = () => (new Error().stack ?? '').split('\n').slice(3).map((l) => /([\w.-]+\.m?js)\b/.exec(l)?.[1]).find(Boolean) ?? '?';
  const add = (memory: unknown, label: string) => {
    if (memory instanceof OrigMemory && !seen.some((t) => t.memory === memory)) seen.push({ memory, by: label });
  };
  WebAssembly.Memory = new Proxy(OrigMemory, {
    construct(target, args) {
      const m = Reflect.construct(target, args) as WebAssembly.Memory;
      add(m, by());
      return m;
    },
  });
  const fromExports = (inst: WebAssembly.Instance, label: string) => Object.values(inst.exports).forEach((v) => add(v, label));
  const origInstantiate = WebAssembly.instantiate.bind(WebAssembly);
  WebAssembly.instantiate = (async (...args: Parameters<typeof WebAssembly.instantiate>) => {
    const label = by();
    const r: unknown = await origInstantiate(...args);
    fromExports(r instanceof WebAssembly.Instance ? r : (r as WebAssembly.WebAssemblyInstantiatedSource).instance, label);
    return r;
  }) as typeof WebAssembly.instantiate;
  const origStreaming = WebAssembly.instantiateStreaming?.bind(WebAssembly);
  if (origStreaming) {
    WebAssembly.instantiateStreaming = async (...args: Parameters<typeof WebAssembly.instantiateStreaming>) => {
      const label = by();
      const r = await origStreaming(...args);
      fromExports(r.instance, label);
      return r;
    };
  }
  g.__wasmMemories = () => seen.map((t) => ({ by: t.by, bytes: t.memory.buffer.byteLength })).filter((t) => t.bytes > 0);
}

/**
 * Tracks WebAssembly memory on the page's thread (init script) and in its workers (ORT may run in a Web
 * Worker, where init scripts do not reach): every same-origin script is served with the tracker prepended
 * (plain statements, so an ES module's imports stay valid; it installs itself once per realm).
 */
async function trackWasmMemoryEverywhere(page: Page): Promise<void> {
  await page.addInitScript(trackWasmMemory);
  const prelude = `(${trackWasmMemory.toString()})();\n`;
  await page.route(/\/[^/?#]+\.m?js(\?[^#]*)?$/, async (route: Route) => {
    const res = await route.fetch();
    await route.fulfill({ response: res, body: prelude + (await res.text()) });
  });
}

/** The WebAssembly memories of the page and of every worker, e.g. [{ by: 'ort-wasm-simd-threaded.mjs', bytes }]. */
async function wasmMemories(page: Page): Promise<{ where: string; by: string; bytes: number }[]> {
  type Listed = { by: string; bytes: number };
  const list = () => (globalThis as unknown as { __wasmMemories?: () => Listed[] }).__wasmMemories?.() ?? [];
  const out = (await page.evaluate(list)).map((m) => ({ where: 'page', ...m }));
  // ORT's own thread-pool workers (scripts ort-wasm-*.mjs) wait in Atomics.wait and never answer an evaluate
  // (it would hang the test and stall their threads); they share the memory of the realm that made them.
  for (const w of page.workers().filter((x) => !/\/ort-wasm[^/]*\.mjs/.test(x.url()))) {
    const name = w.url().split('/').pop() ?? w.url();
    out.push(...(await w.evaluate(list).catch(() => [] as Listed[])).map((m) => ({ where: name, ...m })));
  }
  return out;
}

async function open(page: Page, query = 'noauto=1&backend=wasm'): Promise<void> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
}

test.describe('demo page: bad input', () => {
  // One page for the whole group (loading the models is the slow part); counters are compared as deltas.
  test.describe.configure({ mode: 'serial' });
  let page: Page;
  let watch: ReturnType<typeof watchPage>;
  const counters = () => page.evaluate(() => ({ ...window.emdm.counters }));
  test.beforeAll(async ({ browser }) => {
    test.setTimeout(300_000);
    page = await browser.newPage();
    watch = watchPage(page);
    await trackWasmMemoryEverywhere(page);
    await open(page);
  });
  test.afterAll(async () => {
    await page?.close();
  });

  test('empty prompt: Generate is disabled with a hint', async () => {
    const c0 = await counters();
    await page.locator('#prompt').fill('   ');
    await expect(page.locator('#generate')).toBeDisabled();
    await expect(page.locator('#prompt-hint')).toContainText('Type a prompt');
    await page.locator('#prompt').press('Enter');
    await page.waitForTimeout(200);
    expect((await counters()).requests).toBe(c0.requests);
    await page.locator('#prompt').fill(PROMPT);
    await expect(page.locator('#generate')).toBeEnabled();
  });

  test('overlong prompt: the encoder reads its first maxTokens tokens (as Python) and a note under the prompt says so', async () => {
    const c0 = await counters();
    const long = `${PROMPT} `.repeat(40); // 920 characters, 162 tokens with [CLS] and [SEP]; MiniLM reads 128
    await page.locator('#prompt').fill(long);
    await expect(page.locator('#prompt-hint')).toHaveText('');
    await page.locator('#seconds').fill('1');
    await page.locator('#steps').fill('0');
    await page.locator('#generate').click();
    await page.waitForFunction((n) => window.emdm.counters.generations === n + 1, c0.generations, { timeout: 120_000 });
    await expect(page.locator('#prompt-hint')).toHaveText(/^Prompt truncated to 128 tokens: .* this prompt has 162/);
    await expect(page.locator('#prompt-hint')).toHaveClass(/warn/);
    expect(await page.locator('#prompt').inputValue()).toBe(long); // nothing is cut by characters
    await page.locator('#prompt').fill(PROMPT);
    await expect(page.locator('#prompt-hint')).toHaveText('');
  });

  test('HTML in the prompt is shown as text, never interpreted', async () => {
    const evil = '<img src=x onerror="window.__pwned=1"><b>bold</b> a person jumps';
    const r = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 1, steps: 1 }), evil);
    expect(r.frames).toBe(20);
    await expect(page.locator('#caption')).toContainText(evil);
    expect(await page.locator('#caption img, #caption b').count()).toBe(0);
    expect(await page.evaluate(() => (window as { __pwned?: number }).__pwned)).toBeUndefined();
    expect(await page.evaluate(() => window.emdm.cspViolations)).toEqual([]);
    watch.assertClean();
  });

  test('repeated clicks: the newest request wins, older ones are cancelled', async () => {
    const c0 = await counters();
    const out = await page.evaluate(async (t) => {
      const seeds = [11, 22, 33];
      const settled = await Promise.allSettled(seeds.map((seed) => window.emdm.generate({ mode: 'text', text: t, seed, seconds: 2, steps: 2 })));
      return settled.map((s) => (s.status === 'fulfilled' ? { ok: true, seed: s.value.state.seed } : { ok: false, name: (s.reason as Error).name }));
    }, PROMPT);
    expect(out[2]).toEqual({ ok: true, seed: 33 });
    expect(out.slice(0, 2).every((o) => !o.ok && o.name === 'AbortError')).toBe(true);
    const c1 = await counters();
    expect(c1.cancelled - c0.cancelled).toBe(2);
    expect(c1.generations - c0.generations).toBe(1);
    await expect(page.locator('#caption')).toContainText('seed 33');
    // The button stays clickable while busy; three clicks in a row end with one finished generation.
    await page.locator('#seconds').fill('2');
    await page.evaluate(() => {
      const b = document.querySelector<HTMLButtonElement>('#generate')!;
      for (let i = 0; i < 3; i++) b.click();
    });
    await page.waitForFunction((n) => window.emdm.counters.requests === n + 3 && !document.querySelector('#generate')!.classList.contains('busy'),
      c1.requests, { timeout: 120_000 });
    const c2 = await counters();
    expect(c2.cancelled - c1.cancelled).toBe(2);
    expect(c2.generations - c1.generations).toBe(1);
  });

  test('no leak over 100 generations (JS heap after GC, and ORT\'s WASM memory)', async () => {
    test.setTimeout(600_000);
    const cdp = await page.context().newCDPSession(page);
    const heap = async () => {
      await cdp.send('HeapProfiler.collectGarbage');
      return (await cdp.send('Runtime.getHeapUsage')).usedSize;
    };
    // WASM memories only grow (a freed tensor is reused, never returned), so a leak inside ORT (sessions,
    // tensors or outputs not released) shows as growth of their total size over many generations.
    const wasm = () => wasmMemories(page);
    const total = (ms: { bytes: number }[]) => ms.reduce((a, m) => a + m.bytes, 0);
    const mb = (b: number) => `${(b / 2 ** 20).toFixed(1)} MB`;
    const generate = (from: number, count: number) => page.evaluate(async ([t, from, count]) => {
      let done = 0;
      for (let i = from; i < from + count; i++) {
        await window.emdm.generate({ mode: 'text', text: t, seconds: 1 + (i % 3), steps: 1, seed: i });
        done++;
      }
      return done;
    }, [PROMPT, from, count] as const);
    await generate(0, 3);                           // every length once: ORT's arena reaches its working size
    const before = await heap();
    const wasmBefore = await wasm();
    expect(wasmBefore.some((m) => /ort/i.test(m.by)), `ORT's wasm memory not found: ${JSON.stringify(wasmBefore)}`).toBe(true);
    console.log(`WASM memory after 3 generations: ${wasmBefore.map((m) => `${m.where}: ${m.by} ${mb(m.bytes)}`).join(', ')}`);
    const n1 = await generate(3, 50);
    const wasmMid = total(await wasm());
    console.log(`WASM memory after 53 generations: ${mb(wasmMid)}`);
    const n = n1 + (await generate(53, 50));
    const after = await heap();
    const wasmAfter = await wasm();
    expect(n).toBe(100);
    const per = wasmAfter.map((m) => `${m.where}: ${m.by} ${mb(m.bytes)}`).join(', ');
    console.log(`JS heap: ${mb(before)} before, ${mb(after)} after 100 generations; WASM memory: ${mb(total(wasmBefore))} before, `
      + `${mb(wasmMid)} after 50, ${mb(total(wasmAfter))} after 100 (${per})`);
    expect(after - before).toBeLessThan(8 * 2 ** 20);
    expect(wasmAfter.length, 'no WASM memory appeared or vanished during the generations').toBe(wasmBefore.length);
    expect(total(wasmAfter) - total(wasmBefore), `WASM memory grew: ${per}`).toBeLessThan(16 * 2 ** 20);
    expect(total(wasmAfter) - wasmMid, 'WASM memory still growing in the second 50 generations').toBeLessThan(8 * 2 ** 20);
  });

  test('out-of-range URL values are clamped with a notice', async ({ page: fresh }) => {
    // The controls are set from the URL as soon as the manifest is read (no need to wait for the models).
    await fresh.goto('/?noauto=1&backend=wasm&mode=dance&steps=7&seconds=30&guidance=-3&seed=-5&text=a%20person%20runs');
    await expect(fresh.locator('.notice.warn').first()).toBeVisible({ timeout: 60_000 }); // shown for 14 s
    await fresh.waitForFunction(() => (window.emdm?.notices().length ?? 0) >= 5, null, { timeout: 60_000 });
    const notices = (await fresh.evaluate(() => window.emdm.notices())).map((n) => n.text).join('\n');
    expect(notices).toContain("mode='dance'");
    expect(notices).toContain('steps=7');
    expect(notices).toContain('seconds=30');
    expect(notices).toContain('guidance=-3');
    expect(notices).toContain('seed=-5');
    await expect(fresh.locator('#seconds-out')).toHaveText('9.8 s');
    await expect(fresh.locator('#guidance-out')).toHaveText('1.0');
    expect(await fresh.locator('#seed').inputValue()).toBe('0');
    expect(await fresh.locator('#prompt').inputValue()).toBe('a person runs');
    const steps = Number(await fresh.locator('#steps-out').textContent());
    const m = await readManifest(fresh);
    const text = Object.values(m.models).find(isEmdmText) as unknown as { supportedSteps: number[] };
    expect(text.supportedSteps).toContain(steps);
    expect(new URL(fresh.url()).searchParams.get('seconds')).toBe('9.8'); // the URL now holds the clamped state
  });
});

test.describe('demo page: faults', () => {
  test('a missing model file: a clear panel, and the rest of the page stays usable', async ({ page }) => {
    const m = await readManifest(page);
    const [name, text] = Object.entries(m.models).find(([, x]) => isEmdmText(x))!;
    for (const f of onnxFiles(text)) await page.route(`**/models/${f}`, (r: Route) => r.fulfill({ status: 404, body: 'not found' }));
    await open(page);
    await expect(page.locator('#error-panel')).toBeVisible();
    await expect(page.locator('#error-title')).toContainText(name);
    await expect(page.locator('#error-reason')).toContainText(/missing|could not be downloaded/);
    await expect(page.locator('#mode-text')).toBeDisabled();
    // one status: the error, never "Downloading …" with the loading dot beside the error panel
    await expect(page.locator('#status-dot')).toHaveClass(/\berror\b/);
    await expect(page.locator('#status-text')).toContainText(`${name} unavailable`);
    await page.waitForTimeout(1500); // late download events of the failed load must not bring "loading" back
    await expect(page.locator('#status-dot')).toHaveClass(/\berror\b/);
    await expect(page.locator('#status-text')).not.toContainText('Downloading');
    await expect(page.locator('#download-bar')).toBeHidden();
    const action = Object.values(m.models).find((x) => x.task === 'action');
    test.skip(!action, 'no action model is shipped, so no other mode can be shown working');
    await expect(page.locator('#mode-action')).toHaveAttribute('aria-selected', 'true');
    expect(new URL(page.url()).searchParams.get('mode'), 'the URL names the mode the page fell back to').toBe('action');
    const r = await page.evaluate(() => window.emdm.generate({ mode: 'action', seconds: 1, steps: 1 }));
    expect(r.frames).toBe(20);
    await expect(page.locator('#status-dot')).toHaveClass(/\bready\b/); // the action model works: ready
    // a prompt now (the page is in action mode) is refused naming what failed, never answered with the selected action
    const done = await page.evaluate(() => window.emdm.counters.generations);
    await expect(page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', seconds: 1, steps: 1 }))).rejects.toThrow(new RegExp(`${name}[^ ]*\\.onnx: not found`));
    expect(await page.evaluate(() => window.emdm.counters.generations)).toBe(done);
    await expect(page.locator('#error-title')).toContainText(name);
  });

  test('a diffusion model that fails to load turns compare off in the URL too, and the status says what failed', async ({ page }) => {
    const m = await readManifest(page);
    const ddim = Object.entries(m.models).find(([, x]) => x.task === 'text' && x.objective === 'diffusion');
    test.skip(!ddim, 'no diffusion model is shipped, so there is no compare view');
    const [name, entry] = ddim!;
    for (const f of onnxFiles(entry)) await page.route(`**/models/${f}`, (r: Route) => r.fulfill({ status: 404, body: 'not found' }));
    await open(page);
    await page.locator('#compare').click();
    await expect(page.locator('#compare')).toBeDisabled({ timeout: 60_000 });
    await expect(page.locator('#compare')).not.toBeChecked();
    expect(new URL(page.url()).searchParams.get('compare'), 'the URL no longer asks for the compare view').toBeNull();
    await expect(page.locator('#status-dot')).toHaveClass(/\berror\b/);
    await expect(page.locator('#status-text')).toContainText(`${name} unavailable`);
  });

  test('a model whose sha256 differs from the manifest is refused with the reason', async ({ page }) => {
    const m = await readManifest(page);
    const [name, text] = Object.entries(m.models).find(([, x]) => isEmdmText(x))!;
    for (const f of onnxFiles(text)) {
      await page.route(`**/models/${f}`, async (r: Route) => {
        const res = await r.fetch();
        const body = Buffer.from(await res.body());
        body[body.length >> 1] ^= 0xff;
        await r.fulfill({ response: res, body });
      });
    }
    await open(page);
    await expect(page.locator('#error-panel')).toBeVisible();
    await expect(page.locator('#error-title')).toContainText(name);
    await expect(page.locator('#error-reason')).toContainText('checksum');
    expect(await page.evaluate(() => window.emdm.error)).toMatch(/sha256/i);
  });

  test('NaN from the model: an error, and the character keeps its last good motion', async ({ page }) => {
    const m = await readManifest(page);
    const action = Object.values(m.models).find((x) => x.task === 'action');
    test.skip(!action, 'needs an action model to swap for a NaN model while the text model stays good');
    const sha = createHash('sha256').update(NAN_STEP_MODEL).digest('hex');
    const files = onnxFiles(action!);
    await page.route('**/models/manifest.json', async (r: Route) => {
      const res = await r.fetch();
      const doc = await res.json();
      for (const f of files) doc.files[f] = { bytes: NAN_STEP_MODEL.length, sha256: sha };
      await r.fulfill({ response: res, body: JSON.stringify(doc) });
    });
    for (const f of files) await page.route(`**/models/${f}`, (r: Route) => r.fulfill({ status: 200, body: NAN_STEP_MODEL, contentType: 'application/octet-stream' }));
    await open(page);
    const good = await page.evaluate((t) => window.emdm.generate({ mode: 'text', text: t, seconds: 2, steps: 2, seed: 5 }), PROMPT);
    const err = await page.evaluate(async () => {
      try {
        await window.emdm.generate({ mode: 'action', seconds: 1, steps: 1 });
        return 'no error';
      } catch (e) {
        return (e as Error).message;
      }
    });
    expect(err).toMatch(/NaN|non-finite/i);
    await expect(page.locator('.notice.error')).toContainText(/non-finite|NaN/i);
    const c = await page.evaluate(() => window.emdm.counters);
    expect(c.generations).toBe(1);
    expect(c.errors).toBe(1);
    await expect(page.locator('#caption')).toContainText(PROMPT); // still showing the good motion
    // the playback bar shows the good motion's length (synced on the next displayed frame)
    await expect(page.locator('#time')).toContainText(`/ ${(good.frames / good.fps).toFixed(1)} s`);
  });

  test('WebGPU unavailable: falls back to WASM and says so', async ({ page }) => {
    await page.addInitScript(() => Object.defineProperty(Navigator.prototype, 'gpu', { get: () => undefined, configurable: true }));
    await open(page, 'noauto=1'); // backend=auto
    expect(await page.evaluate(() => window.emdm.backend)).toBe('wasm');
    const notices = (await page.evaluate(() => window.emdm.notices())).map((n) => n.text).join('\n');
    expect(notices).toMatch(/WebGPU is not available.*WebAssembly/);
    await expect(page.locator('#status-text')).toContainText('WASM');
  });

  // An app built with emdm() alone serves one runtime: its files.json lists no WebGPU runtime, and the library never
  // asks for it ('auto': WASM, nothing said; 'webgpu': WASM, and the notice says why).
  for (const backend of ['auto', 'webgpu'] as const) {
    test(`an app serving only the WASM runtime, backend=${backend}: WASM, no request for WebGPU's runtime${backend === 'webgpu' ? ', the notice says why' : ', no notice'}`, async ({ page }) => {
      await page.route('**/ort/files.json', async (r: Route) => {
        const list = await (await r.fetch()).json() as Record<string, unknown>;
        await r.fulfill({ json: { 'ort-wasm-simd-threaded.wasm': list['ort-wasm-simd-threaded.wasm'] } });
      });
      const asked: string[] = [];
      page.on('request', (r) => { if (r.url().includes('asyncify')) asked.push(r.url()); });
      await open(page, `noauto=1&backend=${backend}`);
      expect(await page.evaluate(() => window.emdm.backend)).toBe('wasm');
      const notices = (await page.evaluate(() => window.emdm.notices())).map((n) => n.text).filter((t) => t.includes('WebGPU'));
      expect(notices).toEqual(backend === 'auto' ? [] : [expect.stringMatching(/^WebGPU is not available \(this app serves only ONNX Runtime's WebAssembly runtime; .*\): .* runs on WebAssembly \(CPU\) instead\.$/)]);
      expect(asked).toEqual([]);
    });
  }
});
