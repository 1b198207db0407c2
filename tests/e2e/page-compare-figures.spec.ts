// The compare view for an educator (issue 30): each half of the stage says which model it shows and the steps it
// actually ran ("EMDM · 10 steps", "DDIM · 20 steps"), and a small table beside the motions gives what the steps
// change: jerk (m/s³), foot skate (cm/s) and speed (m/s), measured in the page on the two motions on screen, the
// speed beside the real clips' range of the prompt's action (the shipped capabilities file). The test measures the
// figures again here, from window.emdm's joints of each panel, and checks the table follows a new pair of motions.
import fs from 'node:fs';
import path from 'node:path';
import { expect, test, type Page } from '@playwright/test';
import { skipWithoutDiffusion, watchPage } from './helpers';

const PROMPT = 'a person walks forward';
const J = 22;

/** The figures, computed here independently of web/ui/motion-figures.ts (same definitions, see its header). */
function figures(joints: number[], frames: number, fps: number): { jerk: number; skate: number; speed: number } {
  const p = (f: number, j: number) => joints.slice((f * J + j) * 3, (f * J + j) * 3 + 3);
  let jerk = 0;
  let nj = 0;
  for (let f = 3; f < frames; f++) {
    for (let j = 0; j < J; j++) {
      const [a, b, c, d] = [p(f, j), p(f - 1, j), p(f - 2, j), p(f - 3, j)];
      jerk += Math.hypot(...[0, 1, 2].map((k) => a[k] - 3 * b[k] + 3 * c[k] - d[k]));
      nj++;
    }
  }
  const feet = [10, 11];
  let skate = 0;
  let ns = 0;
  for (let f = 1; f < frames; f++) {
    for (const j of feet) {
      const [a, b] = [p(f, j), p(f - 1, j)];
      if (!(a[1] < 0.05 && b[1] < 0.05)) continue; // both frames' foot below 5 cm: on the floor
      skate += Math.hypot(a[0] - b[0], a[2] - b[2]);
      ns++;
    }
  }
  const root: number[] = [];
  for (let f = 1; f < frames; f++) root.push(Math.hypot(p(f, 0)[0] - p(f - 1, 0)[0], p(f, 0)[2] - p(f - 1, 0)[2]) * fps);
  root.sort((a, b) => a - b);
  const m = root.length >> 1;
  const speed = root.length % 2 ? root[m] : (root[m - 1] + root[m]) / 2;     // median pelvis speed over the ground
  return { jerk: (jerk / nj) * fps ** 3, skate: ns ? (skate / ns) * fps * 100 : NaN, speed };
}

/** The real clips' speed range the table should show for PROMPT: its action by the check Python wrote into the shipped
 * file's examples, that action's realSpeed there. */
function realRange(): string {
  const caps = JSON.parse(fs.readFileSync(path.join(process.cwd(), 'public/models/capabilities-emdm-t2m-web.json'), 'utf8'));
  const ex = caps.examples.find((e: { prompt: string }) => e.prompt === PROMPT);
  expect(ex?.known, `${PROMPT} is a covered prompt in the capabilities file`).toBe(true);
  const s = caps.actions.find((a: { label: string }) => a.label === ex.action).realSpeed;
  return `real ${ex.action.replace(/-/g, ' ')} ${s.low.toFixed(2)}–${s.high.toFixed(2)}`;
}

/** The table's four numbers as shown. */
async function shown(page: Page): Promise<Record<string, number>> {
  const out: Record<string, number> = {};
  for (const side of ['emdm', 'ddim']) {
    for (const row of ['jerk', 'skate']) out[`${side}-${row}`] = Number(await page.locator(`#fig-${side}-${row}`).textContent());
    out[`${side}-speed`] = Number(await page.locator(`#fig-${side}-speed`).evaluate((td) => td.firstChild!.textContent));
  }
  return out;
}

/** A shown figure (3 significant figures) agrees with the one computed here. */
function agrees(shownValue: number, computed: number): boolean {
  return Math.abs(shownValue - computed) <= 0.006 * Math.abs(computed) + 0.006;
}

test('stage labels from the steps run; jerk, foot skate and speed of the motions on screen, updated with them; the real range from the file', async ({ page }) => {
  test.setTimeout(300_000);
  await skipWithoutDiffusion(page);
  const watch = watchPage(page);
  await page.goto('/?noauto=1&backend=wasm');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });

  const real = realRange();
  const check = async (steps: number, seed: number) => {
    const r = await page.evaluate(([text, steps, seed]) => window.emdm.compare({ mode: 'text', text, steps, seconds: 3, seed }), [PROMPT, steps, seed] as const);
    const { emdm, ddim } = r;
    await expect(page.locator('#stage-label-emdm')).toBeVisible();
    await expect(page.locator('#stage-label-emdm')).toHaveText(`EMDM · ${emdm.steps} steps`);
    await expect(page.locator('#stage-label-ddim')).toHaveText(`DDIM · ${ddim.steps} steps`);
    expect(ddim.steps).toBe(steps);
    await expect(page.locator('#compare-figures')).toBeVisible();
    await expect(page.getByRole('table')).toContainText('Jerk, m/s³');
    const figs = await shown(page);
    const want = { emdm: figures(emdm.joints, emdm.frames, emdm.fps), ddim: figures(ddim.joints, ddim.frames, ddim.fps) };
    for (const side of ['emdm', 'ddim'] as const) {
      expect(agrees(figs[`${side}-jerk`], want[side].jerk), `${side} jerk: shown ${figs[`${side}-jerk`]}, measured ${want[side].jerk}`).toBe(true);
      expect(agrees(figs[`${side}-skate`], want[side].skate), `${side} foot skate: shown ${figs[`${side}-skate`]}, measured ${want[side].skate}`).toBe(true);
      expect(agrees(figs[`${side}-speed`], want[side].speed), `${side} speed: shown ${figs[`${side}-speed`]}, measured ${want[side].speed}`).toBe(true);
    }
    await expect(page.locator('#fig-real')).toHaveText(`${real} m/s (5th–95th percentile of its clips)`);
    // the table fits its box in the rail: nothing cut off (the ranges beside each speed once made it 367 px in 203)
    const [table, box] = await page.evaluate(() => [document.querySelector('#compare-figures table')!.getBoundingClientRect().width,
      document.getElementById('compare-figures')!.clientWidth]);
    expect(table).toBeLessThanOrEqual(box);
    console.log(`${steps} DDIM steps, seed ${seed}: EMDM (${emdm.steps} steps) jerk ${want.emdm.jerk.toFixed(1)} m/s³, skate ${want.emdm.skate.toFixed(1)} cm/s;`
      + ` DDIM jerk ${want.ddim.jerk.toFixed(1)} m/s³, skate ${want.ddim.skate.toFixed(1)} cm/s; speed EMDM ${want.emdm.speed.toFixed(2)}, DDIM ${want.ddim.speed.toFixed(2)} m/s ${real}`);
    return figs;
  };
  const first = await check(20, 7);
  const second = await check(50, 8); // new motions: the table follows them
  expect(second).not.toEqual(first);

  // off: the labels and the table go with the compare view
  await page.locator('#compare').uncheck();
  await expect(page.locator('#stage-label-emdm')).toBeHidden();
  await expect(page.locator('#stage-label-ddim')).toBeHidden();
  await expect(page.locator('#compare-figures')).toBeHidden();
  watch.assertClean();
});
