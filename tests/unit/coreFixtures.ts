// Reader of the parity fixtures written by `python -m emdm.fixtures` (tests/fixtures/parity/).
import crypto from 'node:crypto';
import fs from 'node:fs';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import type { Manifest } from '../../src/manifest';
import type { NoiseSource } from '../../src/sampler/sampler';
import { buildTinyManifest } from '../fixtures/parity/tinyManifest';

export const ROOT = path.resolve(path.dirname(fileURLToPath(import.meta.url)), '..', '..');
// overridable to check another export, e.g. `python -m emdm.fixtures --models-dir D --out P`, then
// EMDM_MODELS_DIR=D EMDM_PARITY_DIR=P npx vitest run tests/unit/coreGenerate.test.ts
export const PARITY_DIR = process.env.EMDM_PARITY_DIR ?? path.join(ROOT, 'tests', 'fixtures', 'parity');
export const MODELS_DIR = process.env.EMDM_MODELS_DIR ?? path.join(ROOT, 'public', 'models');

/** A new models folder under `parent` with the tiny step model as an 8-action model (labels a…h; mean 0,
 * std 1 except the root height, or `meanStd`: e.g. the parity fixtures' tiny.meanstd.f32), its manifest listing the
 * files with their sha256. */
export function tinyModels(parent: string, meanStd?: Buffer): { dir: string; manifest: Manifest } {
  const sha = (b: Buffer) => crypto.createHash('sha256').update(b).digest('hex');
  const onnx = fs.readFileSync(path.join(PARITY_DIR, 'tiny-step.onnx'));
  const ms = new Float32Array(2 * 263);
  ms.fill(1, 263);
  ms[3] = 0.9; // mean root height
  const msBuf = meanStd ?? Buffer.from(ms.buffer);
  const real = JSON.parse(fs.readFileSync(path.join(MODELS_DIR, 'manifest.json'), 'utf8'));
  const manifest = buildTinyManifest(
    real.skeleton,
    { path: 'tiny.onnx', bytes: onnx.length, sha256: sha(onnx) },
    { path: 'tiny.meanstd.f32', bytes: msBuf.length, sha256: sha(msBuf) },
  );
  const dir = fs.mkdtempSync(path.join(parent, 'models-'));
  fs.writeFileSync(path.join(dir, 'tiny.onnx'), onnx);
  fs.writeFileSync(path.join(dir, 'tiny.meanstd.f32'), msBuf);
  fs.writeFileSync(path.join(dir, 'manifest.json'), JSON.stringify(manifest));
  return { dir: dir + '/', manifest };
}

export interface FixtureCase {
  meta: Record<string, unknown> & { frames: number; schedule?: { time: number[]; coef1: number[]; coef2: number[]; sigma: number[] } };
  has(name: string): boolean;
  get(name: string): Float32Array;
  shape(name: string): number[];
}

export function fixtureExists(name: string): boolean {
  return fs.existsSync(path.join(PARITY_DIR, `${name}.json`));
}

/** Names of the model parity cases present (model-<name>), from index.json. */
export function modelFixtures(): string[] {
  const p = path.join(PARITY_DIR, 'index.json');
  if (!fs.existsSync(p)) return [];
  return Object.keys(JSON.parse(fs.readFileSync(p, 'utf8')).cases ?? {}).filter((k) => k.startsWith('model-') && fixtureExists(k));
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

/** The reference skeleton from public/models/manifest.json (written by emdm.manifest from emdm.skeleton). */
export function manifestSkeleton(): { joints: string[]; parents: number[]; offsets: number[][]; footJoints: number[]; fps: number } {
  const p = path.join(MODELS_DIR, 'manifest.json');
  const m = JSON.parse(fs.readFileSync(p, 'utf8'));
  if (!m.skeleton?.joints) throw new Error(`${p}: no skeleton section`);
  return m.skeleton;
}

/** A deterministic pseudo-random local pose: small random rotations (incl. twist) on every joint. */
export function randomPoseQuats(frames: number, J: number, seed: number, amp = 0.6): Float32Array {
  let s = seed >>> 0;
  const rnd = () => ((s = (Math.imul(s, 1664525) + 1013904223) >>> 0) / 4294967296) * 2 - 1;
  const q = new Float32Array(frames * J * 4);
  const base = Array.from({ length: J }, () => [rnd(), rnd(), rnd()]);
  for (let f = 0; f < frames; f++) {
    for (let j = 0; j < J; j++) {
      const ph = f / 10;
      const ax = base[j].map((b, k) => amp * (b + 0.3 * Math.sin(ph + k + j)));
      const ang = Math.hypot(ax[0], ax[1], ax[2]);
      const sn = ang > 0 ? Math.sin(ang / 2) / ang : 0;
      q.set([ax[0] * sn, ax[1] * sn, ax[2] * sn, Math.cos(ang / 2)], (f * J + j) * 4);
    }
  }
  return q;
}

/** Noise supplied from the fixture, checking the documented draw order as it goes. */
export function fixtureNoise(fx: FixtureCase): NoiseSource & { calls: string[] } {
  const calls: string[] = [];
  return {
    calls,
    normals(n, what, k) {
      const key = what === 'xT' ? 'x_T' : `${what}_${k}`;
      calls.push(key);
      const a = fx.get(key);
      if (a.length !== n) throw new Error(`fixture ${key}: ${a.length} values, sampler asked for ${n}`);
      return a;
    },
  };
}

