// Shared helpers for the Playwright suites (tests/e2e/*.spec.ts).
import { type Page, test } from '@playwright/test';

/** Collects page errors and console errors; call `assertClean()` at the end of a test. */
export function watchPage(page: Page): { errors: string[]; logs: string[]; assertClean(): void } {
  const errors: string[] = [];
  const logs: string[] = [];
  page.on('pageerror', (e) => errors.push(`pageerror: ${e.message}`));
  page.on('console', (m) => {
    const where = m.location()?.url;
    const line = `${m.type()}: ${m.text()}${where ? ` (${where})` : ''}`;
    logs.push(line);
    if (m.type() === 'error') errors.push(line);
  });
  page.on('requestfailed', (r) => errors.push(`requestfailed: ${r.url()} ${r.failure()?.errorText ?? ''}`));
  page.on('response', (r) => {
    if (r.status() >= 400) errors.push(`HTTP ${r.status()}: ${r.url()}`);
  });
  return {
    errors,
    logs,
    assertClean() {
      if (errors.length) throw new Error(`page reported errors:\n${errors.join('\n')}`);
    },
  };
}

/** True when the page is cross-origin isolated (COOP/COEP served), so ORT can use wasm threads. */
export async function isCrossOriginIsolated(page: Page): Promise<boolean> {
  return page.evaluate(() => globalThis.crossOriginIsolated === true);
}

/** A requests log of every URL the page fetched that is NOT on the test server (must stay empty: no CDN). */
export function watchExternalRequests(page: Page, baseURL: string): string[] {
  const external: string[] = [];
  const origin = new URL(baseURL).origin;
  page.on('request', (r) => {
    const u = r.url();
    if (u.startsWith('data:') || u.startsWith('blob:')) return;
    if (new URL(u).origin !== origin) external.push(u);
  });
  return external;
}

/** What the page's thread did while something ran: see `probeResponsiveness`. */
export interface Responsiveness {
  /** requestAnimationFrame callbacks */
  frames: number;
  maxFrameGap: number;
  medianFrameGap: number;
  /** ticks of a 50 ms setInterval, and the most one came late (ms past its 50) */
  timerTicks: number;
  maxTimerDelay: number;
  /** how long the work ran */
  ms: number;
}

/** The work `probeResponsiveness` watches: a generation through the demo page's test API or the core harness. */
export type ProbedWork = { api: 'emdm'; req: Parameters<Window['emdm']['generate']>[0] } | { api: 'coreHarness'; req: Parameters<Window['coreHarness']['generate']>[0] };

/**
 * requestAnimationFrame gaps and the lateness of a 50 ms setInterval on the page's thread while `work` runs
 * (or for `idleMs` when it is null). Measured in the page, so nothing else is on its thread.
 */
export async function probeResponsiveness(page: Page, work: ProbedWork | null, idleMs = 2500): Promise<Responsiveness> {
  return page.evaluate(async ([w, idle]) => {
    const frames: number[] = [];
    const ticks: number[] = [];
    let on = true;
    const raf = (t: number) => {
      frames.push(t);
      if (on) requestAnimationFrame(raf);
    };
    requestAnimationFrame(raf);
    const timer = setInterval(() => ticks.push(performance.now()), 50);
    const t0 = performance.now();
    if (w?.api === 'emdm') await window.emdm.generate(w.req);
    else if (w?.api === 'coreHarness') await window.coreHarness.generate(w.req);
    else await new Promise((res) => setTimeout(res, idle));
    const ms = performance.now() - t0;
    on = false;
    clearInterval(timer);
    const gaps = frames.slice(1).map((t, i) => t - frames[i]);
    const sorted = [...gaps].sort((a, b) => a - b);
    const late = ticks.slice(1).map((t, i) => t - ticks[i] - 50);
    return {
      frames: frames.length, maxFrameGap: Math.max(0, ...gaps), medianFrameGap: sorted[sorted.length >> 1] ?? 0,
      timerTicks: ticks.length, maxTimerDelay: Math.max(0, ...late), ms,
    };
  }, [work, idleMs] as const);
}

/** Skip the running test when the page's manifest lists no diffusion-objective text model (the compare view's DDIM). */
export async function skipWithoutDiffusion(page: Page): Promise<void> {
  const m = (await (await page.request.get('/models/manifest.json')).json()) as { models: Record<string, { task: string; objective?: string }> };
  test.skip(!Object.values(m.models).some((e) => e.objective === 'diffusion' && e.task === 'text'), 'no diffusion-objective text model in public/models');
}
