"""Live segments' meaning and blends (issue 33): a live session of the Python twin of the stream (``emdm.motion.live``,
the page's defaults) with prompt changes drawn from the actions the model covers, cut into its segments and judged by
the coverage judges against the same prompts generated alone. Run as part of ``python -m emdm.eval.seams``.

* Session: the first prompt at frame 0, then ``changes`` prompt changes at random moments (every ``gap`` s: a visitor
  watches an action a while before the next), each prompt a covered action's (``capabilities-<model>.json``: its
  prompt), every covered action equally often, never the same twice in a row. The windows cost ``cost`` frames each
  (the Node benchmark's median window cost on this machine, docs/RESULTS.md "Live stream").
* Blends: a prompt's blend is the first new frame of its window (the stream's ``stats.blends``); its figure is the
  largest joint acceleration over the eased span [b − 1, b + SPAN] against the 95th percentile of the played motion
  outside every span: the Node benchmark's statistic (scripts/bench/live-bench.mjs ``seams``), on the frames played.
* Segments: each prompt's frames from the end of its blend (b + SPAN) to the next prompt (the last: to the session's
  end). A prompt whose window never joined (replaced by the next before it was ready) has none.
* Alone: per segment, the same prompt generated alone at the segment's length (one motion per segment, so as many
  seeds per action as segments), decoded as the page shows a motion (``decode_joints``).
* Judges: the action classifier (``emdm.eval.coverage``: recognised = names the prompt's action) reads the features
  (a live segment: the stream's, frames of the segment); the kinematic rule of the action (``emdm.eval.kinematics``,
  only actions it judges on the real test clips) reads the joints as shown (a live segment: what was played).
* Verdict ("each segment's meaning as good as the same prompt generated alone"): each segment is paired with its alone
  motion; met unless a judge fails significantly more live segments than alone ones (one-sided exact sign test on the
  pairs the two disagree on, p < ALPHA). Beside it, for reading: the alone motion read after its first second (made
  LATE frames longer: a live segment is mid-motion), and the classifier on each segment's first and second half.
* Reference for the blends: the same statistic over a span of the same length in the middle of each segment (no
  blend there), against the same percentile: how often the motion itself exceeds 1.5×.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path

import numpy as np

from emdm.eval import coverage as C
from emdm.eval import kinematics as K
from emdm.motion import live as L
from emdm.motion.decode import decode_joints
from emdm.motion.features import recover_joints
from emdm.motion.seams import SEAM_BLEND_EXTRA, SEAM_EASE, joint_acceleration
from emdm.paths import display_path

SPAN = SEAM_EASE + SEAM_BLEND_EXTRA     # a blend's eased span (frames): src/motion/seams.ts's SEAM_EASE_FRAMES + SEAM_BLEND_EXTRA
COST = 5                # frames a window costs (60 new frames: 228 ms median, Node WASM, 1 thread, 2 cores: ⌈228 / 50⌉)
GAP = (4.0, 8.0)        # seconds between prompt changes
LATE = 20               # frames: the alone motion read after its first second (the live segment is mid-motion)
MIN_SEGMENT = 20        # frames: a shorter segment is not judged (counted apart)
FPS = L.FPS
ALPHA = 0.05            # "as good as alone": met unless a judge finds live worse at this significance (paired sign test)
SEAM_BAR = 1.5
UNRECORDED_WINDOW = 40  # new frames per window of the sessions written before results recorded it (2026-11-28)


class LiveMeaningError(ValueError):
    """An input of the live measure cannot be used (the message names it)."""


# ----------------------------------------------------------------------------------------------- measures (pure)

def covered_prompts(capabilities: Path | str) -> dict[str, str]:
    """action → prompt of every action a capabilities file marks covered (with a prompt)."""
    path = Path(capabilities)
    try:
        acts = json.loads(path.read_text())["actions"]
        out = {a["label"]: a["prompt"] for a in acts if a.get("covered") and a.get("prompt")}
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise LiveMeaningError(f"{path}: expected a capabilities file {{\"actions\": [{{\"label\", \"covered\", "
                               f"\"prompt\"}}]}} ({type(e).__name__}: {e})") from None
    if len(out) < 2:
        raise LiveMeaningError(f"{path}: {len(out)} covered action(s) with a prompt; a live session needs at least 2")
    return out


def schedule(actions: list[str], changes: int, rng: np.random.Generator, gap=GAP, fps: int = FPS) -> list[tuple[int, str]]:
    """[(frame, action)]: the first at frame 0, then ``changes`` changes ``gap`` seconds apart (uniform), every action
    equally often (± 1), never one twice in a row."""
    order: list[str] = []
    while len(order) < changes + 1:
        for a in rng.permutation(actions):
            if order and a == order[-1]:
                continue
            order.append(str(a))
    order = order[:changes + 1]
    at = np.concatenate([[0], np.cumsum(np.round(rng.uniform(gap[0], gap[1], changes) * fps))]).astype(int)
    return list(zip(at.tolist(), order))


def prompt_blends(windows, prompted_at: list[int]) -> list[int | None]:
    """Per prompt (its frame): the first new frame of its window (``Simulated.windows``), None if it never joined."""
    first = {w[0].start: w[2] for w in windows if w[0].prompted and w[2] is not None and not w[3]}
    return [first.get(p) for p in prompted_at]


def blend_ratios(joints: np.ndarray, blends, span: int = SPAN) -> tuple[list[float | None], float]:
    """Per blend b: the peak joint acceleration over [b − 1, b + span] ÷ the 95th percentile of the motion's joint
    acceleration outside every span (None: the span runs past the motion's end); and that percentile (m/s²)."""
    acc = joint_acceleration(joints, FPS)
    n = len(acc)
    inside = np.zeros(n, bool)
    peaks: list[float | None] = []
    for b in blends:
        if b is None or b + span >= n - 1:
            peaks.append(None)
            continue
        lo = max(1, b - 1)
        peaks.append(float(acc[lo:b + span + 1].max()))
        inside[lo:b + span + 1] = True
    inside[[0, -1]] = True
    p95 = float(np.percentile(acc[~inside], 95))
    return [None if p is None else p / p95 for p in peaks], p95


def segments(sched: list[tuple[int, str]], blends, frames: int, span: int = SPAN) -> list[tuple[int, int] | None]:
    """Per prompt: its segment [b + span, next prompt) (the last prompt's: to ``frames``); None without a blend."""
    out = []
    for i, ((_, _), b) in enumerate(zip(sched, blends)):
        end = sched[i + 1][0] if i + 1 < len(sched) else frames
        out.append(None if b is None else (b + span, end))
    return out


def judge(labels: list[str], actions: list[str], features: list[np.ndarray], joints: list[np.ndarray], predict,
          judged: list[str]) -> dict[str, list]:
    """Per motion: recognised by the classifier (``predict``: features list → label ids) as its action, and passing its
    action's kinematic rule (None when the rule does not judge the action)."""
    pred = predict(features)
    cls = [bool(labels[int(p)] == a) for p, a in zip(pred, actions)]
    kin = [bool(K.passes(a, K.table([j]))[0]) if a in judged else None for a, j in zip(actions, joints)]
    return {"classifier": cls, "kinematic": kin, "predicted": [labels[int(p)] for p in pred]}


def rates(actions: list[str], live: dict, alone: dict) -> dict:
    """Per action and overall: segments, and per judge the live and alone pass rates, live ÷ alone, and the segments
    only live fails / only alone fails (each segment is paired with its alone motion)."""
    def one(sel) -> dict:
        row = {"n": int(len(sel))}
        for j in ("classifier", "kinematic"):
            pairs = [(live[j][k], alone[j][k]) for k in sel if live[j][k] is not None]
            if pairs:
                a, b = (float(np.mean(v)) for v in zip(*pairs))
                row[j] = {"live": a, "alone": b, "ratio": a / b if b else None, "n": len(pairs),
                          "only_live_fails": sum(y and not x for x, y in pairs),
                          "only_alone_fails": sum(x and not y for x, y in pairs)}
        return row
    per = {a: one([k for k, x in enumerate(actions) if x == a]) for a in dict.fromkeys(actions)}
    return {"per_action": per, "all": one(list(range(len(actions))))}


def worse_p(only_live_fails: int, only_alone_fails: int) -> float:
    """One-sided exact sign test (McNemar) on the discordant pairs: the chance of at least ``only_live_fails`` of them
    going against live if live and alone were as good."""
    n = only_live_fails + only_alone_fails
    return float(sum(math.comb(n, k) for k in range(only_live_fails, n + 1)) / 2**n) if n else 1.0


def verdict(all_row: dict, alpha: float = ALPHA) -> dict:
    """Per judge: worse (live fails significantly more of the paired segments than alone, ``worse_p`` < alpha); met
    when no judge finds live worse."""
    out = {j: worse_p(all_row[j]["only_live_fails"], all_row[j]["only_alone_fails"]) for j in ("classifier", "kinematic")
           if j in all_row}
    return {"p_worse": out, "met": all(p >= alpha for p in out.values())}


def halves(labels: list[str], actions: list[str], motions: list[np.ndarray], predict) -> dict:
    """Classifier recognition of each motion's first and second half (motions of ≥ 2·MIN_SEGMENT frames)."""
    idx = [k for k, m in enumerate(motions) if len(m) >= 2 * MIN_SEGMENT]
    out = {"n": len(idx)}
    for name, part in (("first", lambda m: m[:len(m) // 2]), ("second", lambda m: m[len(m) // 2:])):
        pred = predict([part(motions[k]) for k in idx]) if idx else []
        out[name] = float(np.mean([labels[int(p)] == actions[k] for p, k in zip(pred, idx)])) if idx else None
    return out


def placebo_ratios(joints: np.ndarray, cuts, p95: float, span: int = SPAN) -> list[float]:
    """The blends' statistic where nothing is blended: the peak joint acceleration over a span of the same length in
    the middle of each segment, ÷ the same p95 (the reference: how often the motion itself exceeds 1.5×)."""
    acc = joint_acceleration(joints, FPS)
    out = []
    for c in cuts:
        if c is not None and c[1] - c[0] >= span + 2:
            m = (c[0] + c[1] - span) // 2
            out.append(float(acc[max(1, m - 1):m + span + 1].max() / p95))
    return out


# ----------------------------------------------------------------------------------------------- the run

def session(model, sched: list[tuple[int, str]], prompts: dict[str, str], seed: int, cost: int, tail: int,
            window: int = L.WINDOW):
    """Run the stream (windows of ``window`` new frames) for the schedule and ``tail`` frames after its last prompt:
    (Simulated, its features (frames, 263) as played, the prompts' blends, underruns)."""
    frames = sched[-1][0] + tail
    core = L.LiveCore(model, prompts[sched[0][1]], seed=seed, window=window, record_seconds=frames / FPS + 10)
    sim = L.simulate(core, frames, [(p, prompts[a]) for p, a in sched[1:]], [cost])
    if core.base != 0:
        raise LiveMeaningError(f"live session: the stream dropped its first {core.base} frames; raise record_seconds")
    blends = [0] + prompt_blends(sim.windows, [p for p, _ in sched[1:]])
    return sim, core.features[:frames].copy(), blends, core.underruns


def measure(model, bench, judged: list[str], prompts: dict[str, str], changes: int, seed: int, cost: int = COST,
            gap=GAP, log=print, window: int = L.WINDOW) -> dict:
    """The live session, its blends' figures and its segments judged against the same prompts generated alone."""
    missing = [a for a in prompts if a not in bench.labels]
    if missing:
        raise LiveMeaningError(f"covered actions {missing} are not actions of the dataset {bench.dataset}")
    rng = np.random.default_rng(seed)
    sched = schedule(sorted(prompts), changes, rng, gap)
    tail = round(gap[1] * FPS)
    sim, feats, blends, underruns = session(model, sched, prompts, seed, cost, tail, window)
    ratios, p95 = blend_ratios(sim.joints, blends[1:])
    cuts = segments(sched, blends, len(sim.joints))
    rows, live_f, live_j, alone_f, alone_j, late_f, late_j = [], [], [], [], [], [], []
    for i, ((at, a), cut) in enumerate(zip(sched, cuts)):
        row = {"prompt_at": at, "action": a, "blend": blends[i], "blend_ratio": ratios[i - 1] if i else None,
               "from": sched[i - 1][1] if i else None}
        if cut is not None and cut[1] - cut[0] >= MIN_SEGMENT:
            s, e = cut
            row["segment"] = [s, e]
            live_f.append(feats[s:e])
            live_j.append(sim.joints[s:e])
            f = model.denormalise(model.sample(prompts[a], e - s, seed + 100_000 + i))
            alone_f.append(f)
            alone_j.append(decode_joints(f))
            f = model.denormalise(model.sample(prompts[a], min(e - s + LATE, model.max_frames), seed + 200_000 + i))
            late_f.append(f[LATE:])
            late_j.append(decode_joints(f)[LATE:])
        rows.append(row)
    judged_rows = [r for r in rows if "segment" in r]
    acts = [r["action"] for r in judged_rows]
    live = judge(bench.labels, acts, live_f, live_j, bench.predict, judged)
    alone = judge(bench.labels, acts, alone_f, alone_j, bench.predict, judged)
    late = judge(bench.labels, acts, late_f, late_j, bench.predict, judged)
    for k, r in enumerate(judged_rows):
        r["live"] = {j: live[j][k] for j in live}
        r["alone"] = {j: alone[j][k] for j in alone}
        r["alone_late"] = {j: late[j][k] for j in late}
    rt = rates(acts, live, alone)
    seam = [x for x in ratios if x is not None]
    placebo = placebo_ratios(sim.joints, cuts[1:], p95)
    out = {"changes": changes, "seed": seed, "window": window, "cost_frames": cost, "gap_seconds": list(gap),
           "span": SPAN,
           "prompt_keep_from": L.PROMPT_KEEP_FROM,
           "frames": len(sim.joints), "min_segment": MIN_SEGMENT, "segments": len(judged_rows),
           "no_segment": sum(r["blend"] is None for r in rows),
           "too_short": sum(r["blend"] is not None and "segment" not in r for r in rows),
           "segment_frames": [r["segment"][1] - r["segment"][0] for r in judged_rows],
           "judged_actions": [a for a in sorted(prompts) if a in judged], "rates": rt,
           "rates_alone_late": rates(acts, live, late)["all"], "late": LATE,
           "halves": {"live": halves(bench.labels, acts, live_f, bench.predict),
                      "alone": halves(bench.labels, acts, alone_f, bench.predict)},
           "verdict": verdict(rt["all"]),
           "blends": {"ratios": seam, "p95": p95, "within": sum(x <= SEAM_BAR for x in seam),
                      "placebo": placebo, "placebo_within": sum(x <= SEAM_BAR for x in placebo)},
           "underruns": underruns, "rows": rows}
    log(report_line(out))
    return out


def run(model, dataset: Path, classifier: Path | list[Path], capabilities: Path, changes: int, seed: int, cost: int = COST,
        log=print, window: int = L.WINDOW) -> dict:
    """``measure`` with the coverage judges of ``dataset``'s test clips: the classifier file(s) (``coverage.Benchmark``) and
    the kinematic rules that judge their action there (``kinematics.judged``)."""
    prompts = covered_prompts(capabilities)
    bench = C.Benchmark(dataset, "test", classifier, C.PROMPTS_FILE, seeds=1, log=log)
    desc = K.table([recover_joints(m) for m in bench.test.motions])
    judged = K.judged(K.validate(bench.labels, bench.test.actions, desc))
    t0 = time.time()
    out = measure(model, bench, judged, prompts, changes, seed, cost, log=log, window=window)
    return {**out, "capabilities": display_path(capabilities), "classifier": bench.judge.info(),
            "seconds": round(time.time() - t0, 1),
            "load_avg_1min_end": os.getloadavg()[0]}


def report_line(r: dict) -> str:
    a, b, h = r["rates"]["all"], r["blends"], r["halves"]
    parts = [f"{j} {a[j]['live']:.0%} live vs {a[j]['alone']:.0%} alone (× {a[j]['ratio']:.2f}; only live fails "
             f"{a[j]['only_live_fails']}, only alone {a[j]['only_alone_fails']}, p {r['verdict']['p_worse'][j]:.3f})"
             for j in ("classifier", "kinematic") if j in a and a[j]["ratio"] is not None]
    return (f"live: {r['changes']} prompt changes, {r['segments']} segments judged ({r['no_segment']} never joined, "
            f"{r['too_short']} shorter than {r['min_segment']} frames): " + "; ".join(parts) +
            f" — {'met' if r['verdict']['met'] else 'not met'}; classifier by half, live {h['live']['first']:.0%} / "
            f"{h['live']['second']:.0%}, alone {h['alone']['first']:.0%} / {h['alone']['second']:.0%}; blends within "
            f"{SEAM_BAR}× the p95 elsewhere ({b['p95']:.0f} m/s²): {b['within']}/{len(b['ratios'])}, max "
            f"{max(b['ratios']):.2f}× (mid-segment spans, no blend: {b['placebo_within']}/{len(b['placebo'])}, max "
            f"{max(b['placebo']):.2f}×)")


# ----------------------------------------------------------------------------------------------- RESULTS.md

def _judge_cell(x: dict | None, p: float | None) -> str:
    """live / alone (× ratio; the discordant pairs, and the sign test's p if given)."""
    if x is None:
        return "–"
    ratio = "–" if x["ratio"] is None else f"{x['ratio']:.2f}"
    return (f"{x['live']:.0%} / {x['alone']:.0%} (× {ratio}; only live fails {x['only_live_fails']}, only alone "
            f"{x['only_alone_fails']}" + ("" if p is None else f", p {p:.3f}") + ")")


def pooled(rs: list[dict]) -> list[dict]:
    """Sessions of one stream on one model's weights (the same ``train_steps``, prompt keep-from, window, window cost,
    gaps and judge; only their seeds differ) pooled: their paired segments summed per judge, the sign test on the sum. One row
    per group of two or more sessions: {"files", "rates": {judge: {...}}, "verdict"}."""
    groups: dict[tuple, list[dict]] = {}
    for r in rs:
        v = r.get("live")
        if not v or r.get("train_steps") is None or v.get("prompt_keep_from") is None:
            continue
        key = (r["name"], r["train_steps"], v["prompt_keep_from"], v.get("window", UNRECORDED_WINDOW), v["cost_frames"],
               tuple(v["gap_seconds"]), (v.get("classifier") or {}).get("sha256"))   # one judge: sessions judged
        # by another classifier file (or none recorded, before 2026-11-28) are not summed with these
        groups.setdefault(key, []).append(r)
    out = []
    for group in groups.values():
        if len({r["live"]["seed"] for r in group}) < 2:
            continue
        row = {}
        for j in ("classifier", "kinematic"):
            xs = [r["live"]["rates"]["all"][j] for r in group if j in r["live"]["rates"]["all"]]
            if xs:
                n = sum(x["n"] for x in xs)
                live, alone = (sum(x[k] * x["n"] for x in xs) / n for k in ("live", "alone"))
                row[j] = {"live": live, "alone": alone, "ratio": live / alone if alone else None, "n": n,
                          "only_live_fails": sum(x["only_live_fails"] for x in xs),
                          "only_alone_fails": sum(x["only_alone_fails"] for x in xs)}
        out.append({"files": sorted(r["_file"] for r in group), "rates": row, "verdict": verdict(row)})
    return out


def section(rs: list[dict]) -> list[str]:
    """The live rows of RESULTS.md's "Seams and loops" section (results with a ``live`` part), and their per-action
    rates side by side."""
    rs = sorted((r for r in rs if r.get("live")), key=lambda r: (r["name"], r["_file"]))
    if not rs:
        return []
    head = ["Result", "Session", "Classifier live / alone", "Kinematic rules live / alone",
            "Alone read after its first second: classifier / kinematic", "Classifier by half, live; alone",
            "Meaning as good as alone", "Blends ≤ 1.5× p95 elsewhere", "Same span mid-segment (no blend)"]
    rows = []
    for r in rs:
        v = r["live"]
        a, p, h, b = v["rates"]["all"], v["verdict"]["p_worse"], v["halves"], v["blends"]
        rows.append([f"`{r['_file']}`", f"{v['changes']} prompt changes every {v['gap_seconds'][0]:g}–{v['gap_seconds'][1]:g} s, "
                     f"{v['segments']} segments ({int(np.median(v['segment_frames']))} frames median), windows of "
                     f"{v.get('window', UNRECORDED_WINDOW)} new frames cost {v['cost_frames']} frames; "
                     f"{r['hardware']}, load {v['load_avg_1min_end']:.1f}, {v['seconds']:.0f} s",
                     _judge_cell(a.get("classifier"), p.get("classifier")), _judge_cell(a.get("kinematic"), p.get("kinematic")),
                     " / ".join(f"{v['rates_alone_late'][j]['alone']:.0%}" for j in ("classifier", "kinematic")
                                if j in v["rates_alone_late"]),
                     f"{h['live']['first']:.0%} / {h['live']['second']:.0%}; {h['alone']['first']:.0%} / {h['alone']['second']:.0%}",
                     "**met**" if v["verdict"]["met"] else "**not met**",
                     f"{b['within']}/{len(b['ratios'])} (max {max(b['ratios']):.2f}×; p95 {b['p95']:.0f} m/s²)",
                     f"{b['placebo_within']}/{len(b['placebo'])} (max {max(b['placebo']):.2f}×)"])
    for g in pooled(rs):
        a, p = g["rates"], g["verdict"]["p_worse"]
        rows.append([" + ".join(f"`{f}`" for f in g["files"]), f"the {len(g['files'])} sessions pooled (same weights "
                     "and stream, other seeds): their paired segments summed", _judge_cell(a.get("classifier"), p.get("classifier")),
                     _judge_cell(a.get("kinematic"), p.get("kinematic")), "", "",
                     "**met**" if g["verdict"]["met"] else "**not met**", "", ""])
    pair = lambda x: "–" if x is None else f"{x['live']:.0%} / {x['alone']:.0%}"  # noqa: E731
    acts = sorted({a for r in rs for a in r["live"]["rates"]["per_action"]})
    per = [[a] + [" · ".join(pair(r["live"]["rates"]["per_action"].get(a, {}).get(j)) for j in ("classifier", "kinematic"))
                  for r in rs] for a in acts]
    table = lambda h, rows: ["| " + " | ".join(h) + " |", "|" + " --- |" * len(h)] + ["| " + " | ".join(c) + " |" for c in rows]  # noqa: E731
    return (table(head, rows) + ["", "Per action, live / alone: classifier · kinematic rule (– : the rule does not judge "
                                 "the action on the real test clips); each session has 10 or 11 segments per action.", ""]
            + table(["Action"] + [f"`{r['_file']}`" for r in rs], per) + [""])

__all__ = ["LiveMeaningError", "blend_ratios", "covered_prompts", "halves", "judge", "measure", "placebo_ratios",
           "pooled", "prompt_blends", "rates", "run", "schedule", "section", "segments", "verdict", "worse_p"]
