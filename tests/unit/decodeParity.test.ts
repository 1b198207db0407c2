// tests/fixtures/parity/decode.* is written by `python -m emdm.motion.decode_fixture` (emdm.motion.decode): the
// benchmarks judge the motion the page shows, so Python's decoding (smoothing σ = 1, foot clean-up) must be the page's.
import { describe, expect, it } from 'vitest';
import { decodeJoints } from '../../src/motion/decode';
import { loadCase, manifestSkeleton, maxAbsDiff } from './coreFixtures';

describe("the page's decoding is Python's (emdm.motion.decode, fixture tests/fixtures/parity/decode.*)", () => {
  const fx = loadCase('decode');
  const sk = manifestSkeleton();
  const cases = fx.meta.cases as Record<string, { frames: number }>;
  const modes = fx.meta.modes as Record<string, { smooth: boolean; footCleanup: boolean; loop?: boolean }>;
  for (const [name, { frames }] of Object.entries(cases)) {
    for (const [mode, o] of Object.entries(modes)) {
      it(`${name}, ${mode}: decodeJoints within 1e-5 m of decode_joints`, () => {
        const got = decodeJoints(fx.get(`${name}_features`), frames, { parents: sk.parents, footJoints: sk.footJoints }, o);
        const want = fx.get(`${name}_${mode}`);
        // both compute in float64 from the same float32 input; a changed rule (σ, blend, threshold) moves cm
        expect(maxAbsDiff(got, want)).toBeLessThan(1e-5);
      });
    }
  }
  it('the contacts case moves the feet: cleaned joints differ from smoothed ones by centimetres', () => {
    expect(maxAbsDiff(fx.get('contacts_both'), fx.get('contacts_smooth'))).toBeGreaterThan(0.03);
  });
});
