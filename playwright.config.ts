// Playwright (tests/e2e/*.spec.ts) on Debian's /usr/bin/chromium (`npx playwright install` cannot
// download browsers here). The web server is the BUILT site in the test mode (the demo as shipped plus
// the test harness at /harness/, into dist-e2e/; the production dist/ has no harness) served by
// `vite preview` with the COOP/COEP headers (see vite.config.ts), on its own port so a running
// `make demo` does not clash.
import { createHash } from 'node:crypto';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { defineConfig } from '@playwright/test';

// One port per checkout (4200..4999, from its path), so two clones testing at once do not collide;
// E2E_PORT overrides it.
const ROOT = path.dirname(fileURLToPath(import.meta.url));
const PATH_PORT = 4200 + (createHash('sha256').update(ROOT).digest().readUInt16BE(0) % 800);
export const E2E_PORT = Number(process.env.E2E_PORT ?? PATH_PORT);
const CHROMIUM = process.env.CHROMIUM_PATH ?? '/usr/bin/chromium';
// EMDM_WEBGPU=1: Chromium with the GPU and WebGPU on (for the benchmarks' `backend=webgpu` runs on a machine with a
// GPU); EMDM_WEBGPU=swiftshader: WebGPU on Chromium's CPU adapter (checks that the WebGPU path runs; its times are
// the CPU's, not a GPU's). Default: no GPU, the page falls back to WASM as on a machine without one.
const WEBGPU = process.env.EMDM_WEBGPU ?? '';
const GPU_ARGS = WEBGPU ? ['--enable-unsafe-webgpu', ...(WEBGPU === 'swiftshader' ? ['--use-webgpu-adapter=swiftshader'] : ['--enable-features=Vulkan', '--ignore-gpu-blocklist'])] : ['--disable-gpu'];

export default defineConfig({
  testDir: 'tests/e2e',
  testMatch: '**/*.spec.ts',
  outputDir: 'test-results',
  fullyParallel: false,
  workers: 1, // 2 CPU cores: one browser at a time
  retries: 0,
  timeout: 180_000,
  expect: { timeout: 30_000 },
  reporter: process.env.CI ? [['list']] : [['list']],
  use: {
    baseURL: `http://127.0.0.1:${E2E_PORT}`,
    browserName: 'chromium',
    headless: true,
    launchOptions: {
      executablePath: CHROMIUM,
      args: [
        '--no-sandbox',
        ...GPU_ARGS,
        '--disable-quic',
        '--no-first-run',
        '--disable-background-networking',
        '--disable-component-update',
        '--disable-sync',
      ],
    },
    trace: 'off',
    screenshot: 'only-on-failure',
  },
  webServer: {
    command: `npx vite build --mode e2e && npx vite preview --mode e2e --host 127.0.0.1 --port ${E2E_PORT} --strictPort`,
    url: `http://127.0.0.1:${E2E_PORT}/models/manifest.json`,
    reuseExistingServer: !process.env.CI,
    timeout: 300_000,
    stdout: 'ignore',
    stderr: 'pipe',
  },
});
