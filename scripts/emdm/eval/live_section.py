"""docs/RESULTS.md's "Live stream" section (issue 33) from ``node scripts/bench/live-bench.mjs --json
docs/results/json/live-<name>.json`` (``emdm.eval.report``): the library's live stream (``generator.live``,
src/live) in Node with the page's defaults, against the issue's bars.

Live JSON: {"schema": 1, "task": "live", "name", "model", "runtime", "hardware", "load", "steps", "variant",
"live": {"window", "lead", "promptLead", "recordSeconds"}, "windowCost": {new frames: [ms]},
"random": {"seconds", "prompts", "latencies": [s]}, "steady": {"seconds", "prompts", "stats": {"underruns",
"coastedFrames"}, "maxPullGapMs"}, "seams": {"ratios": [peak ÷ p95 elsewhere], "p95": [m/s²], "repeated": [frames]}}.

The page (tests/e2e/page-bench-live.spec.ts, EMDM_BENCH=1, Chromium on WASM) writes two more:
task "live-page" (EMDM_BENCH_OUT): {"name", "runtime", "hardware", "load", "steps", "threads", "summary": {"seconds",
"promptsSent", "latencies", "latencyMedianS", "latencyP95S", "underruns", "displayed", "repeated", "frameGapMs": {"idle",
"live", "idleAfter": {"p95", ...}}}}; task "live-soak" (EMDM_BENCH_SOAK_OUT): {..., "summary": {"minutes",
"promptsSent", "heapMB": {"first", "last", "max", "firstMinuteMean", "lastMinuteMean"}, "heapGrowthMB", "nodes": {"first",
"last", "max"}, "pelvisM": {"min", "max"}, "realPelvisM": {"min", "max", "source"}, "rootDistanceMaxM", "underruns", "displayed", "repeated"},
"samples": [...]}.
"""

from __future__ import annotations

import numpy as np

LATENCY_BARS = (0.5, 1.0)       # median, 95th percentile (s)
SEAM_BAR = 1.5                  # × the stream's 95th percentile of joint acceleration elsewhere
HEAP_BAR_MB = 20                # the soak's JS heap growth, first minute's mean → last minute's (MB)
TASKS = ("live", "live-page", "live-soak")

PAGE_KEYS = ("seconds", "promptsSent", "latencies", "latencyMedianS", "latencyP95S", "underruns", "displayed",
             "repeated", "frameGapMs")
SOAK_KEYS = ("minutes", "promptsSent", "heapMB", "heapGrowthMB", "nodes", "pelvisM", "realPelvisM", "rootDistanceMaxM",
             "underruns", "displayed", "repeated")

INTRO = ("`node scripts/bench/live-bench.mjs` runs `generator.live` (src/live: windows of C + W frames continuing the "
         "last second of what is playing, by the timelines' prefix inpainting and seam easing) in Node with the page's "
         "defaults, in real time with frames pulled every 50 ms: the cost of one window per length; a stream with "
         "prompts at random moments (every 3–7 s), its latency from `prompt()` to the first new frame on the stream's "
         "clock; a 2-minute stream with a prompt every 5 s, its underruns (the motion played back while generation is "
         "behind); over both streams' prompt changes, the peak joint acceleration over each blend's eased span "
         "(SEAM_EASE_FRAMES + SEAM_BLEND_EXTRA frames from the blend) against the 95th percentile of the played motion "
         "elsewhere, raw joints (`record()`: what was played). The window length, lead and prompt lead "
         "(src/live/core.ts) follow the window costs: a prompt's window is cut 8 frames (0.4 s) ahead, above the 60-frame "
         "window's cost on a loaded 2-core machine, so most prompts join on time at their cut.")


def _q(a, p: float) -> float:
    return float(np.quantile(np.asarray(a, float), p)) if len(a) else float("nan")


def row(r: dict) -> str:
    live, lat, seams = r["live"], r["random"]["latencies"], r["seams"]
    cost = "; ".join(f"{w} + 20: {_q(ms, .5):.0f} ms" for w, ms in sorted(r["windowCost"].items(), key=lambda kv: int(kv[0])))
    med, p95 = _q(lat, .5), _q(lat, .95)
    lat_ok = med <= LATENCY_BARS[0] and p95 <= LATENCY_BARS[1]
    steady = r["steady"]
    under = steady["stats"]["underruns"]
    ratios = seams["ratios"]
    within = sum(x <= SEAM_BAR for x in ratios)
    return (f"| `{r['_file']}` | {r['runtime']}; {r['hardware']}, load {r['load']:.1f} | {r['steps']} ({r['variant']}); "
            f"W {live['window']}, lead {live['lead']}, prompt lead {live['promptLead']} | {cost} | "
            f"**{med:.2f} / {p95:.2f} s** over {len(lat)} prompts ({'met' if lat_ok else 'not met'}) | "
            f"**{under}** in {steady['seconds']} s, {steady['prompts']} prompts ({'met' if under == 0 else 'not met'}) | "
            f"**{within}/{len(ratios)}** (max {max(ratios):.2f}×; p95 elsewhere {', '.join(f'{v:.0f}' for v in seams['p95'])} m/s²) | "
            f"{sum(seams['repeated'])} |")


PAGE_INTRO = ("In the page: `EMDM_BENCH=1 npx playwright test tests/e2e/page-bench-live.spec.ts` (headless Chromium, "
              "WASM, the page's defaults) plays a generated motion idle, then runs live mode through the real prompt box "
              "(Enter at a random moment of every 5 s): prompt → first new frame latency on the live clock, underruns, "
              "frames displayed and how many repeated the pose before, and the page's requestAnimationFrame gaps live "
              "against idle (95th percentile). `EMDM_BENCH_SOAK_MINUTES=10` (with `-g soak`) soaks it: a prompt every 5 s "
              "for the minutes given, every 10 s the JS heap after a forced GC (CDP `Performance.getMetrics`), DOM nodes "
              "and the stream's buffers, and every displayed frame's pelvis height against the real clips' range "
              "(the prepared dataset's pelvis heights, min to max), the root's distance from the stage centre.")


def missing(r: dict) -> list[str]:
    """The summary fields a "live-page" / "live-soak" result lacks ([] for other tasks)."""
    keys = {"live-page": PAGE_KEYS, "live-soak": SOAK_KEYS}.get(r.get("task"), ())
    s = r.get("summary")
    return [k for k in keys if not isinstance(s, dict) or k not in s]


def _summary(r: dict) -> dict:
    gone = missing(r)
    if gone:
        raise ValueError(f"{r.get('_file', r.get('name'))}: field 'summary' lacks {', '.join(repr(k) for k in gone)} "
                         f"(task {r.get('task')!r}; rerun tests/e2e/page-bench-live.spec.ts)")
    return r["summary"]


def _where(r: dict) -> str:
    n = r.get("threads")
    return f"{r['runtime']}, WASM, {n if n is not None else '?'} thread{'' if n == 1 else 's'}; {r['hardware']}, load {r['load']:.1f}"


def _met(ok: bool) -> str:
    return "met" if ok else "not met"


def page_row(r: dict) -> str:
    """One page benchmark (task "live-page"): latency against the bars, underruns, repeated frames, frame gaps."""
    s = _summary(r)
    med, p95 = s["latencyMedianS"], s["latencyP95S"]
    gaps = s["frameGapMs"]
    idle = min(gaps["idle"]["p95"], gaps.get("idleAfter", gaps["idle"])["p95"])     # the stricter of the two
    # the page's stream settings are in results written since 2026-11-28; those before ran windows of 40 new frames
    window = (r.get("live") or {}).get("window", 40)
    cost = f", {s['windowMsMedian']} ms median" if "windowMsMedian" in s else ""
    return (f"| `{r['_file']}` | {_where(r)} | "
            f"{r['steps']}; W {window}{cost} | **{med:.2f} / {p95:.2f} s** over {s['latencies']} of "
            f"{s['promptsSent']} prompts "
            f"({_met(med <= LATENCY_BARS[0] and p95 <= LATENCY_BARS[1])}) | **{s['underruns']}** in {s['seconds']} s "
            f"({_met(s['underruns'] == 0)}) | {s['repeated']} of {s['displayed']} | {gaps['live']['p95']:.1f} / "
            f"{gaps['idle']['p95']:.1f}, after {gaps.get('idleAfter', gaps['idle'])['p95']:.1f} ms "
            f"({gaps['live']['p95'] / idle:.2f}× the smaller idle) |")


def soak_row(r: dict) -> str:
    """One soak (task "live-soak"): heap growth against HEAP_BAR_MB, pelvis height against the real clips' range."""
    s = _summary(r)
    h, pel, real = s["heapMB"], s["pelvisM"], s["realPelvisM"]
    grow = s["heapGrowthMB"]
    within = real["min"] <= pel["min"] and pel["max"] <= real["max"]
    return (f"| `{r['_file']}` | {_where(r)} | "
            f"{s['minutes']:g} min, {s['promptsSent']} prompts | {h['first']:.1f} / {h['last']:.1f} / {h['max']:.1f} | "
            f"**{grow:+.1f} MB** ({h['firstMinuteMean']:.1f} → {h['lastMinuteMean']:.1f}; {_met(grow <= HEAP_BAR_MB)}) | "
            f"**{pel['min']:.2f}–{pel['max']:.2f} m** (real {real['min']:.2f}–{real['max']:.2f} m; {_met(within)}) | "
            f"{s['nodes']['first']} → {s['nodes']['last']} (max {s['nodes']['max']}) | {s['rootDistanceMaxM']:.2f} m | "
            f"{s['underruns']} | {s['repeated']} of {s['displayed']} |")


def section(runs: list[dict]) -> list[str]:
    """The "Live stream" section from the runs of TASKS: the Node table, then the page's and the soak's."""
    by = {t: sorted((r for r in runs if r["task"] == t), key=lambda r: r["name"]) for t in TASKS}
    out = ["## Live stream (issue 33)", ""]
    if by["live"]:
        out += [INTRO, "",
                "| Result | Runtime | Steps; frames | Window cost (median) | Latency median / p95 (bars 0.5 / 1 s) | Underruns "
                "(bar 0) | Seams ≤ 1.5× p95 | Repeated frames |",
                "| --- | --- | --- | --- | --- | --- | --- | --- |"]
        out += [row(r) for r in by["live"]] + [""]
    if by["live-page"] or by["live-soak"]:
        out += [PAGE_INTRO, ""]
    if by["live-page"]:
        out += ["| Result | Runtime | Steps; window new frames, cost | Latency median / p95 (bars 0.5 / 1 s) | "
                "Underruns (bar 0) | Repeated frames | "
                "Frame gaps p95, live / idle |", "| --- | --- | --- | --- | --- | --- | --- |"]
        out += [page_row(r) for r in by["live-page"]] + [""]
    if by["live-soak"]:
        out += [f"| Soak | Runtime | Length | JS heap first / last / max (MB) | Heap growth, first → last minute "
                f"(bar {HEAP_BAR_MB} MB) | Pelvis height (real clips' range) | DOM nodes (CDP), first → last | Root from stage "
                "centre, max | Underruns | Repeated frames |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
        out += [soak_row(r) for r in by["live-soak"]] + [""]
    return out
