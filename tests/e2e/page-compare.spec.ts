// The compare view on the demo page (WASM): "Compare with diffusion (DDIM)" shows EMDM and the plain
// diffusion baseline side by side from the same prompt, seed and length, each with its own timings;
// the slider offers the diffusion model's 20/50/100 steps while EMDM stays at its maximum. Without a
// diffusion model in the manifest the toggle is disabled with a notice saying why.
import { expect, test, type Page, type Route } from '@playwright/test';
import { watchPage } from './helpers';

const PROMPT = 'a person walks forward and waves';

interface ModelInfo { task: string; objective?: string; supportedSteps: number[] }

async function readManifest(page: Page): Promise<{ models: Record<string, ModelInfo> }> {
  return (await page.request.get('/models/manifest.json')).json();
}

async function open(page: Page, query = 'noauto=1&backend=wasm'): Promise<void> {
  await page.goto(`/?${query}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

test.describe('compare view', () => {
  test('without a diffusion model the toggle is disabled and says why', async ({ page }) => {
    // the same manifest with every diffusion-objective model removed
    await page.route('**/models/manifest.json', async (r: Route) => {
      const res = await r.fetch();
      const m = await res.json();
      for (const [k, e] of Object.entries(m.models as Record<string, ModelInfo>)) if (e.objective === 'diffusion') delete m.models[k];
      await r.fulfill({ response: res, json: m });
    });
    await open(page);
    await expect(page.locator('#compare')).toBeDisabled();
    await expect(page.locator('#compare-hint')).toContainText('ships no diffusion (DDIM) model');
    const info = await page.evaluate(() => window.emdm.compareInfo());
    expect(info.available).toBe(false);
    expect(info.steps).toEqual([]);
    expect(await page.evaluate(() => { try { window.emdm.setCompare(true); return 'no error'; } catch (e) { return (e as Error).message; } }))
      .toMatch(/compare view unavailable: .*no diffusion/);
    // a shared link asking for compare falls back to the plain view with a notice
    await open(page, 'noauto=1&backend=wasm&compare=1');
    expect((await page.evaluate(() => window.emdm.notices())).map((n) => n.text).join('\n')).toContain('compare=1: this demo ships no diffusion');
    expect(await page.evaluate(() => window.emdm.compareInfo().on)).toBe(false);
  });

  test('toggle, generate: two characters, same length, different motions, each panel with its own timings', async ({ page }) => {
    test.setTimeout(300_000);
    const m = await readManifest(page);
    const ddimModel = Object.entries(m.models).find(([, e]) => e.objective === 'diffusion' && e.task === 'text');
    test.skip(!ddimModel, 'public/models/manifest.json has no diffusion-objective text model (diffusion-t2m-web)');
    const watch = watchPage(page);
    await open(page);
    const emdmMax = Math.max(...Object.values(m.models).filter((e) => e.task === 'text' && e.objective !== 'diffusion')[0].supportedSteps);

    // the toggle, as a user flips it
    await page.locator('#mode-text').click();
    await expect(page.locator('#compare')).toBeEnabled();
    await page.locator('#compare').check();
    const info = await page.evaluate(() => window.emdm.compareInfo());
    expect(info).toMatchObject({ available: true, on: true, ddim: ddimModel![0], emdmMaxSteps: emdmMax });
    expect(info.steps).toEqual(expect.arrayContaining([20, 50, 100]));
    expect(new URL(page.url()).searchParams.get('compare')).toBe('1');

    // the slider now reaches 100; past EMDM's maximum the note says EMDM stays there
    await page.locator('#steps').fill(String(info.steps.length - 1));
    await expect(page.locator('#steps-out')).toHaveText('100');
    await expect(page.locator('#steps-note')).toBeVisible();
    await expect(page.locator('#steps-note')).toContainText(`EMDM stays at ${emdmMax} steps, its maximum`);

    // generate at 20 steps (EMDM runs its maximum), 2 s, a fixed seed
    const r = await page.evaluate((t) => window.emdm.generate({ text: t, steps: 20, seconds: 2, seed: 7 }), PROMPT);
    expect(r.compare).toBeDefined();
    const { emdm, ddim } = r.compare!;
    for (const [p, sampler, steps] of [[emdm, 'ddgan', emdmMax], [ddim, 'ddim', 20]] as const) {
      expect(p.frames).toBe(40);
      expect(p.joints).toHaveLength(40 * 22 * 3);
      expect(p.joints.every(Number.isFinite)).toBe(true);
      expect(p.sampler).toBe(sampler);
      expect(p.steps).toBe(steps);
      expect(p.timings.stepMs).toHaveLength(steps);
      expect(p.timings.totalMs).toBeGreaterThan(0);
    }
    expect(ddim.model).toBe(ddimModel![0]);
    const diff = emdm.joints.reduce((mx, v, i) => Math.max(mx, Math.abs(v - ddim.joints[i])), 0);
    expect(diff).toBeGreaterThan(0.01);

    // both panels, labelled, with their own step counts and timings
    await expect(page.locator('#compare-panels')).toBeVisible();
    await expect(page.locator('#timings')).toBeHidden();
    await expect(page.locator('#panel-emdm-label')).toHaveText('EMDM (left)');
    await expect(page.locator('#panel-ddim-label')).toHaveText('DDIM (right)');
    await expect(page.locator('#panel-emdm-steps')).toContainText(`${emdmMax} (`);
    await expect(page.locator('#panel-ddim-steps')).toContainText('20 (');
    await expect(page.locator('#panel-ddim-sub')).toContainText('DDIM, η = 0');
    for (const id of ['#panel-emdm-step', '#panel-emdm-total', '#panel-ddim-step', '#panel-ddim-total']) {
      await expect(page.locator(id)).toHaveText(/\d+(\.\d+)? (ms|s)$/);
    }
    await expect(page.locator('#caption small')).toContainText(`EMDM ${emdmMax} vs DDIM 20 steps`);
    expect(await page.evaluate(() => window.emdm.compareInfo())).toMatchObject({ ddimCharacterVisible: true, split: true, panelsVisible: true });
    await expect(page.locator('#compare-divider')).toBeVisible();

    // the same request again reproduces both motions (same seed)
    const again = await page.evaluate((t) => window.emdm.compare({ text: t, steps: 20, seconds: 2, seed: 7 }), PROMPT);
    expect(again.ddim.joints).toEqual(ddim.joints);
    expect(again.emdm.joints).toEqual(emdm.joints);

    // off again: one character, the single-model timings
    await page.locator('#compare').uncheck();
    await expect(page.locator('#compare-panels')).toBeHidden();
    await expect(page.locator('#timings')).toBeVisible();
    expect(await page.evaluate(() => window.emdm.compareInfo())).toMatchObject({ ddimCharacterVisible: false, split: false, on: false });
    await expect(page.locator('#steps-out')).toHaveText(String(emdmMax));

    // action mode: the diffusion model takes no action label
    await page.locator('#mode-action').click();
    if (await page.locator('#mode-action').getAttribute('aria-selected') === 'true') {
      await expect(page.locator('#compare')).toBeDisabled();
      await expect(page.locator('#compare-hint')).toContainText('takes a text prompt or nothing');
    }
    watch.assertClean();
  });

  test('a diffusion model file that cannot be loaded: compare turns itself off with the reason; EMDM keeps working', async ({ page }) => {
    const m = (await readManifest(page)) as { models: Record<string, ModelInfo & { onnx: string; variants?: Record<string, string> }> };
    const ddimModel = Object.entries(m.models).find(([, e]) => e.objective === 'diffusion' && e.task === 'text');
    test.skip(!ddimModel, 'public/models/manifest.json has no diffusion-objective text model (diffusion-t2m-web)');
    const [name, entry] = ddimModel!;
    for (const f of [entry.onnx, ...Object.values(entry.variants ?? {})]) await page.route(`**/models/${f}`, (r: Route) => r.fulfill({ status: 404, body: 'not found' }));
    await open(page);
    await page.locator('#compare').click(); // turned on; the model's download fails quickly and turns it off again
    await expect(page.locator('#compare')).toBeDisabled({ timeout: 60_000 });
    await expect(page.locator('#compare')).not.toBeChecked();
    await expect(page.locator('#compare-hint')).toContainText(`The diffusion model ${name} failed to load`);
    await expect(page.locator('#error-title')).toContainText(name);
    const r = await page.evaluate((t) => window.emdm.generate({ text: t, seconds: 1, steps: 1, seed: 1 }), PROMPT);
    expect(r.frames).toBe(20);
    expect(r.sampler).toBe('ddgan');
  });
});
