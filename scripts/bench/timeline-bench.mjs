#!/usr/bin/env node
// Issue 14's time bar on the library in Node (ORT-web WASM, no page drawing beside it): a 3 × 5 s timeline
// (generateTimeline with the generator's begin, as the page runs it) against one 5 s motion (generate), interleaved
// after a warm-up, medians; also the same timeline with its windows run in turn (no begin). Each (thread count,
// file) runs in a fresh process: ORT's thread count is global. Conditions are fixed random vectors, so the text
// encoder is not timed.
//
//   node scripts/bench/timeline-bench.mjs                          # threads 1,2 × files int8,fp32, 7 reps
//   node scripts/bench/timeline-bench.mjs --threads 2 --variants fp16 --reps 9 --json out.json
import { spawnSync } from 'node:child_process';
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { fileURLToPath } from 'node:url';
import { ROOT, cli, withLibrary } from './common.mjs';

const { args, opt } = cli();
const MODEL = opt('model', 'emdm-t2m-web');
const reps = Number(opt('reps', '7'));

async function one(threads, variant) {
  return withLibrary(async (load) => {
    const { openModel } = await load('src/openModel.ts');
    const { loadManifest } = await load('src/manifest.ts');
    const { generateTimeline } = await load('src/edit.ts');
    const { SeededRandom } = await load('src/sampler/rng.ts');
    const dir = path.join(ROOT, 'public', 'models') + '/';
    const manifest = await loadManifest(dir);
    const entry = manifest.models[MODEL];
    const g = await openModel({ manifest, baseUrl: dir, model: MODEL, variant: variant === 'fp32' ? undefined : variant, backend: 'wasm', threads });
    const C = entry.condition.dim;
    const vec = (p) => new SeededRandom(p.length * 7919 + p.charCodeAt(0)).normals(C).map((v) => v * 0.05);
    const o = { steps: entry.defaultSteps, guidance: entry.guidance };
    const gen = async (r) => (await g.generate({ ...o, condition: { type: 'vector', vector: vec(r.prompt) }, frames: r.frames, seed: r.seed, known: r.known, resume: r.resume })).motion;
    const begin = (rs) => g.begin(rs.map((r) => ({ ...o, condition: { type: 'vector', vector: vec(r.prompt) }, frames: r.frames, seed: r.seed, stopAt: r.stopAt, ...(r.keep ? { known: { keep: r.keep, fromTime: r.keepFromTime } } : {}) })));
    const limits = { fps: entry.fps, maxFrames: entry.maxFrames };
    const segs = (s) => ['a person walks', 'a person raises both hands', 'a person climbs'].map((prompt, k) => ({ prompt, seconds: 5, seed: s + k }));
    const time = async (f) => {
      const t0 = performance.now();
      await f();
      return performance.now() - t0;
    };
    for (let i = 0; i < 2; i++) {
      await gen({ prompt: 'warm', frames: 100, seed: i });
      await generateTimeline(segs(i), gen, limits, { begin });
    }
    const r = { single: [], begun: [], inTurn: [] };
    for (let i = 0; i < reps; i++) {
      r.single.push(await time(() => gen({ prompt: 'a person walks', frames: 100, seed: 10 + i })));
      r.begun.push(await time(() => generateTimeline(segs(100 + i), gen, limits, { begin })));
      r.inTurn.push(await time(() => generateTimeline(segs(100 + i), gen, limits)));
    }
    const med = (a) => [...a].sort((x, y) => x - y)[a.length >> 1];
    const out = { threads, variant, batchesExactly: g.batchesExactly, singleMs: med(r.single), timelineMs: med(r.begun), inTurnMs: med(r.inTurn) };
    await g.dispose();
    return { ...out, ratio: out.timelineMs / out.singleMs, inTurnRatio: out.inTurnMs / out.singleMs };
  });
}

if (args[0] === '--one') {
  process.stdout.write(JSON.stringify(await one(Number(args[1]), args[2])) + '\n');
} else {
  const rows = [];
  for (const threads of opt('threads', '1,2').split(',').map(Number)) {
    for (const variant of opt('variants', 'int8,fp32').split(',')) {
      const p = spawnSync(process.execPath, [fileURLToPath(import.meta.url), '--one', String(threads), variant, '--reps', String(reps), '--model', MODEL], { encoding: 'utf8' });
      if (p.status !== 0) throw new Error(`timeline-bench (${threads} threads, ${variant}): ${p.stderr}`);
      const row = JSON.parse(p.stdout.trim().split('\n').at(-1));
      rows.push(row);
      console.log(`${MODEL} ${variant.padEnd(4)} ${threads} thread(s): one 5 s motion ${row.singleMs.toFixed(0)} ms; 3 × 5 s timeline ${row.timelineMs.toFixed(0)} ms = ${row.ratio.toFixed(2)}× `
        + `(${row.batchesExactly ? 'windows begun together' : 'windows begun one by one: the file quantises per call'}); in turn ${row.inTurnMs.toFixed(0)} ms = ${row.inTurnRatio.toFixed(2)}×`);
    }
  }
  const figures = { source: 'scripts/bench/timeline-bench.mjs', runtime: 'Node, ORT-web WASM', model: MODEL, reps, cpus: os.cpus().length, cpu: os.cpus()[0]?.model, load: os.loadavg()[0], rows };
  const json = opt('json', null);
  if (json) fs.writeFileSync(json, JSON.stringify(figures, null, 1));
}
