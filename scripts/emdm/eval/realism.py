"""Realism per action: is a generated motion as fast, as smooth and as grounded as the real clips of its action,
and does it do the action by a judge other than the classifier? (issue 28)

    python -m emdm.eval.realism --model emdm-t2m-web --variant int8                 # the page's settings
    python -m emdm.eval.realism --model emdm-t2m-web --variant int8 --x0-smoothing 0 --name emdm-t2m-web-int8-raw
    python -m emdm.eval.realism --model emdm-a2m-web

The motions are the coverage benchmark's (``emdm.eval.coverage.Benchmark``): per action of the vocabulary, its
prompts (``prompts.json``; an action model: its one-hot label) × ``--seeds``, lengths drawn from the action's real
test clips. Per action, against those real clips (the reference row):

* **speed**: median horizontal root speed (m/s), the ratio of the motions' median to the real clips' median, and
  the share of motions inside the real range (5th–95th percentile of the action's real clips, widened by
  ``SPEED_SLACK``): a walk at 2.2 m/s when real walks go 0.6–1.5 is out of range.
* **joint step**: every joint's displacement between consecutive frames; its 99th percentile, the share of steps
  over the real clips' largest (``over_all``: pooled over the real test clips of every action; ``over_action``:
  of the same action), and the share of motions with a step over the pooled maximum (a one-frame flip of the feet
  is one such step).
* **ground**: share of airborne frames (both feet above ``kinematics.AIRBORNE``), penetration, floating, foot
  skate (``emdm.eval.plausibility``), and the largest bone-length error (``emdm.eval.poses.check_frames``).
* **feet**: the feet's acceleration (ankles and balls of the feet, m/s², 95th percentile over a motion's frames
  and those four joints pooled; mean over motions, as the skate) against the real clips': what holding a foot still costs the swing that follows (a foot
  clean-up that stops a skate makes the swing make up the distance), beside the skate it trades against.
* **moving**: the motions' median ``peak_speed`` (the fastest joint's speed, 95th percentile over frames) over the
  real clips' median, and the share of motions that *move* (peak speed at least ``STILL`` = a quarter of the 5th
  percentile of the action's real clips; an action with too few test clips takes its train clips': ``train_peaks``):
  a punch whose fists never leave the guard is recognised as a boxer's stance by the classifier, but does not move;
  one throw in a few seconds does.
* **meaning**: the share passing the action's kinematic rule (``emdm.eval.kinematics``; only actions whose rule
  passes ≥ 85 % of their real test clips are judged) beside the share the classifier recognises.

Writes ``docs/results/json/realism-<name>.json``; ``python -m emdm.eval.report`` adds its RESULTS.md section
and plot. One step count of a shipped model takes about five minutes on one thread.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.eval import coverage as C
from emdm.eval import kinematics as K
from emdm.eval.plausibility import batch_plausibility, flip_share
from emdm.eval.poses import check_frames
from emdm.eval import markdown as md
from emdm.eval.args import add_model_source
from emdm.eval.report_plots import save_figure
from emdm.eval.judge import add_argument as add_judge_argument
from emdm.eval.results import RESULTS_DIR, SCHEMA, dataset_info, hardware, slug, write_result
from emdm.eval.sources import ModelSource
from emdm.model.open import ModelError, open_model
from emdm.motion.decode import decode_joints
from emdm.motion.features import recover_joints
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, display_path
from emdm.sampler.flags import add_sampling_settings

SPEED_SLACK = 1.15        # a motion's speed is in range within [p5 / this, p95 × this] of its action's real clips
STEP_Q = 99               # the joint-step percentile reported
# a motion moves when its peak speed is at least this share of the 5th percentile of its action's real clips': a
# quarter of what the slowest real clips reach, so only a motion holding a pose falls under it, not one done more
# calmly than the real clips (few and energetic for some actions: 4 real backward walks peak at 4.5 m/s, a calm one
# at 0.9 m/s peaks near 1.6)
STILL = 0.25


def moving(peak, real_peak) -> np.ndarray:
    """Which motions move: peak speed ≥ STILL × the 5th percentile of the action's real clips' peak speed."""
    return np.asarray(peak, float) >= STILL * float(np.percentile(np.asarray(real_peak, float), 5))


# ----------------------------------------------------------------------------- per motion (pure)

def joint_steps(joints) -> np.ndarray:
    """(F-1, 22) metres each joint moves between consecutive frames."""
    j = np.asarray(joints, np.float64)
    return np.linalg.norm(np.diff(j, axis=0), axis=2)


def foot_acceleration(joints, fps: float = K.FPS) -> float:
    """The feet's (ankles', balls of the feet's) acceleration, m/s²: the 95th percentile over frames and those 4
    joints of the second difference's length (0 for a motion under 3 frames)."""
    j = np.asarray(joints, np.float64)[:, list(sk.FOOT_JOINTS)]
    if len(j) < 3:
        return 0.0
    return float(np.percentile(np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=2), 95) * fps * fps)


def motion_row(joints) -> dict:
    """The per-motion figures: speed, largest joint step, airborne share, largest bone error, feet acceleration,
    descriptors."""
    d = K.descriptors(joints)
    return {"speed": d["speed"], "max_step": float(joint_steps(joints).max()), "airborne": d["airborne"],
            "bone": check_frames(joints).worst_bone, "foot_acc": foot_acceleration(joints), "desc": d}


def speed_in_range(speed, real_speeds) -> np.ndarray:
    """Which speeds lie inside the real clips' range [p5 / SPEED_SLACK, p95 × SPEED_SLACK]."""
    lo, hi = np.percentile(np.asarray(real_speeds, float), [5, 95])
    s = np.asarray(speed, float)
    return (s >= lo / SPEED_SLACK) & (s <= hi * SPEED_SLACK)


def steps_ok(joints, real_max: float) -> bool:
    """No joint moves further between two frames than the real clips' largest step."""
    return bool(joint_steps(joints).max() <= real_max)


# ----------------------------------------------------------------------------- per action (pure)

def group(joints: list[np.ndarray], rows: list[dict], real_max_all: float, real_max_action: float | None,
          real_speeds: np.ndarray | None, real_peak: np.ndarray | None = None,
          real_foot_acc: np.ndarray | None = None) -> dict:
    """The figures of one action's motions (``joints`` with their ``motion_row``s) against the real reference."""
    steps = np.concatenate([joint_steps(j).ravel() for j in joints])
    speed = np.array([r["speed"] for r in rows])
    plaus = batch_plausibility(joints, K.FPS)
    out = {"n": len(rows), "speed": float(np.median(speed)),
           "step_p99": float(np.percentile(steps, STEP_Q)),
           "over_all": float((steps > real_max_all).mean()),
           "motions_over_all": float(np.mean([not steps_ok(j, real_max_all) for j in joints])),
           "max_step": float(steps.max()),
           "airborne": float(np.mean([r["airborne"] for r in rows])),
           "penetration_mm": float(plaus["penetration_mm"].mean()), "floating_mm": float(plaus["floating_mm"].mean()),
           "skate_cm_s": float(plaus["skate_cm_s"].mean()), "skate_ratio": float(plaus["skate_ratio"].mean()),
           "bone_worst": float(np.median([r["bone"] for r in rows])),
           "foot_acc": float(np.mean([r["foot_acc"] for r in rows]))}
    if real_max_action is not None:
        out["over_action"] = float((steps > real_max_action).mean())
        out["motions_over_action"] = float(np.mean([not steps_ok(j, real_max_action) for j in joints]))
    if real_speeds is not None and len(real_speeds):
        out["speed_ratio"] = out["speed"] / max(float(np.median(real_speeds)), 1e-6)
        out["speed_in_range"] = float(speed_in_range(speed, real_speeds).mean())
    if real_foot_acc is not None and len(real_foot_acc):
        out["foot_acc_ratio"] = out["foot_acc"] / max(float(np.mean(real_foot_acc)), 1e-6)
    peak = np.array([r["desc"]["peak_speed"] for r in rows])
    out["peak_speed"] = float(np.median(peak))
    # every kinematic descriptor's median: why a rule fails (realism_diff's "rules" lines: a wave whose wrist is still)
    out["desc"] = {k: float(np.median([r["desc"][k] for r in rows])) for k in K.DESCRIPTORS}
    if real_peak is not None and len(real_peak):
        out["peak_ratio"] = out["peak_speed"] / max(float(np.median(real_peak)), 1e-6)
        out["moving"] = float(moving(peak, real_peak).mean())
    return out


def judge(labels: list[str], action: np.ndarray, rows: list[dict]) -> dict[str, float]:
    """Per action with a kinematic rule and motions: the share of its motions passing the rule (whether the rule
    may judge the action is ``kinematics.judged``'s call, made on the real clips)."""
    desc = {k: np.array([r["desc"][k] for r in rows]) for k in K.DESCRIPTORS}
    out = {}
    for i, a in enumerate(labels):
        sel = action == i
        if a in K.RULES and sel.any():
            out[a] = float(K.passes(a, {k: v[sel] for k, v in desc.items()}).mean())
    return out


def prompt_rows(labels: list[str], action: np.ndarray, prompt_of: list[str], rows: list[dict],
                real_peak: dict[str, list[float]] | None = None) -> dict[str, dict]:
    """Per prompt: its action, motions, median root speed, largest joint step (median over its motions) and the share
    passing its action's kinematic rule (None without a rule): e.g. how fast "a person walks forward" walks; with the
    real clips' peak speeds per action also its median peak speed and the share of its motions that move (``moving``)."""
    out = {}
    for p in dict.fromkeys(prompt_of):
        idx = [k for k, q in enumerate(prompt_of) if q == p]
        a = labels[int(action[idx[0]])]
        desc = {d: np.array([rows[k]["desc"][d] for k in idx]) for d in K.DESCRIPTORS}
        out[p] = {"action": a, "n": len(idx), "speed": float(np.median(desc["speed"])),
                  "max_step": float(np.median([rows[k]["max_step"] for k in idx])),
                  "kinematic": float(K.passes(a, desc).mean()) if a in K.RULES else None,
                  "peak_speed": float(np.median(desc["peak_speed"]))}
        if real_peak and real_peak.get(a):
            out[p]["moving"] = float(moving(desc["peak_speed"], real_peak[a]).mean())
    return out


def measure(labels, action, joints, real: dict | None = None) -> dict:
    """Every action's figures for motions ``joints`` (one action id each); ``real`` is the real row (None: these
    motions ARE the real clips, and become the reference)."""
    rows = [motion_row(j) for j in joints]
    action = np.asarray(action)
    if real is None:
        max_all = max(r["max_step"] for r in rows)
        ref = {"max_step_all": max_all, "max_step": {}, "speeds": {}, "peak_speed": {}, "foot_acc": {}}
        for i, a in enumerate(labels):
            sel = np.flatnonzero(action == i)
            if sel.size:
                ref["max_step"][a] = max(rows[k]["max_step"] for k in sel)
                ref["speeds"][a] = [rows[k]["speed"] for k in sel]
                ref["peak_speed"][a] = [rows[k]["desc"]["peak_speed"] for k in sel]
                ref["foot_acc"][a] = [rows[k]["foot_acc"] for k in sel]
    else:
        ref = real["reference"]
    per = {}
    for i, a in enumerate(labels):
        sel = np.flatnonzero(action == i)
        if sel.size:
            speeds, peaks, acc = ref["speeds"].get(a), ref.get("peak_speed", {}).get(a), ref.get("foot_acc", {}).get(a)
            per[a] = group([joints[k] for k in sel], [rows[k] for k in sel], ref["max_step_all"],
                           ref["max_step"].get(a), None if speeds is None else np.asarray(speeds),
                           None if peaks is None else np.asarray(peaks), None if acc is None else np.asarray(acc))
    every = group(joints, rows, ref["max_step_all"], None, None)
    return {"per_action": per, "all": every, "reference": ref, "rows": rows}


# ----------------------------------------------------------------------------- the run

def default_out(a) -> Path:

    sigma = "" if a.x0_smoothing is None else f"-x0s{a.x0_smoothing:g}"
    model = a.model or slug(Path(a.ckpt).parent.name, Path(a.ckpt).stem)
    raw = "-raw" if getattr(a, "decode", "page") == "raw" else ""
    cap = f"-cap{a.speed_cap:g}" if getattr(a, "speed_cap", None) is not None else ""
    name = a.name or slug(model, None if a.variant in (None, "fp32") else a.variant) + sigma + cap + raw
    return RESULTS_DIR / "json" / f"realism-{slug(name)}.json"


def train_peaks(ref: dict, labels: list[str], action, desc: dict) -> None:
    """Where an action has fewer than ``coverage.MIN_CLIPS`` real test clips, its *moving* floor comes from its train
    clips (``ref["peak_speed"]``; ``ref["peak_from_train"]`` lists those actions): how fast a real joint of the action
    moves is a physical floor, not a held-out measure, and without it a rare action's held pose goes unseen."""
    action = np.asarray(action)
    ref["peak_from_train"] = []
    for i, a in enumerate(labels):
        sel = action == i
        if len(ref["peak_speed"].get(a, [])) < C.MIN_CLIPS and sel.sum() >= C.MIN_CLIPS:
            ref["peak_speed"][a] = [float(v) for v in desc["peak_speed"][sel]]
            ref["peak_from_train"].append(a)


def real_row(bench, labels) -> tuple[dict, dict]:
    """The real test clips' row, and each kinematic rule's validation on them (``kinematics.validate``)."""
    joints = [recover_joints(m) for m in bench.test.motions]
    r = measure(labels, bench.test.actions, joints)
    rows = r.pop("rows")
    validation = K.validate(labels, bench.test.actions, {k: np.array([x["desc"][k] for x in rows]) for k in K.DESCRIPTORS})
    r["kinematic"] = judge(labels, bench.test.actions, rows)
    r["classifier"] = {a: v["rate"] for a, v in bench.real["per_action"].items() if v["rate"] is not None}
    r["n"] = len(joints)
    r["flip_share"] = bench.real["flip_share"]
    return r, validation


def run(a) -> Path:
    t_start = time.time()
    out = check_writable(a.out or default_out(a))
    opened = open_model(a.ckpt if a.ckpt is not None else a.model, models_dir=a.models_dir, variant=a.variant,
                        threads=a.threads)
    guidance, _ = C.model_defaults(opened)
    guidance = guidance if a.guidance is None else a.guidance
    gmin = float(opened.meta.get("guidanceMinTime", 0.0)) if a.guidance_min_time is None else a.guidance_min_time
    sigma = float(opened.meta.get("x0Smoothing", 0.0)) if a.x0_smoothing is None else a.x0_smoothing
    bench = C.Benchmark(a.dataset, a.split, a.classifier, a.prompts, a.seeds, a.seed)
    labels = bench.labels
    real, validation = real_row(bench, labels)
    on_train = {}
    if (Path(a.dataset) / "train.txt").is_file():
        train = K.split_table(a.dataset, "train")
        on_train = K.validate(*train)
        train_peaks(real["reference"], *train)
    src = ModelSource(opened=opened, steps=a.steps, guidance=guidance, guidance_min_time=gmin, x0_smoothing=sigma,
                      speed_cap=a.speed_cap,
                      batch_size=a.batch, threads=a.threads)
    t0 = time.time()
    cond, action, prompt_of = bench.conditions(src)
    motions = src.generate(cond, a.seed)
    t_gen = time.time() - t0
    # the joints judged: as the page and the library show them (smoothed σ = 1, feet cleaned up), or raw
    shown = decode_joints if a.decode == "page" else recover_joints
    gen = measure(labels, action, [shown(m) for m in motions], real)
    if src.task == "text":
        gen["prompts"] = prompt_rows(labels, action, prompt_of, gen["rows"], real["reference"]["peak_speed"])
    gen["kinematic"] = judge(labels, action, gen.pop("rows"))
    gen["classifier"] = {k: v["rate"] for k, v in C.rates(labels, action, bench.predict(motions)).items() if v["n"]}
    gen.pop("reference")
    gen.update({"n": len(motions), "flip_share": flip_share(motions), "generate_seconds": round(t_gen, 1),
                "seconds": round(time.time() - t_start, 1), "load_avg_1min_end": os.getloadavg()[0]})
    result = {"schema": SCHEMA, "task": "realism", "name": a.name or out.stem.removeprefix("realism-"),
              "model": opened.name, "variant": opened.variant, "condition": src.task,
              "info": {k: v for k, v in src.info.items()},
              "key": {**C._key(a, guidance, gmin, sigma), **({"speed_cap": src.speed_cap} if src.speed_cap else {})},
              "steps": a.steps, "speed_cap": src.speed_cap,
              "x0_smoothing": sigma, "decode": a.decode, "labels": labels, "real": real, "generated": gen,
              "rules": {act: {"rule": v["rule"], "own": v["own"], "n": v["n"], "false_pass": v["false_pass"],
                              "own_train": on_train.get(act, {}).get("own"), "n_train": on_train.get(act, {}).get("n"),
                              "confused": v["confused"], "confused_rate": v["confused_rate"]}
                        for act, v in validation.items()},
              "judged": K.judged(validation), "bar": K.BAR, "min_clips": K.MIN_CLIPS, "speed_slack": SPEED_SLACK,
              "dataset": dataset_info(Path(a.dataset), a.split), "hardware": hardware(),
              "classifier": bench.judge.info(),
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    write_result(result, out)
    g = gen["all"]
    print(f"[{result['name']}] {len(motions)} motions, {gen['seconds']:.0f} s in all: joint step p99 {g['step_p99']:.3f} m, "
          f"motions with a step over the real maximum {g['motions_over_all']:.1%}, airborne {g['airborne']:.1%}")
    for p, e in gen.get("prompts", {}).items():
        if e["action"] in ("walk", "dance"):
            print(f"  \"{p}\": speed {e['speed']:.2f} m/s, median largest joint step {e['max_step']:.2f} m, "
                  f"kinematic {_p(e['kinematic'])}")
    for act in ("walk", "run", "dance"):
        if act in gen["per_action"]:
            p = gen["per_action"][act]
            real = (f"× {p['speed_ratio']:.2f} real, in range {_p(p.get('speed_in_range'))}" if "speed_ratio" in p
                    else "no real clips to compare")
            print(f"  {act}: speed {p['speed']:.2f} m/s ({real}), kinematic {_p(gen['kinematic'].get(act))}, "
                  f"classifier {_p(gen['classifier'].get(act))}")
    return out


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.realism", description=__doc__.split("\n\n")[0])
    add_model_source(ap)
    ap.add_argument("--name", default=None, help="result name (default: model, variant and --x0-smoothing)")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--seeds", type=int, default=8, help="motions per prompt")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--guidance", type=float, default=None, help="default: the manifest's")
    add_sampling_settings(ap)
    ap.add_argument("--speed-cap", type=float, default=None, metavar="C",
                    help="the sampler's root speed cap: each motion at most C times its first step's root speed "
                         "(emdm.sampler.sampler; default: the manifest's speedCap, else 0 = off)")
    ap.add_argument("--decode", choices=["page", "raw"], default="page",
                    help="judge the joints as the page shows them (page: σ = 1 smoothing and foot clean-up, "
                         "emdm.motion.decode) or as recovered (raw); the classifier reads the sampler's features")
    ap.add_argument("--data", "--dataset", dest="dataset", type=Path, default=DATASET_DIR)
    ap.add_argument("--split", default="test")
    add_judge_argument(ap)
    ap.add_argument("--prompts", type=Path, default=C.PROMPTS_FILE)
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--out", type=Path, default=None, help="default docs/results/json/realism-<name>.json")
    return ap


def main(argv: list[str] | None = None) -> int:
    import torch

    a = build_parser().parse_args(argv)
    torch.set_num_threads(a.threads)
    try:
        print(f"wrote {display_path(run(a))}")
    except (C.CoverageError, FileNotFoundError, ModelError, OutputRefused, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0



# ----------------------------------------------------------------------------- RESULTS.md

def _p(v, fmt="{:.0%}") -> str:
    return "–" if v is None else fmt.format(v)


def _setting(r: dict) -> str:
    k = r.get("key", {})
    return (f"{r.get('model', r['name'])} {k.get('variant_file', '')} file, {r.get('steps', '?')} steps, guidance "
            f"{k.get('guidance', '?')}" + (f" at t > {k['guidance_min_time']:g}" if k.get("guidance_min_time") else "") +
            f", x̂0 smoothing σ {r.get('x0_smoothing', 0):g}, {k.get('seeds', '?')} seeds per prompt")


def _foot_acc(g: dict, rv: dict | None) -> str:
    """The feet-acceleration cell: generated (real), – for a result measured before it existed."""
    if "foot_acc" not in g:
        return "–"
    return f"{g['foot_acc']:.0f} ({rv['foot_acc']:.0f})" if rv and "foot_acc" in rv else f"{g['foot_acc']:.0f}"


def section(r: dict, plot: str | None = None) -> list[str]:
    """One realism result: per action, the generated figures beside the real clips' (in brackets)."""
    real, gen = r["real"], r["generated"]
    header = ["Action", "Real clips", "Speed m/s (real)", "× real", "In real range", "Step p99 m (real)",
              "Motions with a step > real max (all / action)", "Steps > real max (all / action)", "Airborne (real)", "Feet accel. m/s² (real)", "Moving: peak speed × real, motions that move", "Kinematic rule (real)", "Classifier (real)"]
    rows = []
    for a in r["labels"] + ["all"]:
        g = gen["all"] if a == "all" else gen["per_action"].get(a)
        rv = real["all"] if a == "all" else real["per_action"].get(a)
        if g is None:
            continue
        rows.append([f"**{a}**" if a == "all" else a, str(rv["n"]) if rv else "0",
                     f"{g['speed']:.2f} ({rv['speed']:.2f})" if rv else f"{g['speed']:.2f}",
                     _p(g.get("speed_ratio"), "{:.2f}"), _p(g.get("speed_in_range")),
                     f"{g['step_p99']:.3f} ({rv['step_p99']:.3f})" if rv else f"{g['step_p99']:.3f}",
                     f"{_p(g['motions_over_all'])} / {_p(g.get('motions_over_action'))}", f"{g['over_all']:.2%} / {_p(g.get('over_action'), '{:.2%}')}",
                     f"{g['airborne']:.1%} ({rv['airborne']:.1%})" if rv else f"{g['airborne']:.1%}",
                     _foot_acc(g, rv),
                     f"× {g['peak_ratio']:.2f}, {_p(g['moving'])}" if "moving" in g else "–",
                     f"{_p(gen['kinematic'].get(a))} ({_p(real['kinematic'].get(a))})" if a in r["judged"] else "not judged",
                     f"{_p(gen['classifier'].get(a))} ({_p(real['classifier'].get(a))})"])
    ref = real["reference"]
    return [f"### {r['name']}: {_setting(r)}", "",
            f"{gen['n']} motions against {real['n']} real test clips. *Speed*: median horizontal root speed (median over "
            f"motions); *in real range*: motions whose speed lies within the action's real 5th–95th percentile widened by "
            f"× {r['speed_slack']:g}. *Step*: every joint's displacement between consecutive frames; the real maximum is "
            f"{ref['max_step_all']:.3f} m over the real test clips of all actions. *Airborne*: frames with both feet "
            f"higher than {100 * K.AIRBORNE:.0f} cm. *Feet accel.*: the ankles' and balls of the feet's acceleration, 95th "
            f"percentile over a motion's frames and those four joints, mean over motions (holding a foot still makes the swing after it "
            f"faster). *Moving*: the motions' median peak speed (the fastest joint's speed, 95th "
            f"percentile over frames) over the real clips', and the share of motions with at least {STILL:g} × the real "
            f"clips' 5th percentile (the rest hold a pose). *Kinematic rule*: share passing the action's rule (table below); "
            f"*classifier*: share the action classifier names as the action.", "",
            md.table(header, rows), "",
            f"All motions: penetration {gen['all']['penetration_mm']:.1f} mm (real {real['all']['penetration_mm']:.1f}), "
            f"floating {gen['all']['floating_mm']:.1f} mm (real {real['all']['floating_mm']:.1f}), foot skate "
            f"{gen['all']['skate_cm_s']:.1f} cm/s (real {real['all']['skate_cm_s']:.1f}), " + (
                f"feet acceleration {gen['all']['foot_acc']:.0f} m/s² (real {real['all']['foot_acc']:.0f}), "
                if "foot_acc" in gen["all"] and "foot_acc" in real["all"] else "") + f"median largest bone-length error "
            f"{gen['all']['bone_worst']:.1%} (real {real['all']['bone_worst']:.1%}), joint steps over the real maximum "
            f"{gen['all']['over_all']:.2%}, frames with a one-frame flip {gen['flip_share']:.2%} (real {real['flip_share']:.2%}).",
            "", f"Measured on {r.get('hardware', '?')} in {gen['seconds'] / 60:.1f} min ({gen['generate_seconds'] / 60:.1f} "
            f"min sampling; load average {gen.get('load_avg_1min_end', 0):.0f} at the end). "
            f"Classifier: {r.get('classifier', {}).get('summary', '?')}.", ""] + ([f"![realism of {r['name']}]({plot})", ""] if plot else [])


def rules_section(r: dict) -> list[str]:
    """The kinematic rules and their validation on the real test clips."""
    rows = [[a, v["rule"], f"{_p(v.get('own_train'))} ({v.get('n_train') or 0})", f"{_p(v['own'])} ({v['n']})", _p(v["false_pass"], "{:.1%}"),
             f"{v['confused']} {v['confused_rate']:.0%}" if v["confused"] else "–",
             "✓" if a in r["judged"] else ("no test clips" if not v["n"] else "too few test clips"
                                           if v["n"] < r.get("min_clips", 3) else "below the bar")]
            for a, v in r["rules"].items()]
    none = [a for a in r["labels"] if a not in r["rules"]]
    return ["### Kinematic rules (`emdm/eval/kinematics.py`)", "",
            f"Each rule's thresholds were read off the train split; an action is judged when its rule passes ≥ "
            f"{r['bar']:.0%} of its real test clips, of which it needs at least {r.get('min_clips', 3)}. *False pass*: share of the other actions' test clips that pass it.", "",
            md.table(["Action", "Rule", "Own train clips", "Own test clips", "False pass", "Most confused with", "Judged"], rows), "",
            "No rule: " + ", ".join(none) + ".", ""]


def comparison(results: list[dict]) -> list[str]:
    """Per action, speed ratio / motions over the real step maximum / moving / kinematic / classifier, one column per
    result (moving: – for a result measured before it existed, or an action without real clips)."""
    labels = results[0]["labels"]
    header = ["Action"] + [f"{r['name']}: × speed · > max (all / action) · moves · kin. · cls." for r in results]
    rows = []
    for a in labels + ["all"]:
        cells = []
        for r in results:
            g = r["generated"]["all"] if a == "all" else r["generated"]["per_action"].get(a)
            if g is None:
                cells.append("–")
                continue
            kin = _p(r["generated"]["kinematic"].get(a)) if a in r["judged"] else "n/j"
            cells.append(f"{_p(g.get('speed_ratio'), '{:.2f}')} · {g['motions_over_all']:.0%} / "
                         f"{_p(g.get('motions_over_action'))} · {_p(g.get('moving'))} · {kin} · "
                         f"{_p(r['generated']['classifier'].get(a))}")
        rows.append([a] + cells)
    # results of older weights cannot be measured again: where a later classifier judged the newer ones, say which
    # (told apart by the files' sha256 where recorded: two classifiers of one config can share a summary)
    judges: dict[str, tuple[str, list[str]]] = {}
    for r in results:
        c = r.get("classifier") or {}
        summary = c.get("summary", "an unrecorded classifier")
        judges.setdefault(c.get("sha256") or summary, (summary, []))[1].append(r["name"])
    by = ("" if len(judges) < 2 else " Each column's classifier is its own result's: " + "; ".join(
        f"{', '.join(names)}: {summary}" + ("" if sum(s == summary for s, _ in judges.values()) < 2 else f" (sha256 {key})")
        for key, (summary, names) in judges.items()) + ".")
    return ["### Side by side", "", "Per action: speed ÷ real · motions with a joint step over the real maximum (of all actions' clips / of the "
            "action's own) · "
            "motions that move (peak joint speed ≥ a quarter of the real clips' 5th percentile) · kinematic rule (n/j: not judged) · "
            "classifier." + by, "", md.table(header, rows), ""]


def plot(r: dict, path: Path) -> bool:
    """Two panels per action: speed ÷ real, and the share of motions with a joint step over the real maximum."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    gen = r["generated"]["per_action"]
    labels = [a for a in r["labels"] if a in gen]
    y = np.arange(len(labels))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(9, 0.28 * len(labels) + 1.4), dpi=100, sharey=True)
    ax1.barh(y, [gen[a].get("speed_ratio", np.nan) for a in labels], color="tab:blue")
    ax1.axvline(1.0, color="k", lw=0.8, ls="--")
    ax1.set_xlabel("median root speed ÷ real clips' (dashed: real)")
    ax2.barh(y - 0.2, [gen[a]["motions_over_all"] for a in labels], 0.4, color="tab:red", label="all actions' clips")
    ax2.barh(y + 0.2, [gen[a].get("motions_over_action", np.nan) for a in labels], 0.4, color="tab:orange",
             label="the action's own clips")
    ax2.set_xlim(0, 1)
    ax2.set_xlabel("motions with a joint step over the real maximum of ...")
    ax2.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=2, frameon=False)
    ax1.set_yticks(y, labels, fontsize=7)
    ax1.set_ylim(len(labels) - 0.5, -0.5)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, axis="x")
    fig.suptitle(f"Realism per action: {r['name']}", fontsize=9, y=0.995)
    return save_figure(fig, path)


if __name__ == "__main__":
    sys.exit(main())
