// Shared helpers for the Playwright suites (tests/e2e/*.spec.ts).
import type { Page } from '@playwright/test';

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
