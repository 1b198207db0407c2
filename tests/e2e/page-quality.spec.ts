// The lowered rendering quality (issue 30): when frames are slow the page drops to half resolution and then turns
// the shadow map off (web/ui/stage.ts adapt); `?quality=low` starts there. The character must still stand on a
// visible floor: the floor beside it differs from the sky, and a contact shadow darkens the floor under its feet,
// at rest and after a generated motion has moved it. Pixels are read from a screenshot of the page.
import { expect, test, type Page } from '@playwright/test';
import { watchPage } from './helpers';

test.use({ viewport: { width: 1280, height: 800 } });

interface Lum { under: number; side: number; sky: number }

/**
 * Mean luminance (0–255) of three boxes of the page as shown: just below the character's feet (centre third of its
 * width, 2–8 px under its lowest point), the floor at the same height one character width or more to its left, and
 * the sky at the same x near the top of the stage.
 */
async function floorLuminance(page: Page): Promise<Lum> {
  const [c] = await page.evaluate(() => window.emdm.characterRects());
  const stage = (await page.locator('#scene').boundingBox())!;
  const png = (await page.screenshot()).toString('base64');
  return page.evaluate(async ({ png, c, stage }) => {
    const img = new Image();
    img.src = `data:image/png;base64,${png}`;
    await img.decode();
    const cv = document.createElement('canvas');
    cv.width = img.width;
    cv.height = img.height;
    const g = cv.getContext('2d')!;
    g.drawImage(img, 0, 0);
    const mean = (x0: number, y0: number, w: number, h: number) => {
      const d = g.getImageData(Math.round(x0), Math.round(y0), Math.round(w), Math.round(h)).data;
      let s = 0;
      for (let i = 0; i < d.length; i += 4) s += 0.2126 * d[i] + 0.7152 * d[i + 1] + 0.0722 * d[i + 2];
      return s / (d.length / 4);
    };
    const bottom = c.y + c.height;
    const sideX = Math.max(stage.x + 4, c.x - 1.4 * c.width);
    return {
      under: mean(c.x + c.width / 3, bottom + 2, c.width / 3, 6),
      side: mean(sideX, bottom + 2, c.width / 3, 6),
      sky: mean(sideX, stage.y + 0.1 * stage.height, c.width / 3, 8),
    };
  }, { png, c, stage });
}

test('quality=low: half resolution, no shadow map, and the character still stands on a visible floor', async ({ page }) => {
  test.setTimeout(180_000);
  const watch = watchPage(page);
  await page.goto('/?noauto=1&backend=wasm&quality=low&steps=4&seconds=2');
  await page.waitForFunction(() => window.emdm?.ready === true, null, { timeout: 120_000 });
  expect(await page.evaluate(() => window.emdm.quality())).toEqual({ pixelRatio: 0.5, shadows: false });
  expect(await page.evaluate(() => window.emdm.notices().map((n) => n.text).join('\n'))).not.toContain('quality');
  await page.waitForTimeout(500);
  const atRest = await floorLuminance(page);
  console.log('luminance at rest (under the feet, floor beside, sky):', JSON.stringify(atRest));
  expect(atRest.side - atRest.sky, 'the floor beside the character is lighter than the sky').toBeGreaterThan(6);
  expect(atRest.under, 'the floor under the feet is darkened by the contact shadow').toBeLessThan(atRest.side * 0.85);

  // a motion that moves the character: the shadow goes with it
  await page.evaluate(() => window.emdm.generate({ mode: 'text', text: 'a person walks forward', steps: 4, seconds: 2, seed: 3 }));
  await page.evaluate(() => window.emdm.seek(1.9, false));
  await page.waitForTimeout(1500); // the camera's follow lag settles
  const moved = await floorLuminance(page);
  console.log('luminance after a walk (under, beside, sky):', JSON.stringify(moved));
  expect(moved.under).toBeLessThan(moved.side * 0.85);
  watch.assertClean();
});
