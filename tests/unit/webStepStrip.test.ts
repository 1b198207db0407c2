// The "show steps" thumbnails: the front-view projection of one frame's joints (web/ui/step-strip.ts).
import { describe, expect, it } from 'vitest';
import { STRIP_HEIGHT_M, frontStickFigure } from '../../web/ui/step-strip';

describe('frontStickFigure', () => {
  // 3 joints: root, a child 1 m above it, a child of that 0.5 m to +x; 2 frames, the second shifted
  const parents = [-1, 0, 1];
  const joints = Float32Array.from([
    0, 0, 0, 0, 1, 0, 0.5, 1, 0.3, // frame 0
    2, 0.2, 5, 2, 1.2, 5, 1.5, 1.2, 5, // frame 1: root at x = 2, mirrored arm (−x)
  ]);
  const W = 40;
  const H = 2 * 4 + 100 * STRIP_HEIGHT_M; // 100 px per metre with pad 4

  it('draws one line per bone, root centred, floor at the bottom, +x to the right, depth ignored', () => {
    const s = frontStickFigure(joints, 2, 0, parents, W, H);
    expect(s).toHaveLength(2);
    expect(s[0]).toEqual([20, H - 4, 20, H - 4 - 100]);
    expect(s[1][0]).toBe(20);
    expect(s[1][2]).toBeCloseTo(70, 4);
    expect(s[1][3]).toBeCloseTo(H - 4 - 100, 4);
  });

  it('reads the asked frame and centres it on its own root', () => {
    const s = frontStickFigure(joints, 2, 1, parents, W, H);
    expect(s[0][0]).toBe(20);
    expect(s[0][1]).toBeCloseTo(H - 4 - 20, 4);
    expect(s[1][2]).toBeCloseTo(-30, 4); // 0.5 m to −x of the root: left of centre (and off this small canvas)
  });

  it('says what is wrong with the input', () => {
    expect(() => frontStickFigure(joints, 3, 0, parents, W, H)).toThrow(/expected frames 3 × 3 joints × 3/);
    expect(() => frontStickFigure(joints, 2, 2, parents, W, H)).toThrow(/frame 2 outside 0…1/);
  });
});
