// The page's layout at a laptop (1280×800), a desktop (1920×1080) and a phone (390×844) screen: nothing
// drawn over the 3-D view covers the character (its posed mesh projected through the camera, from
// window.emdm.characterRects()) or another overlay, the character stays inside the visible stage,
// Generate and the downloads are on screen without scrolling on desktop, every notice stays
// reachable (5 URL warnings at once: none dropped), the "Show steps" strip is not cut off, the compare
// view's panels clear both characters, and the playback bar says nothing about a motion before there
// is one. Each state is screenshotted into the test's output folder (test-results/) to be looked at.
import { expect, test, type Page, type TestInfo } from '@playwright/test';
import { skipWithoutDiffusion, watchPage } from './helpers';

const PROMPT = 'a person walks forward and waves';
/** Five out-of-range URL values, each clamped with a warning (see web/ui/state.ts). */
const FIVE_WARNINGS = 'mode=dance&steps=7&seconds=30&guidance=-3&seed=-5';

const SIZES = [
  { name: 'laptop', width: 1280, height: 800, desktop: true },
  { name: 'desktop', width: 1920, height: 1080, desktop: true },
  { name: 'phone', width: 390, height: 844, desktop: false },
] as const;

interface Rect { x: number; y: number; width: number; height: number }
interface Box extends Rect { name: string }

/** Things drawn over (or beside) the 3-D view: none may cover the character or each other. */
const OVERLAYS = ['#caption', '#timings', '#playback', '#notices .notice', '#notices .notices-more', '#panel-emdm', '#panel-ddim', '#compare-figures', '.stage-label', '#panel', '#step-strip'];

const overlap = (a: Rect, b: Rect) => Math.max(0, Math.min(a.x + a.width, b.x + b.width) - Math.max(a.x, b.x))
  * Math.max(0, Math.min(a.y + a.height, b.y + b.height) - Math.max(a.y, b.y));
const fmt = (r: Rect) => `(${r.x.toFixed(0)}, ${r.y.toFixed(0)}, ${r.width.toFixed(0)}×${r.height.toFixed(0)})`;

/**
 * Every visible element matching OVERLAYS, page CSS pixels: the part of its box that shows, i.e. clipped
 * by the scrolling containers around it (a notice scrolled out of the rail covers nothing); skipped
 * when nothing of it shows (display:none, visibility:hidden, scrolled away).
 */
async function overlayBoxes(page: Page): Promise<Box[]> {
  return page.evaluate((selectors) => {
    const out: Array<{ name: string; x: number; y: number; width: number; height: number }> = [];
    for (const sel of selectors) {
      document.querySelectorAll<HTMLElement>(sel).forEach((e, i) => {
        if (!e.checkVisibility({ visibilityProperty: true })) return;
        const r = e.getBoundingClientRect();
        let [x0, y0, x1, y1] = [r.left, r.top, r.right, r.bottom];
        for (let a = e.parentElement; a; a = a.parentElement) {
          const cs = getComputedStyle(a);
          if (cs.overflowX === 'visible' && cs.overflowY === 'visible') continue;
          const c = a.getBoundingClientRect();
          [x0, y0, x1, y1] = [Math.max(x0, c.left), Math.max(y0, c.top), Math.min(x1, c.right), Math.min(y1, c.bottom)];
        }
        if (x1 - x0 < 1 || y1 - y0 < 1) return;
        out.push({ name: `${sel}${i ? `[${i}]` : ''}`, x: x0, y: y0, width: x1 - x0, height: y1 - y0 });
      });
    }
    return out;
  }, OVERLAYS);
}

/** The layout rules at one moment; returns the problems found ('' each when fine). */
async function layoutProblems(page: Page): Promise<string[]> {
  const problems: string[] = [];
  const chars = await page.evaluate(() => window.emdm.characterRects());
  if (!chars.length) problems.push('no character on screen');
  const stage = await page.locator('#scene').boundingBox();
  const vp = page.viewportSize()!;
  // the visible part of the stage: the canvas clipped to the window
  const visible = { x: Math.max(0, stage!.x), y: Math.max(0, stage!.y), width: 0, height: 0 };
  visible.width = Math.min(vp.width, stage!.x + stage!.width) - visible.x;
  visible.height = Math.min(vp.height, stage!.y + stage!.height) - visible.y;
  const boxes = await overlayBoxes(page);
  for (const c of chars) {
    if (c.x < visible.x - 1 || c.y < visible.y - 1 || c.x + c.width > visible.x + visible.width + 1 || c.y + c.height > visible.y + visible.height + 1) {
      problems.push(`character ${fmt(c)} is not inside the visible stage ${fmt(visible)}`);
    }
    for (const b of boxes) if (overlap(c, b) > 0) problems.push(`${b.name} ${fmt(b)} covers the character ${fmt(c)}`);
  }
  for (let i = 0; i < boxes.length; i++) {
    for (let j = i + 1; j < boxes.length; j++) {
      const a = boxes[i];
      const b = boxes[j];
      // the side panel contains the step strip: that pair is a parent and its child, not two overlays
      if ([a.name, b.name].includes('#panel') && [a.name, b.name].includes('#step-strip')) continue;
      if (overlap(a, b) > 0) problems.push(`${a.name} ${fmt(a)} and ${b.name} ${fmt(b)} overlap`);
    }
  }
  return problems;
}

/** Check the layout several times while the motion plays (the camera follows the root with a lag). */
async function checkWhilePlaying(page: Page, samples = 6): Promise<string[]> {
  const found = new Set<string>();
  await page.evaluate(() => window.emdm.seek(0, true));
  const duration = await page.evaluate(() => window.emdm.playback().duration);
  for (let i = 0; i < samples; i++) {
    await page.waitForTimeout((duration * 1000) / samples);
    for (const p of await layoutProblems(page)) found.add(p);
  }
  return [...found];
}

/** An element is on screen and not covered: the topmost element at its centre is itself or inside it. */
async function onScreen(page: Page, selector: string): Promise<string> {
  return page.evaluate((sel) => {
    const e = document.querySelector<HTMLElement>(sel);
    if (!e) return `${sel}: not on the page`;
    const r = e.getBoundingClientRect();
    if (r.top < 0 || r.left < 0 || r.bottom > innerHeight || r.right > innerWidth) {
      return `${sel} at (${r.left.toFixed(0)}, ${r.top.toFixed(0)})–(${r.right.toFixed(0)}, ${r.bottom.toFixed(0)}) is outside the ${innerWidth}×${innerHeight} window`;
    }
    const top = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
    return top && (top === e || e.contains(top)) ? '' : `${sel} is covered by ${top?.id ? `#${top.id}` : top?.className || top?.tagName}`;
  }, selector);
}

async function shot(page: Page, info: TestInfo, name: string): Promise<void> {
  const path = info.outputPath(`${name}.png`);
  await page.screenshot({ path });
  await info.attach(name, { path, contentType: 'image/png' });
}

async function open(page: Page, query = ''): Promise<void> {
  await page.goto(`/?noauto=1&backend=wasm${query ? `&${query}` : ''}`);
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.error)).toBe('');
}

for (const size of SIZES) {
  test.describe(`layout at ${size.width}×${size.height} (${size.name})`, () => {
    test.use({ viewport: { width: size.width, height: size.height } });

    test('character, overlays, controls and notices', async ({ page }, info) => {
      test.setTimeout(300_000);
      const watch = watchPage(page);
      await open(page, FIVE_WARNINGS);

      // before any motion: the playback bar offers nothing to play and shows no clock
      await expect.soft(page.locator('#play')).toBeDisabled();
      await expect.soft(page.locator('#play .i-pause')).toBeHidden();
      await expect.soft(page.locator('#time')).not.toContainText('0.0 / 0.0 s');
      await shot(page, info, `${size.name}-1-empty`);

      // five warnings: every one reachable (shown, or behind "N more" that opens them), none covering another
      const warnings = await page.evaluate(() => window.emdm.notices().filter((n) => n.kind === 'warn').length);
      expect(warnings).toBeGreaterThanOrEqual(5);
      const more = page.locator('#notices .notices-more');
      // the ones not shown in full are counted on the "N more" button (the newest 3 show until their time is up)
      const folding = await page.evaluate(() => ({
        shown: [...document.querySelectorAll<HTMLElement>('#notices .notice')].filter((e) => e.checkVisibility()).length,
        all: document.querySelectorAll('#notices .notice').length,
        label: document.querySelector<HTMLElement>('#notices .notices-more')?.checkVisibility() ? document.querySelector('#notices .notices-more')!.textContent : '',
      }));
      expect.soft(folding.shown).toBeLessThanOrEqual(3);
      const folded = folding.all - folding.shown;
      expect.soft(folding.label).toBe(folded ? `${folded} more notice${folded === 1 ? '' : 's'}` : '');
      if (await more.isVisible()) await more.click();
      await expect.soft(page.locator('#notices .notice.warn')).toHaveCount(warnings);
      for (const n of await page.locator('#notices .notice.warn').all()) {
        await n.scrollIntoViewIfNeeded();
        await expect.soft(n).toBeVisible();
      }
      await shot(page, info, `${size.name}-1-notices-open`);

      // desktop: Generate and the downloads on screen, nothing scrolled
      if (size.desktop) {
        for (const sel of ['#generate', '#dl-bvh', '#dl-glb', '#dl-json']) expect.soft(await onScreen(page, sel)).toBe('');
        expect.soft(await page.evaluate(() => [scrollY, document.getElementById('panel')!.scrollTop])).toEqual([0, 0]);
      }

      // a motion, with "Show steps" on: the strip must be on screen, whole
      await page.locator('#mode-text').click();
      await page.locator('#show-steps').check();
      await page.evaluate((text) => window.emdm.generate({ mode: 'text', text, steps: 4, seconds: 4, seed: 7 }), PROMPT);
      await expect(page.locator('#play')).toBeEnabled();
      await expect(page.locator('#step-strip')).toBeVisible();
      if (size.desktop) expect.soft(await onScreen(page, '#step-strip .step-thumb:last-child'), 'the step strip, unscrolled').toBe('');
      await shot(page, info, `${size.name}-2-motion`);
      expect.soft(await checkWhilePlaying(page), 'layout while the motion plays').toEqual([]);

      // the notices opened: still nothing over the character
      if (await more.isVisible() && (await more.getAttribute('aria-expanded')) !== 'true') await more.click();
      await shot(page, info, `${size.name}-3-notices`);
      expect.soft(await layoutProblems(page), 'layout with the notices opened').toEqual([]);

      if (size.desktop) {
        for (const sel of ['#generate', '#dl-bvh', '#dl-glb', '#dl-json']) expect.soft(await onScreen(page, sel)).toBe('');
      }

      // each notice can be dismissed (the log keeps it)
      const count = await page.locator('#notices .notice').count();
      await page.locator('#notices .notice button').first().click();
      await expect(page.locator('#notices .notice')).toHaveCount(count - 1);
      expect(await page.evaluate(() => window.emdm.notices().filter((n) => n.kind === 'warn').length)).toBe(warnings);
      watch.assertClean();
    });

    test('compare view: both panels clear of both characters', async ({ page }, info) => {
      test.setTimeout(300_000);
      await skipWithoutDiffusion(page);
      const watch = watchPage(page);
      await open(page);
      await page.evaluate((text) => window.emdm.compare({ mode: 'text', text, steps: 20, seconds: 3, seed: 7 }), PROMPT);
      await expect(page.locator('#compare-panels')).toBeVisible();
      expect(await page.evaluate(() => window.emdm.characterRects().length)).toBe(2);
      await shot(page, info, `${size.name}-4-compare`);
      expect(await checkWhilePlaying(page), 'compare view while the motions play').toEqual([]);
      watch.assertClean();
    });
  });
}

test.describe('phone on load (390×844)', () => {
  test.use({ viewport: { width: 390, height: 844 } });

  test('the prompt box, the example chips, Generate and the character show without scrolling', async ({ page }, info) => {
    test.setTimeout(180_000);
    const watch = watchPage(page);
    await open(page);
    await shot(page, info, 'phone-0-load');
    for (const sel of ['#prompt', '#generate', '#examples .chip:first-child']) expect.soft(await onScreen(page, sel), sel).toBe('');
    // every example chip is on screen: none hides in a row that scrolls sideways
    const chips = await page.locator('#examples .chip').count();
    for (let i = 1; i <= chips; i++) expect.soft(await onScreen(page, `#examples .chip:nth-child(${i})`)).toBe('');
    const chars = await page.evaluate(() => window.emdm.characterRects());
    expect(chars.length).toBeGreaterThan(0);
    const stage = (await page.locator('#scene').boundingBox())!;
    for (const c of chars) expect.soft(c.y + c.height, 'the character inside the visible stage').toBeLessThanOrEqual(Math.min(844, stage.y + stage.height) + 1);
    expect(await page.evaluate(() => [scrollY, document.getElementById('panel')!.scrollTop])).toEqual([0, 0]);
    watch.assertClean();
  });
});

test.describe('a short phone on load (360×640)', () => {
  test.use({ viewport: { width: 360, height: 640 } });

  test('the prompt box and Generate show without scrolling (the model files list scrolls within three lines)', async ({ page }, info) => {
    test.setTimeout(180_000);
    await open(page);
    await shot(page, info, 'short-phone-load');
    for (const sel of ['#prompt', '#generate']) expect.soft(await onScreen(page, sel), sel).toBe('');
    expect(await page.evaluate(() => [scrollY, document.getElementById('panel')!.scrollTop])).toEqual([0, 0]);
  });
});

test.describe('a touch phone on load (390×844, a finger for a pointer)', () => {
  test.use({ viewport: { width: 390, height: 844 }, isMobile: true, hasTouch: true });

  test('the example chips are at least 28 px tall, and the prompt box and every chip still show without scrolling', async ({ page }) => {
    test.setTimeout(180_000);
    await open(page);
    expect(await page.evaluate(() => matchMedia('(pointer: coarse)').matches)).toBe(true);
    const heights = await page.locator('#examples .chip').evaluateAll((cs) => cs.map((c) => c.getBoundingClientRect().height));
    expect(Math.min(...heights)).toBeGreaterThanOrEqual(28);
    for (const sel of ['#prompt', '#generate']) expect.soft(await onScreen(page, sel), sel).toBe('');
    for (let i = 1; i <= heights.length; i++) expect.soft(await onScreen(page, `#examples .chip:nth-child(${i})`)).toBe('');
  });
});

test.describe('a phone held sideways (844×390)', () => {
  test.use({ viewport: { width: 844, height: 390 } });

  test('the stage takes most of the width and the scrubber can be dragged (it was 2 px beside a 230 px rail)', async ({ page }, info) => {
    test.setTimeout(180_000);
    await open(page);
    await page.evaluate(() => window.emdm.generate({ text: 'a person walks forward', steps: 2, seconds: 2 }));
    await shot(page, info, 'sideways-phone');
    const stage = (await page.locator('#scene').boundingBox())!;
    const scrub = (await page.locator('#scrub').boundingBox())!;
    expect(stage.width).toBeGreaterThan(844 / 2);
    expect(scrub.width).toBeGreaterThan(150);
    for (const sel of ['#scrub', '#play', '#generate']) expect.soft(await onScreen(page, sel), sel).toBe('');
    const chars = await page.evaluate(() => window.emdm.characterRects());
    for (const c of chars) expect.soft(c.x + c.width, 'the character inside the stage').toBeLessThanOrEqual(stage.x + stage.width + 1);
    expect(await page.evaluate(() => document.documentElement.scrollWidth)).toBeLessThanOrEqual(844);
  });
});

/**
 * What of the timeline panel's fields does not show whole: a select narrower than the same select sized to its
 * longest option (a copy with `width: auto` beside it: the browser's own measure, arrow included), a text field whose
 * value (or placeholder) is wider than its box (scrollWidth > clientWidth). One line per field; [] when all fit.
 */
async function truncatedTimelineFields(page: Page): Promise<string[]> {
  return page.evaluate(() => {
    const out: string[] = [];
    const name = (e: HTMLElement) => e.getAttribute('aria-label') ?? e.id ?? e.className;
    for (const s of document.querySelectorAll<HTMLSelectElement>('#edit-panel select')) {
      if (!s.checkVisibility()) continue;
      const copy = s.cloneNode(true) as HTMLSelectElement;
      copy.removeAttribute('id');
      copy.style.cssText = 'width: auto; min-width: 0; max-width: none; flex: none; position: absolute; visibility: hidden';
      s.parentElement!.append(copy);
      const need = copy.offsetWidth;
      copy.remove();
      if (s.offsetWidth + 0.5 < need) out.push(`select ${name(s)}: ${s.offsetWidth} px wide, its longest option needs ${need} px`);
    }
    for (const i of document.querySelectorAll<HTMLInputElement>('#edit-panel input[type="text"]')) {
      if (!i.checkVisibility()) continue;
      const had = i.value;
      i.value = had || i.placeholder; // an empty field: measure its placeholder as text
      if (i.scrollWidth > i.clientWidth) out.push(`input ${name(i)} "${i.value}": ${i.scrollWidth} px of text in ${i.clientWidth} px`);
      i.value = had;
    }
    return out;
  });
}

for (const vp of [{ width: 1280, height: 800 }, { width: 390, height: 844 }]) {
  test.describe(`timeline panel at ${vp.width}×${vp.height}`, () => {
    test.use({ viewport: vp });
    test('the prompt/action selectors and the edit prompts show whole', async ({ page }, info) => {
      const watch = watchPage(page);
      await open(page);
      await page.locator('#edit-panel summary').click();
      await expect(page.locator('#edit-panel details')).toHaveAttribute('open', '');
      await expect(page.locator('#tl-body-prompt')).toHaveValue('a person raises both hands');
      await page.locator('#edit-panel').scrollIntoViewIfNeeded();
      await page.locator('#edit-panel details').screenshot({ path: info.outputPath(`timeline-${vp.width}.png`) });
      expect(await truncatedTimelineFields(page)).toEqual([]);
      watch.assertClean();
    });
  });
}
