// Fuzzing what a visitor can hand the page (issue 29): seeded random mutations of a valid timeline link
// (web/ui/timeline-url.ts decodeTimeline, then src/edit.ts planTimeline) and of a valid character GLB
// (src/character/retarget/load.ts loadCharacter): truncation, byte flips, huge counts and lengths, 1e308 and
// non-numbers, deep nesting, bad JSON and bad chunk lengths. Each input must be read or refused with the
// module's own error (TimelineUrlError / EditError / CharacterLoadError), never a TypeError, a RangeError of the
// engine or a hang: no call may take a second. Each part runs for a bounded time (~5 s) from a fixed seed (FUZZ_SEED for others), and
// prints how many inputs it tried and how they ended.
import { describe, expect, it } from 'vitest';
import { CharacterLoadError, loadCharacter, readGlb } from '../../src/character/retarget/load';
import { writeGlb } from '../../src/export/glb';
import { EditError, planTimeline } from '../../src/edit';
import { TimelineUrlError, decodeTimeline } from '../../web/ui/timeline-url';
import { manifestSkeleton } from './coreFixtures';
import { RIGS, buildRigGlb } from './retargetRigs';

const BUDGET_MS = 5000;
/** FUZZ_SEED=<n> tries other inputs (a failure names its seed and case) */
const SEED = Number(process.env.FUZZ_SEED ?? 29);
const CALL_MS = 1000;

/** mulberry32: a small seeded generator, so a failure names the seed and case that reproduce it. */
function rng(seed: number) {
  let a = seed >>> 0;
  const next = () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
  return { next, int: (n: number) => Math.floor(next() * n), pick: <T>(xs: readonly T[]): T => xs[Math.floor(next() * xs.length)] };
}
type Rng = ReturnType<typeof rng>;

const HOSTILE: unknown[] = [1e308, -1e308, 0, -1, 2 ** 32, 2 ** 53 + 1, 1e-320, '1e308', 'NaN', null, true, '', 'x'.repeat(5000), [], {}, [[[[[[[[]]]]]]]], { a: 1 }];
const nest = (depth: number, inner: unknown): unknown => {
  let v = inner;
  for (let i = 0; i < depth; i++) v = [v];
  return v;
};

/** Set a random value somewhere in a JSON document (objects and arrays walked from the root) to a hostile one. */
function mutateJson(r: Rng, doc: unknown): unknown {
  if (doc === null || typeof doc !== 'object' || r.next() < 0.15) {
    const k = r.int(4);
    return k === 0 ? structuredClone(r.pick(HOSTILE)) : k === 1 ? nest(1 + r.int(1000), structuredClone(r.pick(HOSTILE))) : k === 2 ? Array.from({ length: r.int(300) }, () => structuredClone(r.pick(HOSTILE))) : undefined;
  }
  const keys = Array.isArray(doc) ? doc.map((_, i) => i) : Object.keys(doc);
  if (!keys.length) return structuredClone(r.pick(HOSTILE));
  const key = r.pick(keys as (string | number)[]);
  const box = doc as Record<string | number, unknown>;
  const v = mutateJson(r, box[key]);
  if (v === undefined) delete box[key];
  else box[key] = v;
  return doc;
}

/** A text mutation: cut, a character inserted or removed, a number replaced. */
function mutateText(r: Rng, s: string): string {
  const at = r.int(s.length + 1);
  switch (r.int(5)) {
    case 0: return s.slice(0, at);
    case 1: return s.slice(0, at) + r.pick(['[', ']', '{', '}', ',', '"', ':', 'NaN', '1e308', '-', '\\', '\u0000']) + s.slice(at);
    case 2: return s.slice(0, at) + s.slice(at + 1 + r.int(4));
    case 3: return s.replace(/-?\d+(\.\d+)?/, () => r.pick(['NaN', '1e308', '-1', '1e999', '0.0000001', '4294967296']));
    default: return `${'['.repeat(r.int(2000))}${s}${']'.repeat(r.int(2000))}`;
  }
}

function timed<T>(what: string, f: () => T): T {
  const t0 = performance.now();
  const out = f();
  const ms = performance.now() - t0;
  if (ms > CALL_MS) throw new Error(`${what} took ${ms.toFixed(0)} ms (over ${CALL_MS} ms)`);
  return out;
}

describe('fuzz: a hostile timeline link or character file is read or refused with its own error, quickly', () => {
  it('timeline links (decodeTimeline, then planTimeline)', () => {
    const actions = ['walk', 'bow'];
    const valid = JSON.stringify([['a person walks forward', 4, 1], [{ a: 'bow' }, 2.5, 77], ['a person waves', 3, 4294967295]]);
    const r = rng(SEED);
    const counts = { read: 0, refusedUrl: 0, refusedPlan: 0 };
    const t0 = performance.now();
    let n = 0;
    for (; performance.now() - t0 < BUDGET_MS; n++) {
      let value: string;
      if (r.next() < 0.5) {
        value = valid;
        for (let k = 1 + r.int(3); k > 0; k--) value = mutateText(r, value);
      } else {
        const doc = JSON.parse(valid) as unknown[];
        if (r.next() < 0.1) for (let k = r.int(300); k > 0; k--) doc.push(['walk', 0.1, k]);
        value = JSON.stringify(mutateJson(r, doc)) ?? 'undefined';
      }
      const where = `seed ${SEED}, case ${n}: ${value.slice(0, 80)}`;
      try {
        const segs = timed(`decodeTimeline (${where})`, () => decodeTimeline(value, actions));
        timed(`planTimeline (${where})`, () => planTimeline(segs, { fps: 20, maxFrames: 196 }));
        counts.read++;
      } catch (e) {
        if (e instanceof TimelineUrlError) counts.refusedUrl++;
        else if (e instanceof EditError) counts.refusedPlan++;
        else throw new Error(`${where}: ${(e as Error)?.name}: ${(e as Error)?.message}`);
      }
    }
    console.log(`[fuzz timeline] ${n} links in ${BUDGET_MS} ms: ${counts.read} read, ${counts.refusedUrl} refused by decodeTimeline, ${counts.refusedPlan} by planTimeline`);
    expect(counts.read).toBeGreaterThan(0);
    expect(counts.refusedUrl).toBeGreaterThan(0);
    expect(counts.refusedPlan).toBeGreaterThan(0);
  });

  it('character GLB files (loadCharacter: GLB header and chunks, JSON, buffers, rig)', async () => {
    const glb = buildRigGlb(manifestSkeleton(), RIGS[0]);
    const r = rng(SEED + 1);
    const counts: Record<string, number> = { loaded: 0 };
    const t0 = performance.now();
    let n = 0;
    for (; performance.now() - t0 < BUDGET_MS; n++) {
      let bytes: Uint8Array;
      const kind = r.int(4);
      if (kind === 0) bytes = glb.slice(0, r.int(glb.length)); // truncated
      else if (kind === 1) { // bytes flipped, header and chunk lengths included
        bytes = glb.slice();
        const dv = new DataView(bytes.buffer);
        for (let k = 1 + r.int(4); k > 0; k--) {
          if (r.next() < 0.5) dv.setUint32(r.pick([8, 12, 16]), r.pick([0, 1, 7, 0xffffffff, 0x7fffffff, glb.length + 4, r.int(glb.length)]), true);
          else bytes[r.int(bytes.length)] = r.int(256);
        }
      } else if (kind === 2) { // the document mutated (counts, transforms, nesting), then written back as a GLB
        const { json, bin } = readGlb(glb, 'x');
        let doc: unknown = json;
        for (let k = 1 + r.int(3); k > 0; k--) doc = mutateJson(r, doc);
        bytes = writeGlb((doc && typeof doc === 'object' ? doc : { value: doc }) as Record<string, unknown>, bin!);
      } else { // the JSON text mutated (bad JSON, NaN, nesting) with its chunk length as written
        const { json, bin } = readGlb(glb, 'x');
        const d = r.int(100_000); // nesting far past any stack: JSON.parse takes it, a recursive walk would not
        const text = r.next() < 0.3 ? JSON.stringify(json).replace('{', `{"extras":${'['.repeat(d)}${']'.repeat(d)},`) : mutateText(r, JSON.stringify(json));
        bytes = writeGlb({}, bin!);
        const enc = new TextEncoder().encode(text);
        const pad = (4 - (enc.length % 4)) % 4;
        const out = new Uint8Array(20 + enc.length + pad + (bytes.length - 20 - 4));
        out.set(bytes.subarray(0, 12));
        const dv = new DataView(out.buffer);
        dv.setUint32(8, out.length, true);
        dv.setUint32(12, enc.length + pad, true);
        dv.setUint32(16, 0x4e4f534a, true);
        out.set(enc, 20);
        out.fill(0x20, 20 + enc.length, 20 + enc.length + pad);
        out.set(bytes.subarray(24), 20 + enc.length + pad);
        bytes = out;
      }
      const where = `seed ${SEED} (+1), case ${n} (mutation ${kind}, ${bytes.length} bytes)`;
      const c0 = performance.now();
      try {
        await loadCharacter([{ name: 'fuzz.glb', data: bytes }], { textures: false });
        counts.loaded++;
      } catch (e) {
        if (!(e instanceof CharacterLoadError)) throw new Error(`${where}: ${(e as Error)?.name}: ${(e as Error)?.message}`);
        counts[e.reason] = (counts[e.reason] ?? 0) + 1;
      }
      const ms = performance.now() - c0;
      if (ms > CALL_MS) throw new Error(`${where}: loadCharacter took ${ms.toFixed(0)} ms (over ${CALL_MS} ms)`);
    }
    console.log(`[fuzz glb] ${n} files in ${BUDGET_MS} ms: ${Object.entries(counts).map(([k, v]) => `${v} ${k}`).join(', ')}`);
    expect(counts.loaded).toBeGreaterThan(0);
    expect(counts.corrupt).toBeGreaterThan(0);
  }, 30_000);
});
