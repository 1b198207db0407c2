/**
 * Seeded random numbers that are bit-identical in every JavaScript engine we target (Node and
 * Chromium run the same V8 + fdlibm math, and every operation below is IEEE-754 float64).
 *
 * Algorithm (documented so other implementations can reproduce it):
 *  - seeding: splitmix32 (Vigna's splitmix64 constants adapted to 32 bits, as in the well-known
 *    `splitmix32` of bryc/code) is run from the 32-bit seed to produce the four sfc32 state words;
 *    sfc32 is then advanced 12 times to mix the state.
 *  - uniform: sfc32 (Chris Doty-Humphrey's Small Fast Counting generator, 32-bit) gives uint32 u;
 *    a uniform in the open interval (0, 1) is (u + 0.5) / 2^32 (float64, never 0 or 1).
 *  - Gaussian: Box–Muller in float64 on two consecutive uniforms u1, u2:
 *    r = sqrt(-2 ln u1), θ = 2π u2, giving r·cos θ then r·sin θ (both used, in that order);
 *    values are cast to float32 when written into a Float32Array.
 */

export function splitmix32(seed: number): () => number {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x9e3779b9) | 0;
    let t = a ^ (a >>> 16);
    t = Math.imul(t, 0x21f0aaad);
    t = t ^ (t >>> 15);
    t = Math.imul(t, 0x735a2d97);
    t = t ^ (t >>> 15);
    return t >>> 0;
  };
}

const TWO_POW_32 = 4294967296;

/** A SeededRandom's state (`state()`, `SeededRandom.fromState`): plain numbers, so it can be posted to a worker. */
export interface RandomState {
  seed: number;
  words: number[];
  spare: number | null;
}

export class SeededRandom {
  private a: number;
  private b: number;
  private c: number;
  private d: number;
  private spare: number | null = null;
  readonly seed: number;

  constructor(seed: number) {
    if (!Number.isInteger(seed) || seed < 0 || seed > 0xffffffff) {
      throw new RangeError(`SeededRandom: seed must be an integer in [0, 2^32 - 1], got ${seed}`);
    }
    this.seed = seed;
    const sm = splitmix32(seed);
    this.a = sm();
    this.b = sm();
    this.c = sm();
    this.d = sm();
    for (let i = 0; i < 12; i++) this.nextUint32();
  }

  /** Where the generator stands: its seed, the four sfc32 words and the Box–Muller half kept for the next call. */
  state(): RandomState {
    return { seed: this.seed, words: [this.a, this.b, this.c, this.d], spare: this.spare };
  }

  /** A generator that goes on exactly where `state()` was taken (a sampling run resumed in another call or thread). */
  static fromState(s: RandomState): SeededRandom {
    const ok = s && Array.isArray(s.words) && s.words.length === 4 && s.words.every((w) => Number.isInteger(w) && w >= -0x80000000 && w <= 0xffffffff)
      && (s.spare === null || Number.isFinite(s.spare));
    if (!ok) throw new RangeError(`SeededRandom.fromState: expected { seed, words: four 32-bit integers, spare: a number or null }, got ${JSON.stringify(s)}`);
    const r = new SeededRandom(s.seed);
    [r.a, r.b, r.c, r.d] = s.words.map((w) => w | 0);
    r.spare = s.spare;
    return r;
  }

  /** sfc32: the next unsigned 32-bit integer. */
  nextUint32(): number {
    const t = (((this.a + this.b) | 0) + this.d) | 0;
    this.d = (this.d + 1) | 0;
    this.a = this.b ^ (this.b >>> 9);
    this.b = (this.c + (this.c << 3)) | 0;
    this.c = (this.c << 21) | (this.c >>> 11);
    this.c = (this.c + t) | 0;
    return t >>> 0;
  }

  /** Uniform in the open interval (0, 1). */
  uniform(): number {
    return (this.nextUint32() + 0.5) / TWO_POW_32;
  }

  /** One standard normal value (float64), Box–Muller; the sine half is kept for the next call. */
  normal(): number {
    if (this.spare !== null) {
      const s = this.spare;
      this.spare = null;
      return s;
    }
    const u1 = this.uniform();
    const u2 = this.uniform();
    const r = Math.sqrt(-2 * Math.log(u1));
    const theta = 2 * Math.PI * u2;
    this.spare = r * Math.sin(theta);
    return r * Math.cos(theta);
  }

  /** n standard normal values as float32. */
  normals(n: number): Float32Array {
    const out = new Float32Array(n);
    for (let i = 0; i < n; i++) out[i] = this.normal();
    return out;
  }
}
