"""docs/RESULTS.md's "Live stream" section (issue 33) from ``node scripts/bench/live-bench.mjs --json
docs/results/json/live-<name>.json`` (``emdm.eval.report``): the library's live stream (``generator.live``,
src/live) in Node with the page's defaults, against the issue's bars.

Live JSON: {"schema": 1, "task": "live", "name", "model", "runtime", "hardware", "load", "steps", "variant",
"live": {"window", "lead", "promptLead", "recordSeconds"}, "windowCost": {new frames: [ms]},
"random": {"seconds", "prompts", "latencies": [s]}, "steady": {"seconds", "prompts", "stats": {"underruns",
"coastedFrames"}, "maxPullGapMs"}, "seams": {"ratios": [peak ÷ p95 elsewhere], "p95": [m/s²], "repeated": [frames]}}.
"""

from __future__ import annotations

import numpy as np

LATENCY_BARS = (0.5, 1.0)       # median, 95th percentile (s)
SEAM_BAR = 1.5                  # × the stream's 95th percentile of joint acceleration elsewhere

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


def section(runs: list[dict]) -> list[str]:
    out = ["## Live stream (issue 33)", "", INTRO, "",
           "| Result | Runtime | Steps; frames | Window cost (median) | Latency median / p95 (bars 0.5 / 1 s) | Underruns "
           "(bar 0) | Seams ≤ 1.5× p95 | Repeated frames |",
           "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    out += [row(r) for r in sorted(runs, key=lambda r: r["name"])]
    return out + [""]
