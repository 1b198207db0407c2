import { describe, expect, it } from 'vitest';
import { SeededRandom, splitmix32 } from '../../src/sampler/rng';

describe('seeded RNG (splitmix32 → sfc32, Box–Muller)', () => {
  it('splitmix32 reproduces the reference sequence for seed 0', () => {
    // first outputs of the public-domain splitmix32 (a += 0x9e3779b9; two xorshift-multiply rounds)
    const g = splitmix32(0);
    const got = [g(), g(), g()];
    // recompute independently with BigInt arithmetic
    let a = 0n;
    const ref: number[] = [];
    for (let i = 0; i < 3; i++) {
      a = (a + 0x9e3779b9n) & 0xffffffffn;
      let t = a ^ (a >> 16n);
      t = (t * 0x21f0aaadn) & 0xffffffffn;
      t ^= t >> 15n;
      t = (t * 0x735a2d97n) & 0xffffffffn;
      t ^= t >> 15n;
      ref.push(Number(t));
    }
    expect(got).toEqual(ref);
  });

  it('same seed gives the same numbers; different seeds differ', () => {
    const a = new SeededRandom(42).normals(1000);
    const b = new SeededRandom(42).normals(1000);
    const c = new SeededRandom(43).normals(1000);
    expect(Buffer.from(a.buffer).equals(Buffer.from(b.buffer))).toBe(true);
    expect(Buffer.from(a.buffer).equals(Buffer.from(c.buffer))).toBe(false);
  });

  it('draws standard normal values (mean 0, variance 1, symmetric tails)', () => {
    const n = 200_000;
    const x = new SeededRandom(7).normals(n);
    let m = 0;
    let v = 0;
    let beyond2 = 0;
    for (const xi of x) m += xi;
    m /= n;
    for (const xi of x) {
      v += (xi - m) ** 2;
      if (Math.abs(xi) > 1.959964) beyond2++;
    }
    v /= n;
    expect(Math.abs(m)).toBeLessThan(0.01);
    expect(Math.abs(v - 1)).toBeLessThan(0.015);
    expect(beyond2 / n).toBeGreaterThan(0.045);
    expect(beyond2 / n).toBeLessThan(0.055);
  });

  it('splitting one draw into several calls gives the same stream', () => {
    const whole = new SeededRandom(9).normals(11);
    const r = new SeededRandom(9);
    const parts = [...r.normals(3), ...r.normals(5), ...r.normals(3)];
    expect(Array.from(whole)).toEqual(parts);
  });

  it('rejects seeds that are not uint32', () => {
    expect(() => new SeededRandom(-1)).toThrow(/seed must be an integer/);
    expect(() => new SeededRandom(1.5)).toThrow(/seed must be an integer/);
  });
});
