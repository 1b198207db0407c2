// Reader of the parity fixtures written by `python -m emdm.fixtures` (tests/fixtures/parity/).
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
export const PARITY_DIR = path.join(ROOT, 'tests', 'fixtures', 'parity');
export const MODELS_DIR = path.join(ROOT, 'public', 'models');

export interface FixtureCase {
  meta: Record<string, unknown> & { frames: number; schedule?: { time: number[]; coef1: number[]; coef2: number[]; sigma: number[] } };
  has(name: string): boolean;
  get(name: string): Float32Array;
  shape(name: string): number[];
}

export function fixtureExists(name: string): boolean {
  return fs.existsSync(path.join(PARITY_DIR, `${name}.json`));
}

export function loadCase(name: string): FixtureCase {
  const jsonPath = path.join(PARITY_DIR, `${name}.json`);
  const meta = JSON.parse(fs.readFileSync(jsonPath, 'utf8'));
  const bin = fs.readFileSync(path.join(PARITY_DIR, meta.bin));
  const table = meta.arrays as Record<string, { offset: number; shape: number[] }>;
  return {
    meta,
    has: (k) => k in table,
    shape: (k) => table[k].shape,
    get(k) {
      const e = table[k];
      if (!e) throw new Error(`${jsonPath}: no array '${k}'`);
      const n = e.shape.reduce((a, b) => a * b, 1);
      const out = new Float32Array(n);
      const dv = new DataView(bin.buffer, bin.byteOffset + e.offset, n * 4);
      for (let i = 0; i < n; i++) out[i] = dv.getFloat32(4 * i, true);
      return out;
    },
  };
}

export function maxAbsDiff(a: ArrayLike<number>, b: ArrayLike<number>): number {
  if (a.length !== b.length) throw new Error(`length ${a.length} != ${b.length}`);
  let m = 0;
  for (let i = 0; i < a.length; i++) m = Math.max(m, Math.abs(a[i] - b[i]));
  return m;
}

/** Max per-joint Euclidean distance between two (frames × 22 × 3) arrays. */
export function maxJointDist(a: ArrayLike<number>, b: ArrayLike<number>): number {
  if (a.length !== b.length) throw new Error(`length ${a.length} != ${b.length}`);
  let m = 0;
  for (let i = 0; i < a.length; i += 3) {
    m = Math.max(m, Math.hypot(a[i] - b[i], a[i + 1] - b[i + 1], a[i + 2] - b[i + 2]));
  }
  return m;
}
