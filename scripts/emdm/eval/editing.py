"""Beyond one prompt, measured (issue 14): timelines, in-betweening, body-part edits and loops of ``emdm.motion.edit``
on a shipped model, against the issue's bars.

    nice -n 10 python -m emdm.eval.editing --model emdm-t2m-web        # 10 steps, CPU; a few minutes on 2 cores
    python -m emdm.eval.report                                          # RESULTS.md's "Beyond one prompt" section
    python -m emdm.eval.editing --time-only --ckpt public/models/emdm-t2m-web.weights.f16.pt [--device cuda]
                                        # the time bar alone, on PyTorch (scripts/gpu/editing-time.sh on a GPU)

What is measured (joints from ``recover_joints`` / the timeline's stitched joints, 20 fps):

* seams of 3 × 5 s timelines (prompts: the plain prompts of ``--actions`` in ``prompts.json``, random orders):
  joint acceleration at a seam (the larger of the two second differences that span the step from a segment's
  last frame to the next one's first, max over joints) against the 95th percentile of the same measure on the
  timeline's frames away from seams; foot skate (horizontal speed of a toe joint below 5 cm in two consecutive
  frames, ``emdm.eval.plausibility``'s definition) on frame pairs within 3 frames of a seam against the pairs away
  from seams in the two segments that seam joins (``seam_skate``; pooled over all segments too);
  root x/z step and heading change at a seam against their 95th percentile within segments. The same seam
  measures at the middle frame of real test clips and of single generated motions are the reference (what a
  continuous motion scores).
* semantics: each timeline segment's new frames classified by the coverage benchmark's action classifier
  (``emdm.eval.coverage.Benchmark``), against single 5 s motions of the same prompts.
* kept parts (after decoding): in-betweening (first and last second kept: world joints of kept frames), keeping the
  lower body (world legs and pelvis), keeping the upper body (its joints relative to the root, in the root's frame),
  and the timeline's overlap (the re-generated copy of the previous second, aligned, against it), in mm.
* loops (K = 10): frame 0's pose against frame N−K's (the frame the clip wraps to), per joint, root-relative and
  facing +Z, in cm; the acceleration at the wrap against the loop's own 95th percentile; root travel with ``in
  place``.
* time: a 3 × 5 s timeline against one 5 s motion (sampling + decoding, text encodings cached), interleaved runs.

Writes ``docs/results/json/editing-<model>.json`` (schema 1, task ``editing``); ``section`` renders it for
``emdm.eval.report``. The load average is recorded: timings on a shared CPU are labelled with it.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

from emdm.eval.plausibility import CONTACT_HEIGHT, FLIP_M, FOOT_JOINTS, flip_share, flips
from emdm.paths import DATASET_DIR, RUNS_DIR, display_path

FPS = 20
ACTIONS = ("walk", "raise-both-hands", "walk-backward", "walk-turn-left", "climb", "lie-down")
LAST_ONLY = ("lie-down",)          # a timeline puts these last (nothing in the data gets up from lying down)
SEAM_SKATE_FRAMES = 3              # frame pairs within this many frames of a seam count as "at the seam"
FLIP_FRAMES = 3                    # a seam "sits on a flip" when one is within this many frames of it
TRANSITION_FRAMES = (0, 5, 10, 20)  # segments 2 and 3 are also read without their first d frames (a diagnostic)
BARS = {"seam_acceleration": 1.5, "seam_skate": 1.2, "seam_root": 1.5, "semantics": 0.8, "kept_mm": 1.0,
        "loop_pose_cm": 2.0, "in_place_cm": 5.0, "time_ratio": 3.0}
LEGS = (0, 1, 2, 4, 5, 7, 8, 10, 11)                    # pelvis, hips, knees, ankles, feet
UPPER = (3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21)


class EditingError(ValueError):
    """An input of the benchmark cannot be used (the message names it)."""


# ----------------------------------------------------------------------------------------------- measures (pure)

def acceleration(joints: np.ndarray) -> np.ndarray:
    """(F,) per frame t = 1..F−2 (0 at the ends): max over joints of |J[t+1] − 2J[t] + J[t−1]|·fps², m/s² (the
    measure the timeline's seam easing keeps to: ``emdm.motion.edit.joint_acceleration``)."""
    from emdm.motion.edit import joint_acceleration
    return joint_acceleration(joints, FPS)


def _away(n: int, seams, radius: int) -> np.ndarray:
    ok = np.ones(n, bool)
    for s in seams:
        ok[max(0, s - radius):s + radius] = False
    return ok


def seam_acceleration(joints: np.ndarray, seams) -> list[float]:
    """Per seam s (first frame of a new segment): max(acc[s−1], acc[s]) / p95 of acc away from every seam."""
    a = acceleration(joints)
    away = _away(len(a), seams, 2)
    away[[0, -1]] = False
    p95 = np.percentile(a[away], 95)
    return [float(max(a[s - 1], a[s]) / p95) for s in seams]


def skate_pairs(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(speeds m/s, frame t) of every (toe joint, frame pair (t, t+1)) in contact: both frames below 5 cm."""
    feet = np.asarray(joints, np.float64)[:, list(FOOT_JOINTS)]
    low = feet[:, :, 1] < CONTACT_HEIGHT
    contact = low[:-1] & low[1:]
    speed = np.linalg.norm(feet[1:, :, [0, 2]] - feet[:-1, :, [0, 2]], axis=2) * FPS
    t = np.broadcast_to(np.arange(len(feet) - 1)[:, None], contact.shape)
    return speed[contact], t[contact]


def seam_flips(features: np.ndarray, seams) -> list[float]:
    """Per seam s: the largest flip (``flips``) on frames s − FLIP_FRAMES .. s + FLIP_FRAMES − 1, metres."""
    fl = flips(features)
    return [float(fl[max(0, s - FLIP_FRAMES):s + FLIP_FRAMES].max()) for s in seams]


def seam_skate(motions_and_seams) -> dict:
    """Mean toe speed in contact (cm/s) on pairs within SEAM_SKATE_FRAMES of a seam and elsewhere, pooled (``ratio``),
    and matched (``matched_ratio``, the bar): the pairs at each seam against the skate within the two segments it
    joins (their pairs away from every seam), Σ speed at seams / Σ that segment pair's mean. Pooled, a seam's pairs
    are weighed against every segment of every timeline, so which actions meet at seams moves the ratio by itself:
    with seed 1000 the pairs wholly before the seam (the kept frames, which easing never changes) read 1.25× pooled
    and 1.17× matched. ``before_ratio``: those pairs, matched."""
    at, rest, m_at, m_exp, b_at, b_exp = [], [], [], [], [], []
    for joints, seams in motions_and_seams:
        speed, t = skate_pairs(joints)
        near = [(t >= s - 1 - SEAM_SKATE_FRAMES) & (t <= s - 1 + SEAM_SKATE_FRAMES) for s in seams]
        away = ~np.any(near, axis=0) if near else np.ones(len(t), bool)
        at.append(speed[~away])
        rest.append(speed[away])
        bounds = [0, *seams, len(joints)]
        for k, s in enumerate(seams):
            own = away & (t >= bounds[k]) & (t < bounds[k + 2] - 1)      # within the two segments seam k joins
            if not own.any():
                continue
            mean, before = speed[own].mean(), near[k] & (t <= s - 2)
            m_at.append(speed[near[k]]), m_exp.append(np.full(int(near[k].sum()), mean))
            b_at.append(speed[before]), b_exp.append(np.full(int(before.sum()), mean))
    at, rest = np.concatenate(at), np.concatenate(rest)
    a, r = (float(at.mean() * 100) if len(at) else 0.0), (float(rest.mean() * 100) if len(rest) else 0.0)
    def ratio(speeds, means):
        total = float(np.concatenate(means).sum()) if means else 0.0
        return float(np.concatenate(speeds).sum()) / total if total > 0 else None

    return {"seam_cm_s": a, "within_cm_s": r, "ratio": a / r if r else None, "seam_pairs": int(len(at)),
            "within_pairs": int(len(rest)), "matched_ratio": ratio(m_at, m_exp), "before_ratio": ratio(b_at, b_exp)}


def skate_figure(sk: dict) -> float | None:
    """The ratio the seam-skate bar is judged on: matched (a result from before it was measured: pooled)."""
    return sk.get("matched_ratio", sk["ratio"])


def root_steps(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F−1,) root x/z step (m) and |heading change| (rad) from frame t to t+1."""
    from emdm.motion.features import heading_angles

    j = np.asarray(joints, np.float64)
    step = np.linalg.norm(np.diff(j[:, 0, [0, 2]], axis=0), axis=1)
    turn = np.abs(np.angle(np.exp(1j * np.diff(heading_angles(j)))))
    return step, turn


def seam_root(joints: np.ndarray, seams) -> list[dict]:
    """Per seam s: whether the root jumps there, in position and in heading.

    A jump is a second difference: ``seam_acceleration`` of the root on the floor and of the (unwrapped) heading,
    each as a one-joint motion: the larger of the two second differences that span the step from s−1 to s, over
    their 95th percentile away from seams (``jump_ratio``, ``turn_jump_ratio``: the bar). The
    step itself and the heading change from s−1 to s over their p95 (``step_ratio``, ``turn_ratio``) are kept as
    figures: they are not jumps, a walk that turns on through a seam at its own rate is a large step or turn there,
    and real clips reach 1.8× on them at their middle frame."""
    from emdm.motion.features import heading_angles

    step, turn = root_steps(joints)
    away = _away(len(step), seams, 1)
    ps, pt = np.percentile(step[away], 95), np.percentile(turn[away], 95)
    j = np.asarray(joints, np.float64)
    root = j[:, :1] * np.array([1.0, 0.0, 1.0])                            # the root on the floor, as one joint
    heading = np.zeros_like(root)
    heading[:, 0, 0] = np.unwrap(heading_angles(j))                      # the heading, as a joint moving along x
    jump, turn_jump = seam_acceleration(root, seams), seam_acceleration(heading, seams)
    return [{"step_ratio": float(step[s - 1] / ps), "turn_ratio": float(turn[s - 1] / pt),
             "step_cm": float(step[s - 1] * 100), "turn_deg": float(np.degrees(turn[s - 1])),
             "jump_ratio": jump[i], "turn_jump_ratio": turn_jump[i]} for i, s in enumerate(seams)]


def pose(joints: np.ndarray) -> np.ndarray:
    """Joints relative to the root's x/z, turned to face +Z (heading from hips and shoulders): the pose alone."""
    from emdm.motion.features import heading_angles, rot_y

    j = np.asarray(joints, np.float64)
    return rot_y(-heading_angles(j)[:, None], j - j[:, :1] * np.array([1.0, 0.0, 1.0]))


def root_frame(features: np.ndarray, joints: np.ndarray) -> np.ndarray:
    """Joints relative to the root, in the root's own frame (the integrated heading of ``recover_root``)."""
    from emdm.motion.features import recover_root, rot_y

    theta, root = recover_root(features)
    j = np.asarray(joints, np.float64)
    return rot_y(-theta[:, None], j - root[:, None] * np.array([1.0, 0.0, 1.0]))


def summary(values, bar: float | None = None) -> dict:
    v = np.asarray(values, np.float64)
    out = {"n": int(v.size), "median": float(np.median(v)), "mean": float(v.mean()), "p90": float(np.percentile(v, 90)),
           "max": float(v.max())}
    if bar is not None:
        out["share_within_bar"] = float(np.mean(v <= bar))
    return out


# ----------------------------------------------------------------------------------------------- the run

def orders(actions, n: int, seed: int) -> list[tuple[str, ...]]:
    """``n`` orders of 3 distinct actions (LAST_ONLY ones only last), each action as equally often as can be: the
    valid orders in a seeded random order, each time the one whose actions have been used least."""
    from itertools import permutations

    rng = np.random.default_rng(seed)
    valid = [o for o in permutations(actions, 3) if not any(a in LAST_ONLY for a in o[:2])]
    valid = [valid[i] for i in rng.permutation(len(valid))]
    count = dict.fromkeys(actions, 0)
    out = []
    for _ in range(n):
        o = min(valid, key=lambda o: (sorted((count[a] for a in o), reverse=True), o in out))
        out.append(o)
        for a in o:
            count[a] += 1
    return out


class Recorder:
    """An Editor that keeps every window it returns (to check the timeline's overlap), the seconds its sampling took
    (sampling's share of a timeline's time) and the frame-rows its model calls held (Σ rows × frames: the model's
    work, which does not depend on the machine)."""

    def __init__(self, editor):
        from dataclasses import fields, replace

        from emdm.motion import edit as E

        rec = self
        self.windows: list[np.ndarray] = []
        self.seconds: list[float] = []
        self.frame_rows = 0

        def counting(x, z, c, t, mask):
            rec.frame_rows += int(x.shape[0] * x.shape[1])
            return editor.step(x, z, c, t, mask)

        def timed(sampling, *args, window: bool = True):
            t0 = time.perf_counter()
            x = sampling(*args)
            rec.seconds.append(time.perf_counter() - t0)
            if window:
                rec.windows.append(x)
            return x

        class Recording(E.Editor):
            def sample(self, prompt, frames, seed, known=None, keep=None, keep_from_time=1.0):
                return timed(super().sample, prompt, frames, seed, known, keep, keep_from_time)

            def begin(self, runs):
                timed(super().begin, runs, window=False)

            def finish(self, run, known=None):
                return timed(super().finish, run, known)

        self.editor = replace(Recording(**{f.name: getattr(editor, f.name) for f in fields(editor)}), step=counting)

    def clear(self) -> None:
        self.windows.clear()
        self.seconds.clear()
        self.frame_rows = 0


def uneased_joints(model, tl, windows) -> np.ndarray:
    """The timeline's joints stitched from its windows as sampled, before ``ease_seams`` (an ablation: the same
    windows, each continuing the eased sequence before it)."""
    from emdm.motion.features import recover_joints
    from emdm.motion.stitch import append_segment

    joints = recover_joints(model.denormalise(windows[0]))
    for k in range(1, len(tl.frames)):
        joints = append_segment(joints, recover_joints(model.denormalise(windows[k])), min(tl.overlap, tl.starts[k]))
    return joints


def overlap_error_mm(model, tl, windows) -> float:
    """Max distance (mm) of each window's aligned overlap frames from the previous segment's last ones."""
    from emdm.motion.features import recover_joints
    from emdm.motion.stitch import align_segment

    worst = 0.0
    for k in range(1, len(tl.frames)):
        s = tl.starts[k]
        c = min(tl.overlap, s)
        prev = tl.joints[:s]
        aligned = align_segment(prev, recover_joints(model.denormalise(windows[k])), c)
        worst = max(worst, float(np.abs(aligned[:c] - prev[-c:]).max() * 1000))
    return worst


def measure(model, bench, a, log=print) -> dict:
    from emdm.eval.coverage import load_prompts
    from emdm.motion import edit as E
    from emdm.motion.features import recover_joints

    labels = bench.labels
    missing = [x for x in a.actions if x not in labels]
    if missing:
        raise EditingError(f"--actions: {', '.join(missing)} not in the dataset's vocabulary ({', '.join(labels[:6])}, …)")
    prompt = {x: load_prompts(bench.prompts_file, labels)[x][0] for x in a.actions}
    frames = E.segment_frames(a.seconds)
    rec = Recorder(model)
    for p in prompt.values():
        model.condition(p)                                        # encode once, outside every timing

    # timelines and single motions, interleaved (their timings compare under the same load)
    t_single, t_tl, t_single_sampling, t_tl_sampling = [], [], [], []
    timelines, tl_orders, singles, single_action = [], orders(list(a.actions), a.timelines, a.seed), [], []
    overlap_mm, uneased, raw_segments = 0.0, [], []
    per_single = max(1, round(3 * a.timelines / len(a.actions)))   # as many single motions per action as segments
    todo_single = [(x, s) for x in a.actions for s in range(per_single)]
    for i, o in enumerate(tl_orders):
        rec.clear()
        t0 = time.perf_counter()
        tl = E.timeline(rec.editor, [E.Segment(prompt[x], a.seconds, a.seed + 10 * i + k) for k, x in enumerate(o)],
                        together=True)
        t_tl.append(time.perf_counter() - t0)
        t_tl_sampling.append(sum(rec.seconds))
        tl_frame_rows = rec.frame_rows
        overlap_mm = max(overlap_mm, overlap_error_mm(model, tl, rec.windows))
        if raw_segments is not None and len(rec.windows) == len(tl.frames):     # one window per segment (≤ 196 frames)
            raw_segments += [model.denormalise(w)[len(w) - n:] for w, n in zip(rec.windows, tl.frames)]
        else:
            raw_segments = None
        uneased.append(uneased_joints(model, tl, rec.windows))
        timelines.append(tl)
        for x, s in todo_single[i * len(todo_single) // len(tl_orders):(i + 1) * len(todo_single) // len(tl_orders)]:
            rec.clear()
            t0 = time.perf_counter()
            x_single = rec.editor.sample(prompt[x], frames, a.seed + 1000 + 10 * s + a.actions.index(x))
            t_single_sampling.append(time.perf_counter() - t0)
            f = model.denormalise(x_single)
            j = recover_joints(f)
            t_single.append(time.perf_counter() - t0)
            single_frame_rows = rec.frame_rows
            singles.append((f, j))
            single_action.append(x)
        log(f"timeline {i + 1}/{len(tl_orders)} {' → '.join(o)}: {t_tl[-1]:.1f} s (load {os.getloadavg()[0]:.1f})")

    # semantics: every segment's new frames vs the single motions, by the coverage classifier
    seg_feats, seg_action = [], []
    for tl, o in zip(timelines, tl_orders):
        for k, x in enumerate(o):
            seg_feats.append(tl.features[tl.starts[k]:tl.starts[k] + tl.frames[k]])
            seg_action.append(x)
    # each segment classified whole, after its first second (the bar, below) and after the first d frames of the
    # drop curve (TRANSITION_FRAMES), once per d
    pred_without = {d: bench.predict([f[d:] for f in seg_feats]) for d in sorted({0, FPS, *TRANSITION_FRAMES})}
    pred_seg = pred_without[0]
    pred_single = bench.predict([f for f, _ in singles])
    # after the transition: each segment and each single motion without its first second. A segment's first second
    # holds its seam's blend (``ease_seams``: the previous action faded into the new one over ≥ 14 frames, which the
    # seam bars need), and the classifier's backward GRU ends its reading on a clip's first frames; the single
    # motions lose the same second, so both are read from the same length.
    pred_late = pred_without[FPS]
    pred_single_late = bench.predict([f[FPS:] for f, _ in singles])
    pred_raw = bench.predict(raw_segments) if raw_segments else None   # diagnostic: the windows as sampled, un-eased
    per_action = {}
    for x in a.actions:
        li = labels.index(x)
        s_hit = [int(p == li) for p, y in zip(pred_seg, seg_action) if y == x]
        o_hit = [int(p == li) for p, y in zip(pred_single, single_action) if y == x]
        named = lambda preds, acts: {n: int(c) for n, c in zip(*np.unique([labels[p] for p, y in zip(preds, acts) if y == x],  # noqa: E731
                                                                       return_counts=True))}
        per_action[x] = {"prompt": prompt[x], "segments": len(s_hit), "segment_rate": float(np.mean(s_hit)) if s_hit else None,
                         "singles": len(o_hit), "single_rate": float(np.mean(o_hit)) if o_hit else None,
                         "segment_named": named(pred_seg, seg_action), "single_named": named(pred_single, single_action)}
    hit = lambda preds, acts: [p == labels.index(y) for p, y in zip(preds, acts)]  # noqa: E731
    seg_hits, single_hits = int(sum(hit(pred_seg, seg_action))), int(sum(hit(pred_single, single_action)))
    seg_rate, single_rate = seg_hits / len(seg_action), single_hits / len(single_action)
    by_pos = [float(np.mean([pred_seg[3 * i + k] == labels.index(o[k]) for i, o in enumerate(tl_orders)]))
              for k in range(3)]
    late_hits, single_late_hits = int(sum(hit(pred_late, seg_action))), int(sum(hit(pred_single_late, single_action)))
    raw_rate = float(np.mean(hit(pred_raw, seg_action))) if pred_raw is not None else None
    later = [i for i in range(len(seg_action)) if i % 3]                 # segments 2 and 3 of every timeline
    before = [tl_orders[i // 3][i % 3 - 1] for i in later]               # the action of the segment before each
    # how long the transition is, to the classifier: segments 2 and 3 recognised without their first d frames
    later_after = {d: float(np.mean(hit([pred_without[d][i] for i in later], [seg_action[i] for i in later])))
                   for d in TRANSITION_FRAMES}
    read_as_previous = {name: float(np.mean(hit([preds[i] for i in later], before)))
                        for name, preds in (("whole", pred_seg), ("after_transition", pred_late), ("uneased", pred_raw))
                        if preds is not None}

    # seams (real clips and single motions at their middle frame are the reference)
    seams = [tl.starts[1:] for tl in timelines]
    acc = [r for tl, s in zip(timelines, seams) for r in seam_acceleration(tl.joints, s)]
    acc_uneased = [r for j, s in zip(uneased, seams) for r in seam_acceleration(j, s)]
    root = [r for tl, s in zip(timelines, seams) for r in seam_root(tl.joints, s)]
    real = [recover_joints(m) for m in bench.test.motions if len(m) >= 3 * FPS]
    bar = BARS["seam_acceleration"]
    ref_acc = {"real": summary([r for j in real for r in seam_acceleration(j, [len(j) // 2])], bar),
               "single": summary([r for _, j in singles for r in seam_acceleration(j, [len(j) // 2])], bar)}
    ref_root = {"real": [r for j in real for r in seam_root(j, [len(j) // 2])],
                "single": [r for _, j in singles for r in seam_root(j, [len(j) // 2])]}
    near = [r for tl, s in zip(timelines, seams) for r in seam_flips(tl.features, s)]
    failing = [i for i, r in enumerate(acc) if r > bar]
    where = [(ti, k + 1) for ti, s in enumerate(seams) for k in range(len(s))]     # (timeline, seam) of acc[i]
    shares = {"real": flip_share(bench.test.motions), "single": flip_share([f for f, _ in singles]),
              "timeline": flip_share([tl.features for tl in timelines])}
    skate = seam_skate([(tl.joints, s) for tl, s in zip(timelines, seams)])
    ref_skate = {"real": seam_skate([(j, [len(j) // 2]) for j in real]),
                 "single": seam_skate([(j, [len(j) // 2]) for _, j in singles])}

    # kept parts and loops, on the single motions (one per action)
    firsts = [singles[single_action.index(x)] for x in a.actions]
    kept = {"timeline_overlap_mm": overlap_mm, "inbetween_mm": 0.0, "lower_mm": 0.0, "upper_mm": 0.0}
    loops = {"pose_cm": [], "wrap_acceleration": [], "in_place_travel_cm": [], "travel_cm": []}
    for i, (f, j) in enumerate(firsts):
        other = prompt[a.actions[(i + 1) % len(a.actions)]]
        m = E.inbetween(model, f, other, a.seed + 2000 + i)
        n = len(f)
        kf = np.r_[0:FPS, n - FPS:n]
        kept["inbetween_mm"] = max(kept["inbetween_mm"], float(np.abs(m.joints[kf] - j[kf]).max() * 1000))
        m = E.edit_body(model, f, other, a.seed + 3000 + i, keep="lower")
        kept["lower_mm"] = max(kept["lower_mm"], float(np.abs(m.joints[:, LEGS] - j[:, LEGS]).max() * 1000))
        m = E.edit_body(model, f, other, a.seed + 4000 + i, keep="upper")
        up = list(UPPER)
        err = np.abs(root_frame(m.features, m.joints)[:, up] - root_frame(f, j)[:, up]).max()
        kept["upper_mm"] = max(kept["upper_mm"], float(err * 1000))
        own = prompt[a.actions[i]]
        lp = E.loop(model, f, own, a.seed + 5000 + i)
        still = E.loop(model, f, own, a.seed + 5000 + i, in_place=True)
        n_clip = len(lp.features)
        full = lp.full.joints
        loops["pose_cm"].append(float(np.linalg.norm(pose(full[n_clip:n_clip + 1]) - pose(full[:1]), axis=2).max() * 100))
        loops["wrap_acceleration"] += seam_acceleration(full, [n_clip])
        loops["travel_cm"].append(float(np.linalg.norm(lp.joints[:, 0, [0, 2]] - lp.joints[:1, 0, [0, 2]], axis=1).max() * 100))
        loops["in_place_travel_cm"].append(
            float(np.linalg.norm(still.joints[:, 0, [0, 2]] - still.joints[:1, 0, [0, 2]], axis=1).max() * 100))

    ratio = float(np.median(t_tl) / np.median(t_single))
    by_threads = {str(n): time_ratio(a, n, [[prompt[x] for x in o] for o in tl_orders[:a.time_timelines]], frames, log)
                  for n in a.time_threads}
    return {
        "actions": list(a.actions), "prompts": prompt, "segment_seconds": a.seconds, "timelines": len(timelines),
        "orders": [list(o) for o in tl_orders],
        "seams": {"count": len(acc), "acceleration_ratio": summary(acc),
                  "acceleration_within_bar": int(np.sum(np.asarray(acc) <= BARS["seam_acceleration"])),
                  "failing": [{"timeline": where[i][0], "order": list(tl_orders[where[i][0]]), "seam": where[i][1],
                               "acceleration_ratio": acc[i], "flip_m": near[i]} for i in failing],
                  "failing_on_flip": int(sum(near[i] > FLIP_M for i in failing)),
                  "flip_share_of_frames": shares,
                  "uneased_acceleration_ratio": summary(acc_uneased, BARS["seam_acceleration"]),
                  "reference_acceleration_ratio": ref_acc,
                  "skate": skate, "reference_skate": ref_skate,
                  "root_step_ratio": summary([r["step_ratio"] for r in root]),
                  "root_turn_ratio": summary([r["turn_ratio"] for r in root]),
                  "root_step_cm": summary([r["step_cm"] for r in root]),
                  "root_turn_deg": summary([r["turn_deg"] for r in root]),
                  "root_jump_ratio": summary([r["jump_ratio"] for r in root]),
                  "root_turn_jump_ratio": summary([r["turn_jump_ratio"] for r in root]),
                  "root_within_bar": int(sum(r["jump_ratio"] <= BARS["seam_root"] and r["turn_jump_ratio"] <= BARS["seam_root"]
                                             for r in root)),
                  "reference_root_step_ratio": {k: summary([r["step_ratio"] for r in v], BARS["seam_root"]) for k, v in ref_root.items()},
                  "reference_root_turn_ratio": {k: summary([r["turn_ratio"] for r in v], BARS["seam_root"]) for k, v in ref_root.items()},
                  "reference_root_jump_ratio": {k: summary([r["jump_ratio"] for r in v], BARS["seam_root"]) for k, v in ref_root.items()},
                  "reference_root_turn_jump_ratio": {k: summary([r["turn_jump_ratio"] for r in v], BARS["seam_root"])
                                                     for k, v in ref_root.items()},
                  "real_clips": len(real)},
        "semantics": {"segment_rate": seg_rate, "single_rate": single_rate, "segment_hits": seg_hits, "single_hits": single_hits,
                      # from the counts, so a ratio exactly at the bar is not lost to rounding (40/54 ÷ 50/54 = 0.8)
                      "ratio": (seg_hits * len(single_action)) / (len(seg_action) * single_hits) if single_hits else None, "segment_rate_by_position": by_pos,
                      "segment_rate_without_first_second": late_hits / len(seg_action),
                      "single_rate_without_first_second": single_late_hits / len(single_action),
                      "ratio_after_transition": (late_hits * len(single_action)) / (len(seg_action) * single_late_hits)
                      if single_late_hits else None,
                      "uneased_segment_rate": raw_rate, "later_segments_read_as_previous": read_as_previous,
                      "later_segment_rate_without_first_frames": later_after,
                      "segments": len(seg_action), "singles": len(single_action), "per_action": per_action},
        "kept": kept,
        "loops": {"count": len(firsts), "ends": E.LOOP_ENDS, "pose_cm": summary(loops["pose_cm"]),
                  "wrap_acceleration_ratio": summary(loops["wrap_acceleration"]),
                  "travel_cm": summary(loops["travel_cm"]), "in_place_travel_cm": summary(loops["in_place_travel_cm"])},
        "time": {"timeline_s": summary(t_tl), "single_s": summary(t_single), "ratio_of_medians": ratio,
                 "timeline_frames": int(len(timelines[0].features)), "single_frames": frames,
                 # where the time goes: sampling (the model's steps) against the rest (seam easing, decoding, stitching)
                 "timeline_sampling_s": summary(t_tl_sampling), "single_sampling_s": summary(t_single_sampling),
                 # the model's work: Σ rows × frames over its calls (a timeline's windows begun together, as the page)
                 "timeline_frame_rows": tl_frame_rows, "single_frame_rows": single_frame_rows,
                 "work_ratio": tl_frame_rows / single_frame_rows,
                 "us_per_frame_row": {"timeline": float(np.median(t_tl_sampling)) * 1e6 / tl_frame_rows,
                                      "single": float(np.median(t_single_sampling)) * 1e6 / single_frame_rows},
                 "by_threads": by_threads},
    }


def timed_editor(a, threads: int):
    """The Editor the time bar runs: the shipped file of ``a.variant`` through ONNX Runtime on ``threads`` threads, or
    (``a.ckpt``) those PyTorch weights on ``a.device`` with the shipped entry's sampling settings (guidance, where
    it stops, x̂0 smoothing), so the same steps run on either."""
    from emdm.model.open import open_model
    from emdm.motion import edit as E

    if a.ckpt is None:
        variant = page_variant(a.model, a.models_dir) if a.variant == "page" else a.variant
        return E.Editor.open(open_model(a.model, models_dir=a.models_dir, threads=threads, variant=variant), steps=a.steps)
    import torch

    from emdm import manifest as mf
    from emdm.paths import models_dir

    torch.set_num_threads(threads)
    entry = mf.load(models_dir(a.models_dir))["models"].get(a.model)
    if entry is None:
        raise EditingError(f"--model {a.model}: no such entry in the manifest (its sampling settings time --ckpt)")
    opened = open_model(Path(a.ckpt), device=a.device)
    if opened.meta["condition"] != entry["condition"]:
        raise EditingError(f"--ckpt {display_path(Path(a.ckpt))}: its condition ({opened.meta['condition'].get('type')}, "
                           f"dim {opened.meta['condition'].get('dim')}) is not that of --model {a.model}")
    return E.Editor.from_entry(opened.step, entry, opened.mean, opened.std, steps=a.steps, models_dir=a.models_dir)


def time_ratio(a, threads: int, orders: list[list[str]], frames: int, log=print) -> dict:
    """The time bar on its own, at ``threads`` threads (ONNX Runtime's, or PyTorch's CPU threads with ``--ckpt``):
    timelines of ``orders``' prompts (windows begun together, as the page) and single motions, interleaved after a
    warm-up, medians. One call of several windows' rows costs less than its parts only where the runtime has threads
    to spare (or a GPU)."""
    from emdm.motion import edit as E

    model = timed_editor(a, threads)
    for p in {p for o in orders for p in o}:
        model.condition(p)
    segs = lambda o, s: [E.Segment(p, a.seconds, s + k) for k, p in enumerate(o)]  # noqa: E731
    E.timeline(model, segs(orders[0], 7), together=True)
    model.sample(orders[0][0], frames, 7)
    t_tl, t_one = [], []
    for i, o in enumerate(orders):
        t0 = time.perf_counter()
        E.timeline(model, segs(o, a.seed + 10 * i), together=True)
        t_tl.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        model.sample(o[i % 3], frames, a.seed + 1000 + i)
        t_one.append(time.perf_counter() - t0)
    r = {"timelines": len(orders), "timeline_s": float(np.median(t_tl)), "single_s": float(np.median(t_one)),
         "ratio": float(np.median(t_tl) / np.median(t_one)), "load_avg_1min": os.getloadavg()[0]}
    log(f"time with {threads} thread(s): {r['timeline_s']:.2f} s against {r['single_s']:.2f} s = {r['ratio']:.2f}×")
    return r


def time_orders(a) -> list[list[str]]:
    """``--time-only``'s timelines: the prompts of ``a.actions`` in ``a.time_timelines`` random orders (``orders``)."""
    from emdm.eval.coverage import load_prompts

    plain = {x: p[0] for x, p in load_prompts(a.prompts, list(a.actions)).items()}
    return [[plain[x] for x in o] for o in orders(list(a.actions), a.time_timelines, a.seed)]


def bars(m: dict) -> dict:
    """Each bar of the issue: the figure it is judged on and whether it is met."""
    s, sem = m["seams"], m["semantics"]
    out = {
        "seam_acceleration": (s["acceleration_within_bar"] == s["count"], f"{s['acceleration_within_bar']}/{s['count']} seams ≤ 1.5×"),
        "seam_skate": (skate_figure(s["skate"]) is not None and skate_figure(s["skate"]) <= BARS["seam_skate"],
                       f"ratio {skate_figure(s['skate']):.2f}" + (" (seams against their own segments)" if "matched_ratio" in s["skate"] else "")),
        "seam_root": (s["root_within_bar"] == s["count"],
                      f"{s['root_within_bar']}/{s['count']} seams ≤ 1.5× (position and heading jump)"),
        "semantics": (sem["ratio_after_transition"] is not None and sem["ratio_after_transition"] >= BARS["semantics"],
                      f"{sem['ratio_after_transition']:.2f} of the single-prompt rate after the first second "
                      f"({sem['ratio']:.2f} whole)"),
        "kept": (max(m["kept"].values()) <= BARS["kept_mm"], f"worst {max(m['kept'].values()):.3g} mm"),
        "loop_pose": (m["loops"]["pose_cm"]["max"] <= BARS["loop_pose_cm"], f"worst {m['loops']['pose_cm']['max']:.3g} cm"),
        "in_place": (m["loops"]["in_place_travel_cm"]["max"] <= BARS["in_place_cm"], f"worst {m['loops']['in_place_travel_cm']['max']:.3g} cm"),
        "time": time_bar(m["time"]),
    }
    return {k: {"met": bool(v[0]), "figure": v[1]} for k, v in out.items()}


def time_bar(t: dict) -> tuple[bool, str]:
    """Met when the ratio is within the bar at every thread count measured (``--time-threads``): batched windows pay
    off only where a runtime has threads to spare and uses them poorly on small calls, so no one count stands for
    all. The figure names each, with the model's work ratio (the floor where a frame-row costs the same in any call)."""
    by = t.get("by_threads") or {}
    if not by:
        return t["ratio_of_medians"] <= BARS["time_ratio"], f"{t['ratio_of_medians']:.2f}×"
    each = ", ".join(f"{by[n]['ratio']:.2f}× on {n} thread{'s' if n != '1' else ''}" for n in sorted(by, key=int))
    work = f" (the model's work {t['work_ratio']:.2f}×)" if "work_ratio" in t else ""
    return all(v["ratio"] <= BARS["time_ratio"] for v in by.values()), each + work


def page_variant(model: str, models_dir: Path | None) -> str | None:
    """The file the page runs for a shipped model: its entry's ``defaultVariant`` (None: the fp32 file, also when the
    manifest cannot be read, which ``open_model`` then reports)."""
    from emdm import manifest as mf
    from emdm import paths

    try:
        return mf.load(paths.models_dir(models_dir))["models"].get(model, {}).get("defaultVariant")
    except mf.ManifestError:
        return None


def run(a) -> Path:
    from emdm.eval.coverage import Benchmark
    from emdm.eval.evaluate import _evaluator_info, dataset_info, hardware, write_result
    from emdm.eval.report import SCHEMA
    from emdm.model.open import open_model
    from emdm.motion.edit import Editor
    from emdm.outdir import check_writable

    from emdm.eval.report import RESULTS_DIR

    out = check_writable(a.out or (RESULTS_DIR / "json" / f"editing-{a.model}{f'-seed{a.seed}' if a.seed else ''}.json"))
    t0, load0 = time.time(), os.getloadavg()[0]
    variant = page_variant(a.model, a.models_dir) if a.variant == "page" else a.variant
    opened = open_model(a.model, models_dir=a.models_dir, threads=a.threads, variant=variant)
    model = Editor.open(opened, steps=a.steps)
    bench = Benchmark(a.dataset, a.split, a.classifier, a.prompts, seeds=1, seed=a.seed)
    m = measure(model, bench, a)
    result = {"schema": SCHEMA, "task": "editing", "name": a.model, "variant": opened.variant, "steps": a.steps,
              "guidance": model.guidance, "guidance_min_time": model.guidance_min_time, "x0_smoothing": model.x0_smoothing,
              "seed": a.seed, **m, "bars": bars(m), "classifier": _evaluator_info(bench.classifier, a.classifier),
              "classifier_real_macro": bench.real.get("macro_accuracy"),
              "dataset": dataset_info(Path(a.dataset), a.split), "hardware": hardware(), "threads": a.threads,
              "seconds": round(time.time() - t0, 1), "load_avg_1min_start": load0, "load_avg_1min_end": os.getloadavg()[0],
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    return write_result(result, out)


def run_time_only(a) -> Path:
    """``--time-only``: the time bar alone (no dataset, classifier or quality measures), at each of ``--time-threads``;
    with ``--ckpt`` the PyTorch weights on ``--device`` (a GPU), the runtime the issue's bar is out of reach without
    on these CPUs. Writes ``editing-time-<model>-<runtime>.json`` (task ``editing-time``)."""
    from emdm.eval.evaluate import write_result
    from emdm.eval.report import RESULTS_DIR, SCHEMA
    from emdm.motion.edit import segment_frames
    from emdm.outdir import check_writable

    runtime = (f"pytorch-{a.device.split(':')[0]}" if a.ckpt is not None
               else f"onnxruntime-cpu-{page_variant(a.model, a.models_dir) if a.variant == 'page' else a.variant}")
    out = check_writable(a.out or (RESULTS_DIR / "json" / f"editing-time-{a.model}-{runtime}.json"))
    t0, load0, machine = time.time(), os.getloadavg()[0], machine_name()
    tl_orders = time_orders(a)
    by = {str(n): time_ratio(a, n, tl_orders, segment_frames(a.seconds)) for n in a.time_threads}
    t = {"by_threads": by, "threads_are": "torch CPU" if a.ckpt is not None else "ONNX Runtime"}
    met, figure = time_bar(t)
    result = {"schema": SCHEMA, "task": "editing-time", "name": a.model, "runtime": runtime, "steps": a.steps,
              "segment_seconds": a.seconds, "actions": list(a.actions), "seed": a.seed,
              "weights": display_path(Path(a.ckpt)) if a.ckpt is not None else None, "device": a.device,
              "time": t, "bars": {"time": {"met": met, "figure": figure}}, "hardware": machine,
              "seconds": round(time.time() - t0, 1), "load_avg_1min_start": load0, "load_avg_1min_end": os.getloadavg()[0],
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    return write_result(result, out)


def machine_name() -> str:
    """``emdm.eval.evaluate.hardware()`` without its torch thread count (a time row names its own threads); the GPU,
    when there is one, stays."""
    import re

    from emdm.eval.evaluate import hardware

    return re.sub(r" \(\d+ torch thread\(s\)\)", "", hardware())


PAGE_KEYS = ("reps", "singleMs", "timelineMs", "steps", "environment", "load", "timelineWindowFrames")


def import_page(a) -> Path:
    """``--import-page FILE``: the page benchmark's figures (tests/e2e/page-bench.spec.ts "timeline against" writes
    timeline-time.json) as an ``editing-time`` result (runtime ``page-<backend>-<file>``) for RESULTS.md. Import it on
    the machine that measured it (its hardware is read here)."""
    import json

    from emdm.eval.evaluate import write_result
    from emdm.eval.report import RESULTS_DIR, SCHEMA
    from emdm.outdir import check_writable

    path = Path(a.import_page)
    try:
        d = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as e:
        raise EditingError(f"--import-page {path}: not a readable JSON file ({e})") from None
    missing = [k for k in PAGE_KEYS if k not in d] if isinstance(d, dict) else list(PAGE_KEYS)
    if missing:
        raise EditingError(f"--import-page {path}: not the page benchmark's timeline-time.json (missing {', '.join(missing)})")
    if not (d["singleMs"] > 0 and d["timelineMs"] > 0 and d["reps"] >= 1):
        raise EditingError(f"--import-page {path}: singleMs, timelineMs and reps must be positive "
                           f"(got {d['singleMs']}, {d['timelineMs']}, {d['reps']})")
    variant = d.get("variant", "default")
    if variant == "default":
        variant = page_variant(a.model, a.models_dir) or "fp32"
    backend = d.get("backend", "wasm")
    threads = str(int(d["environment"].get("threads", 1))) if backend == "wasm" else "1"
    by = {threads: {"timelines": int(d["reps"]), "timeline_s": d["timelineMs"] / 1000, "single_s": d["singleMs"] / 1000,
                    "ratio": d["timelineMs"] / d["singleMs"], "load_avg_1min": float(d["load"])}}
    t = {"by_threads": by, "threads_are": "WASM" if backend == "wasm" else None, "window_frames": d["timelineWindowFrames"],
         "begin_ms": d.get("timelineBeginMs"), "cross_origin_isolated": d["environment"].get("crossOriginIsolated")}
    met, figure = time_bar(t)
    if backend != "wasm":
        figure = f"{by[threads]['ratio']:.2f}× on {backend}"
    runtime = f"page-{backend}-{variant}"
    out = check_writable(a.out or (RESULTS_DIR / "json" / f"editing-time-{a.model}-{runtime}.json"))
    result = {"schema": SCHEMA, "task": "editing-time", "name": a.model, "runtime": runtime, "steps": int(d["steps"]),
              "segment_seconds": 5.0, "seed": None, "weights": None, "device": "browser", "time": t,
              "bars": {"time": {"met": met, "figure": figure}},
              "hardware": f"{machine_name()}, Chromium (the demo page through its generation worker)",
              "source": "EMDM_BENCH=1 npx playwright test tests/e2e/page-bench.spec.ts -g 'timeline against'",
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    return write_result(result, out)


# ----------------------------------------------------------------------------------------------- RESULTS.md

def _pct(x):
    return "–" if x is None else f"{x:.0%}"


def _f(x, d=2):
    return "–" if x is None else f"{x:.{d}f}"


def section(r: dict) -> list[str]:
    """RESULTS.md's section for one editing result (``emdm.eval.report``)."""
    s, sem, k, lp, t, b = r["seams"], r["semantics"], r["kept"], r["loops"], r["time"], r["bars"]
    yes = lambda key: "**met**" if b[key]["met"] else "**not met**"  # noqa: E731
    ra = s["reference_acceleration_ratio"]
    sk, rsk = s["skate"], s["reference_skate"]
    how = [f"guidance {r['guidance']:g}"] + ([f"{r['variant']} file"] if "variant" in r else [])
    how += [f"guided at t > {r['guidance_min_time']:g}"] if r.get("guidance_min_time") else []
    how += [f"x̂0 smoothed σ = {r['x0_smoothing']:g}"] if r.get("x0_smoothing") else []
    how += [f"seed {r['seed']}"] if r.get("seed") else []
    out = [f"### {r['name']}, {r['steps']} steps ({', '.join(how)})", "",
           f"{r['timelines']} timelines of 3 × {r['segment_seconds']:g} s ({s['count']} seams) from the plain prompts of "
           f"{', '.join(r['actions'])} in random orders; {sem['singles']} single {r['segment_seconds']:g} s motions of the same "
           f"prompts. Measured on {r['hardware']}, ONNX Runtime on {r['threads']} thread(s), in {r['seconds']:.0f} s; load average "
           f"{r['load_avg_1min_start']:.1f} at the start, {r['load_avg_1min_end']:.1f} at the end (a shared machine: timings are under that load). File "
           f"`docs/results/json/{r.get('_file', 'editing-' + r['name'] + '.json')}`.", "",
           "| bar (issue 14) | measured | |", "|---|---|---|",
           f"| seam joint acceleration ≤ 1.5× the within-timeline 95th percentile | median {_f(s['acceleration_ratio']['median'])}×, "
           f"max {_f(s['acceleration_ratio']['max'])}×; {b['seam_acceleration']['figure']} (reference at a middle frame: real clips "
           f"median {_f(ra['real']['median'])}×, max {_f(ra['real']['max'])}×, {_pct(ra['real'].get('share_within_bar'))} ≤ 1.5× of "
           f"{ra['real']['n']}; single generated motions median {_f(ra['single']['median'])}×, max {_f(ra['single']['max'])}×)"
           f"{_uneased(s)}{_flips(s)} | {yes('seam_acceleration')} |",
           f"| foot skate at seams ≤ 1.2× within segments | {_skate(sk, rsk)} | {yes('seam_skate')} |",
           f"| no jump in root position or heading (the root's x/z acceleration and the heading's at a seam ≤ 1.5× their 95th "
           f"percentile within) | {_root(s)}; {b['seam_root']['figure']} | {yes('seam_root')} |",
           f"| each segment recognised as its prompt at ≥ 80 % of the single-prompt rate (read after the first second) | "
           f"{_semantics(sem)} | {yes('semantics')} |",
           f"| kept frames/channels equal the known motion ≤ 1 mm after decoding | in-between {k['inbetween_mm']:.3g} mm, "
           f"lower body kept {k['lower_mm']:.3g} mm, upper body kept (root frame) {k['upper_mm']:.3g} mm, timeline overlap "
           f"{k['timeline_overlap_mm']:.3g} mm (worst of {lp['count']} each) | {yes('kept')} |",
           f"| loop first/last pose ≤ 2 cm per joint | worst {lp['pose_cm']['max']:.3g} cm over {lp['count']} loops; the "
           f"wrap's acceleration median {_f(lp['wrap_acceleration_ratio']['median'])}×, max "
           f"{_f(lp['wrap_acceleration_ratio']['max'])}× the loop's 95th percentile | {yes('loop_pose')} |",
           f"| in-place root travel ≤ 5 cm | worst {lp['in_place_travel_cm']['max']:.3g} cm (without in place: median "
           f"{lp['travel_cm']['median']:.0f} cm) | {yes('in_place')} |",
           f"| 3 × 5 s timeline ≤ 3× one 5 s motion | {_time_row(t)} | {yes('time')} |", "",
           "Per action (segment rate / single rate): " + "; ".join(
               f"{x} {_pct(v['segment_rate'])} / {_pct(v['single_rate'])}" for x, v in sem["per_action"].items()) + ".", "",
           *(_another_seed(r) if r.get("seed") else _reading(sem))]
    return out


def time_section(rs: list[dict]) -> list[str]:
    """RESULTS.md's rows for ``--time-only`` results (task ``editing-time``): the time bar on other runtimes."""
    if not rs:
        return []
    out = ["### The time bar on other runtimes (`--time-only`, the page)", "",
           "The same 3 × 5 s timelines against one 5 s motion (windows begun together, medians of interleaved runs), "
           "with nothing else measured: `python -m emdm.eval.editing --time-only [--ckpt WEIGHTS --device DEVICE]` "
           "(scripts/gpu/editing-time.sh on a GPU machine). PyTorch runs the model's float weights, so every window's "
           "early steps go in one call per step, as the page's fp32/fp16 files do. The page row is the demo page "
           "itself (tests/e2e/page-bench.spec.ts 'timeline against', imported with `--import-page`): a timeline there "
           "is one request to the generation worker, against one motion's one request.", "",
           "| runtime | weights | machine | steps | timeline vs one motion | ≤ 3× | file |", "|---|---|---|---|---|---|---|"]
    for r in sorted(rs, key=lambda r: (r["name"], r["runtime"])):
        by = r["time"]["by_threads"]
        are = r["time"]["threads_are"]
        each = "; ".join(f"**{v['ratio']:.2f}×**{f' on {n} {are} thread' + ('s' if n != '1' else '') if are else ''} "
                         f"({v['timeline_s']:.2f} s vs {v['single_s']:.2f} s, {v['timelines']} each, load "
                         f"{v['load_avg_1min']:.1f})" for n, v in sorted(by.items(), key=lambda kv: int(kv[0])))
        out.append(f"| {r['runtime']} | {r.get('weights') or r['name'] + ' (shipped file)'} | {r['hardware']} | "
                   f"{r['steps']} | {each} | {'**met**' if r['bars']['time']['met'] else '**not met**'} | "
                   f"`{r.get('_file', '')}` |")
    return out + [""]


def _another_seed(r: dict) -> list[str]:
    return [f"The same benchmark from seed {r['seed']} (other orders, other noise), for how far its figures move with "
            "the draw; the reading of the run above holds. The bars nearest their limits move most: seam foot skate is "
            "measured on the joints as decoded, before the page's foot-contact clean-up (web/ui/timeline.ts shows every "
            "timeline with it).", ""]


def _reading(sem: dict) -> list[str]:
    return ["Reading: kept parts, the loop's closing pose and in-place travel hold by construction (kept entries are "
           "replaced exactly at every step; the in-place root velocity is zero), so their rows check the bookkeeping, "
           "not the model. Time: a later window's second of context (C = 20 frames) sits out its steps above "
           "t = 0.55 (the five guided ones) and joins for the five below, so a 3 × 100-frame timeline is "
           "1500 + 2·1600 = 4700 frame-rows of the model's work against 1500 for one motion (3.13×: the floor where a "
           "frame-row costs the same in any call, as on one thread). Those early steps need nothing from the window "
           "before, so the page begins every window at once (`begin`), in one call per step on an fp32/fp16 file; "
           "an int8 file (this run's, and the page's default) quantises activations per call, so its windows are "
           "begun one by one and every motion depends on its own request only (a shared timeline must reproduce). "
           "The page's own figures are in the page benchmark (tests/e2e/page-bench.spec.ts, 'timeline against'). "
           "Under 3× needs the windows' rows run side by side, as one call: on a GPU (WebGPU with the fp16 or fp32 file: "
           "not measured, no GPU on the machines these runs had; the default int8 file neither batches nor has WebGPU "
           "kernels for its quantised matmuls, docs/ARCHITECTURE.md) or with threads to spare; an int8 graph quantising each row on its own "
           "batches exactly but ran slower than these calls (docs/ARCHITECTURE.md). Where a call's fixed cost is a "
           "large part of it, the one call per step for every window's early steps pays even on one thread: PyTorch's "
           "eager calls of the same weights (the `--time-only` rows at the end of this section; a GPU's calls are of "
           "that kind, `scripts/gpu/editing-time.sh` measures one in a single device call). "
           "Semantics is read after each motion's first second (segments and single motions alike) because a segment's "
           "first second is its seam: `ease_seams` fades the previous action into the new one there (14 frames or more; "
           "the seam rows need it), and the classifier's bidirectional GRU ends its backward reading on a clip's first "
           "frames, so a half-second blend decides the label (the later segments' whole-segment reading above). The windows "
           "as the model sampled them switch at once (the un-eased figure), at the price of the seam jumps in the first row. "
           f"Semantics counts {sem['segments']} segments and {sem['singles']} single motions: a few motions move the "
           "ratio by several points, so a figure near 0.8 is within noise of the bar.", ""]


def _skate(sk: dict, rsk: dict) -> str:
    pairs = f"{sk['seam_pairs']} contact pairs within {SEAM_SKATE_FRAMES} frames of a seam"
    if "matched_ratio" not in sk:
        return (f"{_f(sk['seam_cm_s'], 1)} vs {_f(sk['within_cm_s'], 1)} cm/s (ratio {_f(sk['ratio'])}; {pairs}); reference "
                f"ratio at a middle frame: real {_f(rsk['real']['ratio'])}, single {_f(rsk['single']['ratio'])}")
    return (f"each seam against the segments it joins: **{_f(sk['matched_ratio'])}** ({pairs}); the pairs wholly before "
            f"the seam, in kept frames the easing never changes, {_f(sk['before_ratio'])}; pooled over every segment "
            f"{_f(sk['seam_cm_s'], 1)} vs {_f(sk['within_cm_s'], 1)} cm/s = {_f(sk['ratio'])} (which actions meet at seams "
            f"weighs on it). Reference at a middle frame: real {_f(skate_figure(rsk['real']))}, single "
            f"{_f(skate_figure(rsk['single']))}")


def _root(s: dict) -> str:
    jr, tj = s["reference_root_jump_ratio"]["real"], s["reference_root_turn_jump_ratio"]["real"]
    rs, rt = s["reference_root_step_ratio"]["real"], s["reference_root_turn_ratio"]["real"]
    return (f"position jump median {_f(s['root_jump_ratio']['median'])}×, max {_f(s['root_jump_ratio']['max'])}×; heading jump "
            f"median {_f(s['root_turn_jump_ratio']['median'])}×, max {_f(s['root_turn_jump_ratio']['max'])}× (real clips at their "
            f"middle frame: {_pct(jr['share_within_bar'])} and {_pct(tj['share_within_bar'])} ≤ 1.5×, medians {_f(jr['median'])}× "
            f"and {_f(tj['median'])}×). Not jumps, for scale: the root's step at a seam median {_f(s['root_step_ratio']['median'])}×, "
            f"max {_f(s['root_step_ratio']['max'])}× its 95th percentile (max {_f(s['root_step_cm']['max'], 1)} cm), the heading's "
            f"change median {_f(s['root_turn_ratio']['median'])}×, max {_f(s['root_turn_ratio']['max'])}× (max "
            f"{_f(s['root_turn_deg']['max'], 1)}°); real middle frames reach {_f(rs['max'])}× and {_f(rt['max'])}× on these "
            f"(a walk turning on through a seam at its own rate)")


def _semantics(sem: dict) -> str:
    prev, after = sem["later_segments_read_as_previous"], sem["later_segment_rate_without_first_frames"]
    raw = sem.get("uneased_segment_rate")
    return (f"after each motion's first second: segments {sem['segment_rate_without_first_second']:.0%}, single motions "
            f"{sem['single_rate_without_first_second']:.0%}: **{_f(sem['ratio_after_transition'])}**. Whole: segments "
            f"{sem['segment_rate']:.0%} (by position {', '.join(f'{v:.0%}' for v in sem['segment_rate_by_position'])}), single "
            f"motions {sem['single_rate']:.0%} ({sem['segment_hits']}/{sem['segments']} vs {sem['single_hits']}/{sem['singles']}): "
            f"{_f(sem['ratio'])}. Segments 2 and 3 recognised without their first "
            + ", ".join(f"{d}" for d in after) + " frames: " + ", ".join(f"{v:.0%}" for v in after.values())
            + f"; read as the segment before them: whole {prev['whole']:.0%}, after the first second {prev['after_transition']:.0%}"
            + (f"; the same windows as sampled, before the seam easing, whole: {raw:.0%} recognised, {prev['uneased']:.0%} read "
               f"as the one before" if raw is not None else ""))


def _time_row(t: dict) -> str:
    share = t["timeline_sampling_s"]["median"] / t["timeline_s"]["median"]
    us = t["us_per_frame_row"]
    by = t.get("by_threads") or {}
    each = "; ".join(f"**{v['ratio']:.2f}×** on {n} thread{'s' if n != '1' else ''} ({v['timeline_s']:.2f} s vs "
                     f"{v['single_s']:.2f} s, medians of {v['timelines']} interleaved, windows begun together)"
                     for n, v in sorted(by.items(), key=lambda kv: int(kv[0])))
    return (f"{each}. The model's work: {t['timeline_frame_rows']} vs {t['single_frame_rows']} frame-rows "
            f"({t['work_ratio']:.2f}×); in the quality run above ({t['timeline_s']['n']} timelines, 1 thread): "
            f"{t['timeline_s']['median']:.2f} s vs {t['single_s']['median']:.2f} s = {_f(t['ratio_of_medians'])}×, sampling "
            f"{share:.1%} of a timeline's time, {us['timeline']:.1f} vs {us['single']:.1f} µs per frame-row")


def _flips(s: dict) -> str:
    fs = s.get("flip_share_of_frames")
    if not fs:
        return ""
    fail = s.get("failing", [])
    share = (f"one-frame flips of the model's output (a joint > {FLIP_M * 100:.0f} cm off its neighbours' mean and back): "
             f"real clips {fs['real']:.2%} of frames, single generated motions {fs['single']:.2%}, timelines {fs['timeline']:.2%}")
    if not fail:
        return f"; {share}"
    worst = "; ".join(f"{' → '.join(x['order'])} seam {x['seam']} {x['acceleration_ratio']:.2f}× (flip {x['flip_m'] * 100:.0f} cm)"
                      for x in sorted(fail, key=lambda x: -x["acceleration_ratio"])[:4])
    return (f"; {s['failing_on_flip']} of the {len(fail)} seams over the bar have a flip within {FLIP_FRAMES} frames "
            f"({worst}); {share}")


def _uneased(s: dict) -> str:
    u = s.get("uneased_acceleration_ratio")
    if not u:
        return ""
    return (f"; the same windows without `ease_seams`: median {_f(u['median'])}×, max {_f(u['max'])}×, "
            f"{round(u['share_within_bar'] * u['n'])}/{u['n']} ≤ 1.5×")


# ----------------------------------------------------------------------------------------------- CLI

def build_parser() -> argparse.ArgumentParser:
    from emdm.eval.coverage import PROMPTS_FILE

    ap = argparse.ArgumentParser(prog="python -m emdm.eval.editing", description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default="emdm-t2m-web", help="a shipped text model of public/models/manifest.json")
    ap.add_argument("--models-dir", type=Path, default=None)
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--timelines", type=int, default=72, help="3-segment timelines (each action in about half of them; "
                    "36 gave seam skate 1.16 and 1.28 with seeds 0 and 1000, 72 pool both halves' noise)")
    ap.add_argument("--seconds", type=float, default=5.0, help="seconds per segment and per single motion")
    ap.add_argument("--actions", type=lambda s: tuple(x.strip() for x in s.split(",") if x.strip()), default=ACTIONS)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--dataset", type=Path, default=DATASET_DIR)
    ap.add_argument("--split", default="test")
    ap.add_argument("--classifier", type=Path, default=RUNS_DIR / "eval" / "classifier.pt")
    ap.add_argument("--prompts", type=Path, default=PROMPTS_FILE)
    ap.add_argument("--variant", default="page", help="the ONNX file: fp32, int8, fp16, or page (default: the entry's "
                    "defaultVariant, the file the page runs)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--time-threads", type=lambda v: [int(x) for x in v.split(",")], default=[1, 2],
                    help="thread counts the time bar is measured at, comma-separated (met when met at each)")
    ap.add_argument("--time-timelines", type=int, default=12, help="timelines (and single motions) timed per thread count")
    ap.add_argument("--time-only", action="store_true",
                    help="only the time bar, at each of --time-threads (no dataset or classifier needed): writes "
                         "editing-time-<model>-<runtime>.json")
    ap.add_argument("--ckpt", type=Path, default=None,
                    help="with --time-only: time these PyTorch weights (e.g. public/models/<model>.weights.f16.pt) on "
                         "--device, with --model's sampling settings, instead of its ONNX file")
    ap.add_argument("--device", default="cpu", help="with --ckpt: cpu, cuda or cuda:N")
    ap.add_argument("--import-page", type=Path, default=None, metavar="FILE",
                    help="write the page benchmark's timeline-time.json (tests/e2e/page-bench.spec.ts) as an editing-time "
                         "result of --model (on the machine that measured it)")
    ap.add_argument("--out", type=Path, default=None,
                    help="default docs/results/json/editing-<model>.json (editing-<model>-seed<N>.json with --seed N ≠ 0)")
    return ap


def main(argv: list[str] | None = None) -> int:
    import torch

    from emdm.eval.coverage import CoverageError
    from emdm.model.open import ModelError
    from emdm.motion.edit import EditError
    from emdm.manifest import ManifestError
    from emdm.outdir import OutputRefused

    a = build_parser().parse_args(argv)
    torch.set_num_threads(a.threads)
    try:
        if len(a.actions) < 3:
            raise EditingError(f"--actions: a 3-segment timeline needs at least 3 actions, got {len(a.actions)}")
        if sum(x not in LAST_ONLY for x in a.actions) < 2:
            raise EditingError(f"--actions: at least 2 of them must be able to come first ({', '.join(LAST_ONLY)} only ends a timeline)")
        if (a.ckpt is not None or a.device != "cpu") and not a.time_only:
            raise EditingError("--ckpt and --device time PyTorch weights: give --time-only too (the quality measures run "
                               "the shipped ONNX file, as the page does)")
        if a.device != "cpu" and a.ckpt is None:
            raise EditingError(f"--device {a.device}: the shipped ONNX file runs on the CPU; give --ckpt to time PyTorch "
                               "weights there")
        if a.device.startswith("cuda") and not torch.cuda.is_available():
            raise EditingError(f"--device {a.device}: PyTorch sees no CUDA GPU here")
        if a.time_only and (a.time_timelines < 1 or not a.time_threads or min(a.time_threads) < 1):
            raise EditingError("--time-only needs --time-timelines ≥ 1 and --time-threads of counts ≥ 1")
        if a.import_page is not None:
            print(f"wrote {display_path(import_page(a))}")
            return 0
        print(f"wrote {display_path(run_time_only(a) if a.time_only else run(a))}")
    except (EditingError, EditError, CoverageError, FileNotFoundError, ModelError, OutputRefused, ManifestError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
