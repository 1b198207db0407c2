"""The seams and loops that exist already, measured as a new user meets them (issue 33, its first bar): timelines of
``emdm.motion.edit`` and loops with and without "in place", on a shipped model (the page's file) and decoded as the
page shows them (``emdm.motion.decode.decode_joints``: σ = 1 smoothing, feet cleaned up).

    nice python -m emdm.eval.seams                 # about 3 minutes on 2 cores (70 s of it live); figures printed, JSON written
    python -m emdm.eval.report                     # RESULTS.md's "Seams and loops" section

What is measured (20 fps, metres):

* timeline seams: the walk → wave-both-hands → bow timeline (``--seeds`` seeds) and timelines of prompt changes
  drawn from the coverage prompts (``prompts.json``'s plain prompts, at least ``--changes`` seams). At each seam s
  (a segment's first new frame): the joint acceleration max(acc[s−1], acc[s]) (``emdm.motion.edit.joint_acceleration``)
  and the largest joint step |J[s] − J[s−1]|, each against the 95th percentile of the same measure on the timeline's
  frames two or more frames from every seam. Bar: acceleration within 1.5× (issue 33).
* loops of "a person walks" (a ``--loop-seconds`` s motion, each seed), plain and in place: stride (the front–back
  range, 5th–95th percentile, of each ankle relative to the pelvis along the body's heading, mean of the two feet)
  and foot lift (the same range of each ankle's height) of the looping clip against the motion it loops; the wrap
  (the clip played again: its last frame to its first, the root's x/z carried on for a travelling loop) against the
  clip's largest in-loop joint step. Bars: stride and lift within 30 % of the plain motion's, wrap ≤ largest step.
  The loop re-generates all but its ends, so its gait against the plain motion varies with the seed either way; an
  in-place loop is also set against the same loop travelling (what "in place" itself changes). The clip is decoded
  as a loop (``decode_joints(loop=True)``), as the page plays it.

* live segments (``--live-changes``, 0: none): a session of the live stream's Python twin with that many prompt changes
  drawn from the model's covered actions, each segment judged by the action classifier and the kinematic rules against
  the same prompt generated alone, and each prompt's blend by the Node benchmark's statistic
  (``emdm.eval.live_meaning``; it reads the prepared dataset's test clips and the classifier).

Writes ``docs/results/json/seams-<model>.json`` (schema 1, task ``seams``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from emdm.eval import live_meaning as LM
from emdm.data.dataset import DatasetError
from emdm.eval.coverage import PROMPTS_FILE, CoverageError
from emdm.eval.editing_run import page_variant
from emdm.eval.judge import add_argument as add_judge_argument
from emdm.eval.results import RESULTS_DIR, SCHEMA, hardware, write_result
from emdm.eval.models_report import total_steps
from emdm.model.open import open_model
from emdm.motion import edit as E
from emdm.motion import live as L
from emdm.motion.decode import decode_joints
from emdm.motion.features import heading_angles
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, models_dir

FPS = 20
SHOWCASE = ("a person walks", "a person waves both hands", "a person bows")
LOOP_PROMPT = "a person walks"
BARS = {"seam_acceleration": 1.5, "gait": 0.3, "wrap": 1.0}
ANKLES = (7, 8)


class SeamsError(ValueError):
    """An input of the benchmark cannot be used (the message names it)."""


# ----------------------------------------------------------------------------------------------- measures (pure)

def joint_steps(joints: np.ndarray) -> np.ndarray:
    """(F−1,) the largest joint displacement from frame t to t+1, metres."""
    j = np.asarray(joints, np.float64)
    return np.linalg.norm(j[1:] - j[:-1], axis=2).max(axis=1)


def seam_figures(joints: np.ndarray, seams) -> list[dict]:
    """Per seam s: acceleration (m/s²) and joint step (m) at the seam and their 95th percentiles away from seams."""
    acc, step = E.joint_acceleration(joints, FPS), joint_steps(joints)
    away = np.ones(len(acc), bool)
    for s in seams:
        away[max(0, s - 2):s + 2] = False
    away[[0, -1]] = False
    acc95, step95 = float(np.percentile(acc[away], 95)), float(np.percentile(step[away[:-1]], 95))
    return [{"frame": int(s), "acc": float(max(acc[s - 1], acc[s])), "acc_p95": acc95,
             "acc_ratio": float(max(acc[s - 1], acc[s]) / acc95), "step": float(step[s - 1]), "step_p95": step95,
             "step_ratio": float(step[s - 1] / step95)} for s in seams]


def gait(joints: np.ndarray) -> dict:
    """Stride and foot lift (module doc), metres; travel: the pelvis's x/z distance from first to last frame."""
    j = np.asarray(joints, np.float64)
    th = heading_angles(j)
    fwd = np.stack([np.sin(th), np.cos(th)], 1)
    rel = j[:, ANKLES][:, :, [0, 2]] - j[:, None, 0, [0, 2]]
    along = (rel * fwd[:, None]).sum(-1)
    spread = lambda v: float(np.mean([np.percentile(v[:, k], 95) - np.percentile(v[:, k], 5) for k in range(v.shape[1])]))
    return {"stride": spread(along), "lift": spread(j[:, ANKLES, 1]),
            "travel": float(np.linalg.norm(j[-1, 0, [0, 2]] - j[0, 0, [0, 2]]))}


def wrap_step(clip: np.ndarray) -> float:
    """The largest joint step from the clip's last frame to its first as a loop plays it: a travelling clip's
    first frame carried to where its root has got (x/z of the pelvis; an in-place clip's stays)."""
    c = np.asarray(clip, np.float64)
    first = c[0].copy()
    first[:, [0, 2]] += c[-1, 0, [0, 2]] - c[0, 0, [0, 2]] + (c[-1, 0, [0, 2]] - c[-2, 0, [0, 2]])
    return float(np.linalg.norm(first - c[-1], axis=1).max())


def summary(values) -> dict:
    v = np.asarray(values, np.float64)
    return {"n": int(v.size), "min": float(v.min()), "median": float(np.median(v)), "p95": float(np.percentile(v, 95)),
            "max": float(v.max())}


# ----------------------------------------------------------------------------------------------- runs

def change_timelines(prompts: list[str], changes: int, seed: int) -> list[tuple[str, ...]]:
    """Timelines of 3 segments, consecutive prompts different, enough for ``changes`` seams."""
    rng = np.random.default_rng(seed)
    out = []
    while 2 * len(out) < changes:
        a = rng.choice(len(prompts))
        b = rng.choice([i for i in range(len(prompts)) if i != a])
        c = rng.choice([i for i in range(len(prompts)) if i != b])
        out.append((prompts[a], prompts[b], prompts[c]))
    return out


def measure_timelines(model, orders, seconds: float, seed0: int) -> list[dict]:
    rows = []
    for k, prompts in enumerate(orders):
        segs = [E.Segment(p, seconds, seed0 + 10 * k + i) for i, p in enumerate(prompts)]
        tl = E.timeline(model, segs)
        for i, f in enumerate(seam_figures(decode_joints(tl.features), tl.starts[1:])):
            rows.append({"timeline": k, "from": prompts[i], "to": prompts[i + 1], **f})
    return rows


def measure_loops(model, seeds, seconds: float) -> list[dict]:
    rows = []
    for seed in seeds:
        plain = model.denormalise(model.sample(LOOP_PROMPT, E.segment_frames(seconds), seed))
        before = gait(decode_joints(plain))
        for in_place in (False, True):
            lp = E.loop(model, plain, LOOP_PROMPT, seed, in_place=in_place)
            clip = decode_joints(lp.features, loop=True)   # as the page shows the clip: played in a loop
            g = gait(clip)
            rows.append({"seed": seed, "in_place": in_place, "plain": before, "loop": g,
                         "stride_ratio": g["stride"] / before["stride"], "lift_ratio": g["lift"] / before["lift"],
                         "wrap": wrap_step(clip), "largest_step": float(joint_steps(clip).max())})
    return rows


def figures(seams: list[dict], showcase: list[dict], loops: list[dict]) -> dict:
    out = {"seams": {"acc_ratio": summary([r["acc_ratio"] for r in seams]),
                     "step_ratio": summary([r["step_ratio"] for r in seams]),
                     "within_bar": sum(r["acc_ratio"] <= BARS["seam_acceleration"] for r in seams)},
           "showcase_first_seam": {k: summary([r[k] for r in showcase if r["frame"] == showcase[0]["frame"]])
                                   for k in ("acc_ratio", "step", "step_p95")},
           "showcase": {"acc_ratio": summary([r["acc_ratio"] for r in showcase]),
                        "within_bar": sum(r["acc_ratio"] <= BARS["seam_acceleration"] for r in showcase)}}
    for ip in (False, True):
        rs = [r for r in loops if r["in_place"] == ip]
        out["loop_in_place" if ip else "loop"] = {
            "stride_ratio": summary([r["stride_ratio"] for r in rs]), "lift_ratio": summary([r["lift_ratio"] for r in rs]),
            "stride_m": summary([r["loop"]["stride"] for r in rs]), "lift_m": summary([r["loop"]["lift"] for r in rs]),
            "wrap_over_largest": summary([r["wrap"] / r["largest_step"] for r in rs]),
            "wrap_m": summary([r["wrap"] for r in rs]), "largest_step_m": summary([r["largest_step"] for r in rs]),
            "gait_within_bar": sum(abs(r["stride_ratio"] - 1) <= BARS["gait"] and abs(r["lift_ratio"] - 1) <= BARS["gait"]
                                   for r in rs),
            "wrap_within_bar": sum(r["wrap"] <= r["largest_step"] for r in rs), "n": len(rs)}
    # what "in place" itself changes: each in-place loop against the same seed's loop travelling
    moving = {r["seed"]: r["loop"] for r in loops if not r["in_place"]}
    vs = [{k: r["loop"][k] / moving[r["seed"]][k] for k in ("stride", "lift")} for r in loops if r["in_place"]]
    out["in_place_vs_travelling"] = {f"{k}_ratio": summary([v[k] for v in vs]) for k in ("stride", "lift")}
    out["in_place_vs_travelling"]["within_bar"] = sum(all(abs(v[k] - 1) <= BARS["gait"] for k in v) for v in vs)
    return out


def report(fig: dict, log=print) -> None:
    s, sc = fig["seams"], fig["showcase_first_seam"]
    log(f"prompt changes: {s['acc_ratio']['n']} seams, acceleration / p95 elsewhere: median {s['acc_ratio']['median']:.2f}, "
        f"p95 {s['acc_ratio']['p95']:.2f}, max {s['acc_ratio']['max']:.2f}; within 1.5×: {s['within_bar']} of {s['acc_ratio']['n']}; "
        f"joint step / p95: median {s['step_ratio']['median']:.2f}, max {s['step_ratio']['max']:.2f}")
    log(f"walk → wave both hands → bow, first seam over {sc['acc_ratio']['n']} seeds: acceleration / p95 median "
        f"{sc['acc_ratio']['median']:.2f}, max {sc['acc_ratio']['max']:.2f}; joint step median {sc['step']['median']:.3f} m, "
        f"max {sc['step']['max']:.3f} m (p95 elsewhere median {sc['step_p95']['median']:.3f} m); all seams within 1.5×: "
        f"{fig['showcase']['within_bar']} of {fig['showcase']['acc_ratio']['n']}")
    for key, what in (("loop", "loop"), ("loop_in_place", "loop in place")):
        l = fig[key]
        log(f"{what} ({l['n']} seeds): stride {l['stride_m']['median']:.3f} m (× plain: median {l['stride_ratio']['median']:.2f}, "
            f"range {min_max(l, 'stride')}), foot lift {l['lift_m']['median']:.3f} m (× plain: median "
            f"{l['lift_ratio']['median']:.2f}, range {min_max(l, 'lift')}), within 30 %: {l['gait_within_bar']}; wrap "
            f"{l['wrap_m']['median']:.3f} m (max {l['wrap_m']['max']:.3f}) vs largest in-loop step {l['largest_step_m']['median']:.3f} m, "
            f"wrap ≤ largest: {l['wrap_within_bar']} of {l['n']}")
    v = fig["in_place_vs_travelling"]
    log(f"in place against the same loop travelling: stride × {min_max(v, 'stride')}, lift × {min_max(v, 'lift')}; "
        f"within 30 %: {v['within_bar']} of {v['stride_ratio']['n']}")


def min_max(l: dict, what: str) -> str:
    return f"{l[what + '_ratio']['min']:.2f}–{l[what + '_ratio']['max']:.2f}"


def section(rs: list[dict]) -> list[str]:
    """docs/RESULTS.md's "Seams and loops" rows, one per result file (``emdm.eval.report``)."""
    rows = []
    for r in sorted(rs, key=lambda r: (r["name"], r["_file"])):
        f = r["figures"]
        s, sc, ip = f["seams"], f["showcase_first_seam"], f["in_place_vs_travelling"]
        wrap = lambda l: f"{l['wrap_within_bar']}/{l['n']} (max {l['wrap_m']['max']:.2f} m)"   # noqa: E731
        rows.append([f"`{r['_file']}`", f"{s['within_bar']}/{s['acc_ratio']['n']} (max {s['acc_ratio']['max']:.2f}×)",
                     f"{s['step_ratio']['max']:.2f}×",
                     f"{sc['step']['max']:.2f} m (p95 {sc['step_p95']['median']:.2f} m); {f['showcase']['within_bar']}/"
                     f"{f['showcase']['acc_ratio']['n']}", wrap(f["loop"]), wrap(f["loop_in_place"]),
                     f"{ip['stride_ratio']['min']:.2f}–{ip['stride_ratio']['max']:.2f} / "
                     f"{ip['lift_ratio']['min']:.2f}–{ip['lift_ratio']['max']:.2f}",
                     f"{f['loop']['gait_within_bar']}/{f['loop']['n']}, {f['loop_in_place']['gait_within_bar']}/"
                     f"{f['loop_in_place']['n']}"])
    head = ["Result", "Prompt-change seams: accel ≤ 1.5× p95", "largest seam step / p95",
            "walk → wave → bow: largest first-seam step; seams ≤ 1.5×", "Loop wrap ≤ largest step",
            "In place: wrap ≤ largest step", "In place vs travelling: stride / lift", "Loop gait within 30 % of the plain walk"]
    return (["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)] + ["| " + " | ".join(c) + " |" for c in rows] + [""]
            + LM.section(rs))


def run(a, log=print) -> Path:
    out = check_writable(a.out or (RESULTS_DIR / "json" / f"seams-{a.model}{'-' + a.tag if a.tag else ''}.json"))
    try:
        prompts = sorted(e["plain"] for e in json.loads(Path(a.prompts).read_text())["actions"].values())
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise SeamsError(f"--prompts {a.prompts}: expected coverage prompts {{\"actions\": {{label: {{\"plain\": ...}}}}}} ({e})") from None
    capabilities = a.capabilities or models_dir(a.models_dir) / f"capabilities-{a.model}.json"
    if a.live_changes:
        LM.covered_prompts(capabilities)            # before anything is measured
    t0 = time.time()
    variant = page_variant(a.model, a.models_dir)
    opened = open_model(a.model, models_dir=a.models_dir, threads=a.threads, variant=variant)
    model = E.Editor.open(opened)
    showcase = measure_timelines(model, [SHOWCASE] * a.seeds, a.seconds, a.seed)
    seams = measure_timelines(model, change_timelines(prompts, a.changes, a.seed), a.seconds, a.seed + 1000)
    loops = measure_loops(model, range(a.seed, a.seed + a.seeds), a.loop_seconds)
    fig = figures(seams, showcase, loops)
    report(fig, log)
    live = (LM.run(model, a.dataset, a.classifier, capabilities, a.live_changes, a.seed, a.live_cost, log,
                   a.live_window) if a.live_changes else None)
    result = {"schema": SCHEMA, "task": "seams", "name": a.model, "variant": opened.variant,
              "train_steps": total_steps(opened.meta) if opened.meta.get("training") else None,
              "steps": model.settings.steps, "decode": "page (smooth σ=1, foot cleanup)", "segment_seconds": a.seconds,
              "loop_seconds": a.loop_seconds, "seed": a.seed, "bars": BARS, "figures": fig,
              "rows": {"showcase": showcase, "changes": seams, "loops": loops}, **({"live": live} if live else {}),
              "hardware": hardware(),
              "seconds": round(time.time() - t0, 1), "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    return write_result(result, out)


def parse_args(argv=None):
    p = argparse.ArgumentParser(prog="python -m emdm.eval.seams", description=__doc__.split("\n\n")[0])
    p.add_argument("--model", default="emdm-t2m-web", help="a shipped text model (the page's file of it)")
    p.add_argument("--models-dir", type=Path, default=None)
    p.add_argument("--prompts", type=Path, default=PROMPTS_FILE, help="the coverage prompts (their plain prompts)")
    p.add_argument("--changes", type=int, default=50, help="prompt changes (seams) to measure, at least")
    p.add_argument("--seeds", type=int, default=8, help="seeds of the walk → wave → bow timeline and of the loops")
    p.add_argument("--seconds", type=float, default=4.0, help="seconds of each timeline segment")
    p.add_argument("--loop-seconds", type=float, default=6.0, help="seconds of the walk a loop is made of")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--live-changes", type=int, default=180, help="prompt changes of the live session (0: none)")
    p.add_argument("--live-cost", type=int, default=LM.COST, help="frames each live window costs")
    p.add_argument("--live-window", type=int, default=L.WINDOW,
                   help="new frames of each live window (the stream's default)")
    p.add_argument("--capabilities", type=Path, default=None, help="the covered actions' prompts (default: the model's "
                   "capabilities file beside it)")
    p.add_argument("--dataset", type=Path, default=DATASET_DIR, help="the prepared dataset (its test clips: the judges' reference)")
    add_judge_argument(p)
    p.add_argument("--tag", default="", help="a suffix of the result file's name (e.g. before)")
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    for name in ("changes", "seeds", "threads", "live_cost", "live_window"):
        if getattr(a, name) < 1:
            p.error(f"--{name.replace('_', '-')} must be at least 1, got {getattr(a, name)}")
    if a.live_changes < 0:
        p.error(f"--live-changes must be 0 (no live session) or more, got {a.live_changes}")
    if not a.seconds > 1 or not a.loop_seconds > 1.05:
        p.error("--seconds and --loop-seconds must be over 1 s (a segment continues the last second)")
    return a


def main(argv=None) -> int:
    a = parse_args(argv)
    try:
        out = run(a)
    except (SeamsError, LM.LiveMeaningError, CoverageError, DatasetError, E.EditError, OutputRefused, FileNotFoundError) as e:
        print(f"emdm.eval.seams: {e}", file=sys.stderr)
        return 2
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
