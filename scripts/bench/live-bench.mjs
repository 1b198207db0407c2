#!/usr/bin/env node
// Issue 33's bars for the library's live stream in Node (generator.live with the page's defaults: the shipped
// emdm-t2m-web, its default file (int8) and steps, text prompts through its encoder, onnxruntime-web WASM in-process,
// 1 thread). Real time, wall clock; frames pulled every 50 ms as a page's animation loop would.
//   1. window cost: the median time of one live window (C + W frames) at the chosen steps, after a warm-up
//   2. a stream with prompts at random moments (every 3–7 s) for --seconds: prompt → first new frame latency
//      (median, 95th percentile)
//   3. a 2-minute stream with a prompt every 5 s: underruns, frames repeated for lack of motion
//   Seams over both runs' prompt changes: the largest joint acceleration over each blend's eased span against the
//   95th percentile of the played motion elsewhere (record(): what was played, world coordinates).
//
//   node scripts/bench/live-bench.mjs                    # defaults: --seconds 180 --steady 120, the page's steps (10)
//   node scripts/bench/live-bench.mjs --json docs/results/json/live-emdm-t2m-web-node-wasm.json   # then python -m emdm.eval.report
//   node scripts/bench/live-bench.mjs --steps 6 --prompt-lead 8 --seconds 60
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { ROOT, cli, withLibrary } from './common.mjs';

const { opt } = cli();
const MODEL = 'emdm-t2m-web';
const seconds = Number(opt('seconds', '180'));
const steadySeconds = Number(opt('steady', '120'));
const steps = opt('steps') ? Number(opt('steps')) : undefined;
const settings = Object.fromEntries(['window', 'lead', 'prompt-lead'].filter((k) => opt(k)).map((k) => [k === 'prompt-lead' ? 'promptLead' : k, Number(opt(k))]));
const PROMPTS = ['a person walks forward', 'a person waves with the right hand', 'a person raises both hands', 'a person runs forward',
  'a person squats down', 'a person walks backward', 'a person turns around', 'a person jumps', 'a person bows', 'a person kicks'];
const sleep = (ms) => new Promise((r) => setTimeout(r, ms));
const q = (a, p) => {
  const s = [...a].sort((x, y) => x - y);
  const pos = p * (s.length - 1);
  const lo = Math.floor(pos);
  return s[lo] + (s[Math.min(lo + 1, s.length - 1)] - s[lo]) * (pos - lo);
};
let rng = 12345;
const rand = () => ((rng = (rng * 1103515245 + 12345) >>> 0) / 2 ** 32);

/** Run a live stream for `secs` seconds with prompts at the times `nextGap()` gives; frames pulled every 50 ms. */
async function runStream(g, secs, nextGap) {
  const s = await g.live({ prompt: PROMPTS[0], seed: 1, steps, recordSeconds: secs + 10, ...settings });
  let nextPrompt = nextGap();
  let k = 1;
  let pulls = 0;
  let maxPullGap = 0;
  let last = performance.now();
  while (s.now() < secs) {
    if (s.now() >= nextPrompt) {
      s.prompt(PROMPTS[k++ % PROMPTS.length]);
      nextPrompt += nextGap();
    }
    s.frameAt(s.now());
    pulls++;
    await sleep(50);
    const t = performance.now();
    maxPullGap = Math.max(maxPullGap, t - last);
    last = t;
  }
  const stats = s.stats();
  const rec = s.record();
  await s.close();
  return { stats, rec, pulls, maxPullGap, prompts: k - 1 };
}

/** Each prompt's blend: its eased span's peak acceleration ÷ the 95th percentile of the played motion outside every span. */
function seams(run, span, jointAccelerations) {
  const { rec, stats } = run;
  const acc = jointAccelerations(rec.joints, rec.frames, rec.fps);
  const inSpan = new Uint8Array(rec.frames);
  const peaks = [];
  for (const b of stats.blends) {
    const a = b; // record() starts at frame 0: its recordSeconds outlast the run
    if (a + span >= rec.frames - 1) continue;
    let m = 0;
    for (let t = Math.max(1, a - 1); t <= a + span; t++) {
      m = Math.max(m, acc[t]);
      inSpan[t] = 1;
    }
    peaks.push(m);
  }
  const elsewhere = [];
  for (let t = 1; t < rec.frames - 1; t++) if (!inSpan[t]) elsewhere.push(acc[t]);
  let repeated = 0;
  for (let t = 1; t < rec.frames; t++) {
    let same = true;
    for (let i = 0; i < 66 && same; i++) same = rec.joints[t * 66 + i] === rec.joints[(t - 1) * 66 + i];
    if (same) repeated++;
  }
  return { peaks, p95: q(elsewhere, 0.95), repeated };
}

await withLibrary(async (load) => {
  const { createGenerator } = await load('src/createGenerator.ts');
  const { LIVE_DEFAULTS } = await load('src/live/core.ts');
  const { OVERLAP_FRAMES, SEAM_EASE_FRAMES, SEAM_BLEND_EXTRA } = await load('src/edit.ts');
  const { jointAccelerations } = await load('src/motion/seams.ts');
  const g = await createGenerator({ baseUrl: path.join(ROOT, 'public', 'models') + '/', backend: 'wasm', threads: 1, worker: false });
  const info = await g.load(MODEL);
  const live = { ...LIVE_DEFAULTS, ...settings };
  const entry = g.manifest.models[MODEL];
  const frames = OVERLAP_FRAMES + live.window;
  console.log(`live-bench: ${MODEL} (${info.backend}, ${info.threads} thread), steps ${steps ?? entry.defaultSteps}, window ${live.window} + ${OVERLAP_FRAMES} frames, lead ${live.lead}, prompt lead ${live.promptLead}; ${os.cpus().length} CPUs, load ${os.loadavg().map((v) => v.toFixed(2)).join(' ')}`);
  for (const p of PROMPTS) await g.generate({ prompt: p, frames: 40, seed: 0, steps }); // warm-up: every prompt encoded once
  let cost = [];
  const windowCost = {};
  for (const w of [...new Set([20, 40, 80, live.window])].sort((a, b) => a - b)) { // what a window of w new frames costs
    const ms = [];
    for (let i = 0; i < 7; i++) {
      const t0 = performance.now();
      await g.generate({ prompt: PROMPTS[i % PROMPTS.length], frames: OVERLAP_FRAMES + w, seed: i, steps });
      if (i >= 2) ms.push(performance.now() - t0);
    }
    if (w === live.window) cost = ms;
    windowCost[w] = ms;
    console.log(`window cost, ${w} + ${OVERLAP_FRAMES} frames: median ${q(ms, 0.5).toFixed(0)} ms, max ${Math.max(...ms).toFixed(0)} ms (${(q(ms, 0.5) / 50).toFixed(1)} frames of playback)`);
  }

  const random = await runStream(g, seconds, () => 3 + 4 * rand());
  const lat = random.stats.latencies;
  console.log(`random prompts: ${random.prompts} in ${seconds} s; latency prompt → first new frame: median ${q(lat, 0.5).toFixed(3)} s, p95 ${q(lat, 0.95).toFixed(3)} s, max ${Math.max(...lat).toFixed(3)} s (bars 0.5 / 1 s); windows ${random.stats.windows}, dropped ${random.stats.dropped}, underruns ${random.stats.underruns}; load ${os.loadavg()[0].toFixed(2)}`);
  const steady = await runStream(g, steadySeconds, () => 5);
  console.log(`every 5 s for ${steadySeconds} s: ${steady.prompts} prompts, underruns ${steady.stats.underruns} (${steady.stats.coastedFrames} frames played back; bar 0), latency median ${q(steady.stats.latencies, 0.5).toFixed(3)} s, p95 ${q(steady.stats.latencies, 0.95).toFixed(3)} s; longest gap between pulls ${steady.maxPullGap.toFixed(0)} ms; load ${os.loadavg()[0].toFixed(2)}`);

  const span = SEAM_EASE_FRAMES + SEAM_BLEND_EXTRA;
  const all = [seams(random, span, jointAccelerations), seams(steady, span, jointAccelerations)];
  const ratios = all.flatMap((s) => s.peaks.map((p) => p / s.p95));
  const over = ratios.filter((r) => r > 1.5).length;
  console.log(`seams: ${ratios.length} prompt blends, peak acceleration over the eased span ÷ the stream's p95 elsewhere (${all.map((s) => s.p95.toFixed(1)).join(', ')} m/s²): median ${q(ratios, 0.5).toFixed(2)}, p95 ${q(ratios, 0.95).toFixed(2)}, max ${Math.max(...ratios).toFixed(2)}; over 1.5×: ${over}; frames repeated in what was played: ${all.map((s) => s.repeated).join(', ')}`);
  const out = opt('json');
  if (out) { // docs/RESULTS.md "Live stream" (python -m emdm.eval.report reads docs/results/json/live-*.json)
    const cpu = os.cpus()[0]?.model ?? 'unknown CPU';
    fs.writeFileSync(out, JSON.stringify({
      schema: 1, task: 'live', name: `live-${MODEL}-node-${info.backend}`, model: MODEL, runtime: `node ${process.version}, onnxruntime-web ${info.backend}, ${info.threads} thread, in-process`,
      hardware: `${cpu}, ${os.cpus().length} cores`, load: os.loadavg()[0], steps: steps ?? entry.defaultSteps, variant: g.manifest.models[MODEL].defaultVariant ?? 'fp32', live,
      windowCost, random: { seconds, prompts: random.prompts, latencies: lat, stats: random.stats },
      steady: { seconds: steadySeconds, prompts: steady.prompts, latencies: steady.stats.latencies, stats: steady.stats, maxPullGapMs: steady.maxPullGap },
      seams: { ratios, p95: all.map((x) => x.p95), repeated: all.map((x) => x.repeated), span },
    }, null, 1) + '\n');
  }
  await g.dispose();
});
