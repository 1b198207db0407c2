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
//   4. frameAt's cost pulled at 60 Hz for --frame-seconds (poses solved once per window) against the per-frame IK the
//      stream did before (solvePose of one frame, timed on the same frames), and one window's solve
//   --load N: N busy threads beside the model (a loaded machine); the steady run is then made twice, with the lead
//   fixed (--max-lead = --lead, the stream before) and adapted to the windows' cost, and their underruns printed.
//   --soak-minutes M [--speed X]: instead of the above, one session of M minutes on a clock X× wall time (default 4)
//   with a prompt every 5–15 s: heap at start and end (after gc with node --expose-gc), the most frames buffered, the
//   stats lists' lengths, the pelvis height against the real clips' range, the lowest foot joint (the floor under the
//   feet) and the lowest joint of all over every frame played, and the root's largest distance from the stage's centre.
//
//   node scripts/bench/live-bench.mjs                    # defaults: --seconds 180 --steady 120, the page's steps (10)
//   node scripts/bench/live-bench.mjs --json docs/results/json/live-emdm-t2m-web-node-wasm.json   # then python -m emdm.eval.report
//   node scripts/bench/live-bench.mjs --steps 6 --prompt-lead 8 --seconds 60
//   node scripts/bench/live-bench.mjs --load 2 --seconds 30 --steady 60
//   node --expose-gc scripts/bench/live-bench.mjs --soak-minutes 10 --speed 4
import fs from 'node:fs';
import os from 'node:os';
import path from 'node:path';
import { Worker } from 'node:worker_threads';
import { ROOT, cli, withLibrary } from './common.mjs';

const { opt } = cli();
const MODEL = 'emdm-t2m-web';
const seconds = Number(opt('seconds', '180'));
const steadySeconds = Number(opt('steady', '120'));
const steps = opt('steps') ? Number(opt('steps')) : undefined;
const camel = (k) => k.replace(/-(.)/g, (_, c) => c.toUpperCase());
const settings = Object.fromEntries(['window', 'lead', 'max-lead', 'prompt-lead'].filter((k) => opt(k)).map((k) => [camel(k), Number(opt(k))]));
const busy = Number(opt('load', '0'));
const frameSeconds = Number(opt('frame-seconds', '10'));
const soakMinutes = opt('soak-minutes') ? Number(opt('soak-minutes')) : 0;
const speed = Number(opt('speed', '4'));
/** Pelvis height of the real clips (m): min / max over the 7,202 clips (664,250 frames) of the prepared dataset's
 * new_joints (lying down … jumping), and the 0.1 / 99.9 percentiles; numpy over data/dataset/new_joints/*.npy [:, 0, 1]. */
const REAL_PELVIS = { min: 0.047, max: 1.777, p001: 0.082, p999: 1.627 };
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
async function runStream(g, secs, nextGap, more = {}) {
  const s = await g.live({ prompt: PROMPTS[0], seed: 1, steps, recordSeconds: secs + 10, ...settings, ...more });
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

/** N threads spinning beside the model (a loaded machine); returns their stop. */
function startBusy(n) {
  const ws = Array.from({ length: n }, () => new Worker('for (;;) {}', { eval: true }));
  return () => Promise.all(ws.map((w) => w.terminate()));
}

/** frameAt pulled at 60 Hz for `secs` (poses solved once per window) against solvePose of one frame on the same frames
 * (what frameAt did on every call before), and one window's solve. */
async function frameAtCost(g, solvePose, secs, windowFrames) {
  const s = await g.live({ prompt: PROMPTS[0], seed: 1, steps, ...settings });
  const now = [];
  const perFrame = [];
  while (s.now() < secs) {
    const t0 = performance.now();
    const f = s.frameAt(s.now());
    now.push(performance.now() - t0);
    const t1 = performance.now();
    solvePose(f.joints, 1, g.skeleton);
    perFrame.push(performance.now() - t1);
    await sleep(1000 / 60);
  }
  const st = s.stats();
  const rec = s.record();
  await s.close();
  const n = Math.min(windowFrames, rec.frames);
  const w0 = performance.now();
  solvePose(rec.joints.slice(0, n * 66), n, g.skeleton);
  const windowMs = performance.now() - w0;
  const us = (a, p) => (q(a, p) * 1000).toFixed(0);
  console.log(`frameAt at 60 Hz for ${secs} s (${now.length} calls): median ${us(now, 0.5)} µs, p95 ${us(now, 0.95)} µs, mean ${(now.reduce((a, b) => a + b, 0) / now.length * 1000).toFixed(0)} µs, poses solved by frameAt itself ${st.poseFallbacks}; before (IK of the frame on every call): + median ${us(perFrame, 0.5)} µs, p95 ${us(perFrame, 0.95)} µs per call; one window's solve (${n} frames) ${windowMs.toFixed(1)} ms (${(windowMs / n * 1000).toFixed(0)} µs a frame, once); load ${os.loadavg()[0].toFixed(2)}`);
  return { calls: now.length, frameAtMs: now, perFrameIkMs: perFrame, windowSolveMs: windowMs, windowFrames: n, poseFallbacks: st.poseFallbacks };
}

/** One long session on a clock `speed`× wall time, prompts every 5–15 s of it, every frame pulled: memory, buffers, heights, stage. */
async function soak(g, minutes) {
  const gc = globalThis.gc ?? null;
  const mem = () => (gc?.(), process.memoryUsage());
  let t0 = Infinity;
  const s = await g.live({ prompt: PROMPTS[0], seed: 1, steps, ...settings, clock: () => Math.max(0, ((performance.now() - t0) / 1000) * speed) });
  const m0 = mem();
  t0 = performance.now();
  const MB = (b) => (b / 2 ** 20).toFixed(1);
  const end = minutes * 60;
  let nextPrompt = 5 + 10 * rand();
  let k = 1;
  let p = 0;
  let minute = 1;
  const x = { buffered: 0, pelvis: [Infinity, -Infinity], feet: [Infinity, -Infinity], lowest: { y: Infinity, joint: 0, prompt: '' }, stage: 0, heap: m0.heapUsed, buffers: m0.arrayBuffers };
  const FEET = [7, 8, 10, 11]; // l_ankle, r_ankle, l_foot, r_foot
  while (s.now() < end) {
    if (s.now() >= nextPrompt) {
      s.prompt(PROMPTS[k++ % PROMPTS.length]);
      nextPrompt += 5 + 10 * rand();
    }
    for (const last = Math.floor(s.now() * 20); p <= last; p++) {
      const j = s.frameAt(p / 20).joints;
      const foot = Math.min(...FEET.map((f) => j[f * 3 + 1]));
      for (let i = 0; i < 22; i++) if (j[i * 3 + 1] < x.lowest.y) x.lowest = { y: j[i * 3 + 1], joint: i, prompt: PROMPTS[(k - 1) % PROMPTS.length] };
      x.pelvis = [Math.min(x.pelvis[0], j[1]), Math.max(x.pelvis[1], j[1])];
      x.feet = [Math.min(x.feet[0], foot), Math.max(x.feet[1], foot)];
      x.stage = Math.max(x.stage, Math.hypot(j[0], j[2]));
    }
    x.buffered = Math.max(x.buffered, s.stats().bufferedFrames);
    if (s.now() >= minute * 60) {
      const m = mem();
      x.heap = Math.max(x.heap, m.heapUsed);
      x.buffers = Math.max(x.buffers, m.arrayBuffers);
      const st = s.stats();
      console.log(`  minute ${minute}: heap ${MB(m.heapUsed)} MB, array buffers ${MB(m.arrayBuffers)} MB, buffered ${st.bufferedFrames} frames, lead ${st.lead}, windows ${st.windows}, underruns ${st.underruns}, load ${os.loadavg()[0].toFixed(2)}`);
      minute++;
    }
    await sleep(50);
  }
  const st = s.stats();
  await s.close();
  const m1 = mem();
  console.log(`soak: ${minutes} min of stream at ${speed}× (${p} frames played, ${k - 1} prompts, windows ${st.windows}, dropped ${st.dropped}, underruns ${st.underruns}, lead at the end ${st.lead}); heap${gc ? ' after gc' : ' (no --expose-gc: before gc)'} ${MB(m0.heapUsed)} → ${MB(m1.heapUsed)} MB (most ${MB(x.heap)}), array buffers ${MB(m0.arrayBuffers)} → ${MB(m1.arrayBuffers)} MB (most ${MB(x.buffers)}); most frames buffered ${x.buffered}; stats lists ${st.latencies.length} / ${st.windowMs.length} / ${st.blends.length}; pelvis ${x.pelvis[0].toFixed(3)}–${x.pelvis[1].toFixed(3)} m (real clips ${REAL_PELVIS.min}–${REAL_PELVIS.max}, 0.1–99.9 % ${REAL_PELVIS.p001}–${REAL_PELVIS.p999}); lowest foot joint ${x.feet[0].toFixed(3)}–${x.feet[1].toFixed(3)} m, lowest joint of all ${x.lowest.y.toFixed(3)} m (joint ${x.lowest.joint}, during '${x.lowest.prompt}'); root at most ${x.stage.toFixed(2)} m from the stage's centre; load ${os.loadavg()[0].toFixed(2)}`);
}

await withLibrary(async (load) => {
  const { createGenerator } = await load('src/createGenerator.ts');
  const { LIVE_DEFAULTS } = await load('src/live/core.ts');
  const { OVERLAP_FRAMES, SEAM_EASE_FRAMES, SEAM_BLEND_EXTRA } = await load('src/edit.ts');
  const { jointAccelerations } = await load('src/motion/seams.ts');
  const { solvePose } = await load('src/motion/ik.ts');
  const g = await createGenerator({ baseUrl: path.join(ROOT, 'public', 'models') + '/', backend: 'wasm', threads: 1, worker: false });
  const info = await g.load(MODEL);
  const live = { ...LIVE_DEFAULTS, ...settings };
  const entry = g.manifest.models[MODEL];
  const frames = OVERLAP_FRAMES + live.window;
  console.log(`live-bench: ${MODEL} (${info.backend}, ${info.threads} thread), steps ${steps ?? entry.defaultSteps}, window ${live.window} + ${OVERLAP_FRAMES} frames, lead ${live.lead} (up to ${live.maxLead}), prompt lead ${live.promptLead}; ${os.cpus().length} CPUs, load ${os.loadavg().map((v) => v.toFixed(2)).join(' ')}${busy ? `; + ${busy} busy threads` : ''}`);
  for (const p of PROMPTS) await g.generate({ prompt: p, frames: 40, seed: 0, steps }); // warm-up: every prompt encoded once
  const stopBusy = startBusy(busy);
  if (soakMinutes) {
    await soak(g, soakMinutes);
    await stopBusy();
    await g.dispose();
    return;
  }
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

  const frameAt = await frameAtCost(g, solvePose, frameSeconds, frames);
  const random = await runStream(g, seconds, () => 3 + 4 * rand());
  const lat = random.stats.latencies;
  console.log(`random prompts: ${random.prompts} in ${seconds} s; latency prompt → first new frame: median ${q(lat, 0.5).toFixed(3)} s, p95 ${q(lat, 0.95).toFixed(3)} s, max ${Math.max(...lat).toFixed(3)} s (bars 0.5 / 1 s); windows ${random.stats.windows}, dropped ${random.stats.dropped}, underruns ${random.stats.underruns}; load ${os.loadavg()[0].toFixed(2)}`);
  const steadyLine = (r, what) => console.log(`every 5 s for ${steadySeconds} s${what}: ${r.prompts} prompts, underruns ${r.stats.underruns} (${r.stats.coastedFrames} frames played back; bar 0), latency median ${q(r.stats.latencies, 0.5).toFixed(3)} s, p95 ${q(r.stats.latencies, 0.95).toFixed(3)} s; lead at the end ${r.stats.lead}; longest gap between pulls ${r.maxPullGap.toFixed(0)} ms; load ${os.loadavg()[0].toFixed(2)}`);
  const fixedLead = busy ? await runStream(g, steadySeconds, () => 5, { maxLead: live.lead }) : null;
  if (fixedLead) steadyLine(fixedLead, `, lead fixed at ${live.lead} (before)`);
  const steady = await runStream(g, steadySeconds, () => 5);
  steadyLine(steady, busy ? `, lead adapted (${live.lead}…${live.maxLead})` : '');
  await stopBusy();

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
      frameAt, ...(busy ? { busyThreads: busy, fixedLead: { seconds: steadySeconds, prompts: fixedLead.prompts, stats: fixedLead.stats } } : {}),
    }, null, 1) + '\n');
  }
  await g.dispose();
});
