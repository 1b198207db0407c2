"""The editing benchmark's runs (:mod:`emdm.eval.editing`): timelines and single motions of a shipped model,
interleaved, then each measure of :mod:`emdm.eval.editing_measures` over them, and the time bar on its own.

    m = measure(Editor.open(open_model("emdm-t2m-web")), Benchmark(...), args)   # the ``editing`` JSON's fields
    time_ratio(args, threads=2, orders=..., frames=100)                           # one thread count's time bar
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field, fields, replace
from itertools import permutations
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm.eval.coverage import load_prompts
from emdm.eval.editing_measures import (
    BARS, FPS, LEGS, UPPER, pose, root_frame, seam_acceleration, seam_flips, seam_root, seam_skate, summary)
from emdm.eval.plausibility import FLIP_M, flip_share
from emdm.model.open import open_model
from emdm.motion import edit as E
from emdm.motion.features import recover_joints
from emdm.motion.stitch import align_segment, append_segment
from emdm import paths
from emdm.paths import display_path

ACTIONS = ("walk", "raise-both-hands", "walk-backward", "walk-turn-left", "climb", "lie-down")
LAST_ONLY = ("lie-down",)          # a timeline puts these last (nothing in the data gets up from lying down)
TRANSITION_FRAMES = (0, 5, 10, 20)  # segments 2 and 3 are also read without their first d frames (a diagnostic)


class EditingError(ValueError):
    """An input of the benchmark cannot be used (the message names it)."""


def orders(actions, n: int, seed: int) -> list[tuple[str, ...]]:
    """``n`` orders of 3 distinct actions (LAST_ONLY ones only last), each action as equally often as can be: the
    valid orders in a seeded random order, each time the one whose actions have been used least."""
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
    joints = recover_joints(model.denormalise(windows[0]))
    for k in range(1, len(tl.frames)):
        joints = append_segment(joints, recover_joints(model.denormalise(windows[k])), min(tl.overlap, tl.starts[k]))
    return joints


def overlap_error_mm(model, tl, windows) -> float:
    """Max distance (mm) of each window's aligned overlap frames from the previous segment's last ones."""
    worst = 0.0
    for k in range(1, len(tl.frames)):
        s = tl.starts[k]
        c = min(tl.overlap, s)
        prev = tl.joints[:s]
        aligned = align_segment(prev, recover_joints(model.denormalise(windows[k])), c)
        worst = max(worst, float(np.abs(aligned[:c] - prev[-c:]).max() * 1000))
    return worst


@dataclass
class Runs:
    """What the interleaved runs produced: the timelines (with their orders, the windows' overlap error, the joints
    without seam easing and the windows as sampled) and the single motions (features, joints; their actions), with
    the seconds and the model's frame-rows of each."""
    orders: list[tuple[str, ...]]
    timelines: list = field(default_factory=list)
    singles: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)
    single_action: list[str] = field(default_factory=list)
    overlap_mm: float = 0.0
    uneased: list[np.ndarray] = field(default_factory=list)
    raw_segments: list[np.ndarray] | None = field(default_factory=list)
    t_tl: list[float] = field(default_factory=list)
    t_single: list[float] = field(default_factory=list)
    t_tl_sampling: list[float] = field(default_factory=list)
    t_single_sampling: list[float] = field(default_factory=list)
    tl_frame_rows: int = 0
    single_frame_rows: int = 0


def run_interleaved(model, prompt: dict[str, str], frames: int, a, log=print) -> Runs:
    """``a.timelines`` timelines (random orders of ``a.actions``) and as many single motions per action as segments,
    interleaved (their timings compare under the same load)."""
    rec = Recorder(model)
    for p in prompt.values():
        model.condition(p)                                        # encode once, outside every timing
    r = Runs(orders(list(a.actions), a.timelines, a.seed))
    per_single = max(1, round(3 * a.timelines / len(a.actions)))   # as many single motions per action as segments
    todo_single = [(x, s) for x in a.actions for s in range(per_single)]
    for i, o in enumerate(r.orders):
        rec.clear()
        t0 = time.perf_counter()
        tl = E.timeline(rec.editor, [E.Segment(prompt[x], a.seconds, a.seed + 10 * i + k) for k, x in enumerate(o)],
                        together=True)
        r.t_tl.append(time.perf_counter() - t0)
        r.t_tl_sampling.append(sum(rec.seconds))
        r.tl_frame_rows = rec.frame_rows
        r.overlap_mm = max(r.overlap_mm, overlap_error_mm(model, tl, rec.windows))
        if r.raw_segments is not None and len(rec.windows) == len(tl.frames):     # one window per segment (≤ 196 frames)
            r.raw_segments += [model.denormalise(w)[len(w) - n:] for w, n in zip(rec.windows, tl.frames)]
        else:
            r.raw_segments = None
        r.uneased.append(uneased_joints(model, tl, rec.windows))
        r.timelines.append(tl)
        for x, s in todo_single[i * len(todo_single) // len(r.orders):(i + 1) * len(todo_single) // len(r.orders)]:
            rec.clear()
            t0 = time.perf_counter()
            x_single = rec.editor.sample(prompt[x], frames, a.seed + 1000 + 10 * s + a.actions.index(x))
            r.t_single_sampling.append(time.perf_counter() - t0)
            f = model.denormalise(x_single)
            j = recover_joints(f)
            r.t_single.append(time.perf_counter() - t0)
            r.single_frame_rows = rec.frame_rows
            r.singles.append((f, j))
            r.single_action.append(x)
        log(f"timeline {i + 1}/{len(r.orders)} {' → '.join(o)}: {r.t_tl[-1]:.1f} s (load {os.getloadavg()[0]:.1f})")
    return r


def semantics(bench, r: Runs, actions, prompt: dict[str, str]) -> dict:
    """Every segment's new frames against the single motions, by the coverage benchmark's action classifier."""
    labels = bench.labels
    seg_feats, seg_action = [], []
    for tl, o in zip(r.timelines, r.orders):
        for k, x in enumerate(o):
            seg_feats.append(tl.features[tl.starts[k]:tl.starts[k] + tl.frames[k]])
            seg_action.append(x)
    singles, single_action, tl_orders = r.singles, r.single_action, r.orders
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
    pred_raw = bench.predict(r.raw_segments) if r.raw_segments else None   # diagnostic: the windows as sampled, un-eased
    per_action = {}
    for x in actions:
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
    return {"segment_rate": seg_rate, "single_rate": single_rate, "segment_hits": seg_hits, "single_hits": single_hits,
            # from the counts, so a ratio exactly at the bar is not lost to rounding (40/54 ÷ 50/54 = 0.8)
            "ratio": (seg_hits * len(single_action)) / (len(seg_action) * single_hits) if single_hits else None, "segment_rate_by_position": by_pos,
            "segment_rate_without_first_second": late_hits / len(seg_action),
            "single_rate_without_first_second": single_late_hits / len(single_action),
            "ratio_after_transition": (late_hits * len(single_action)) / (len(seg_action) * single_late_hits)
            if single_late_hits else None,
            "uneased_segment_rate": raw_rate, "later_segments_read_as_previous": read_as_previous,
            "later_segment_rate_without_first_frames": later_after,
            "segments": len(seg_action), "singles": len(single_action), "per_action": per_action}


def seam_figures(bench, r: Runs) -> dict:
    """The seams' acceleration, foot skate and root jumps; real clips and single motions at their middle frame are
    the reference (what a continuous motion scores)."""
    timelines, singles, tl_orders = r.timelines, r.singles, r.orders
    seams = [tl.starts[1:] for tl in timelines]
    acc = [x for tl, s in zip(timelines, seams) for x in seam_acceleration(tl.joints, s)]
    acc_uneased = [x for j, s in zip(r.uneased, seams) for x in seam_acceleration(j, s)]
    root = [x for tl, s in zip(timelines, seams) for x in seam_root(tl.joints, s)]
    real = [recover_joints(m) for m in bench.test.motions if len(m) >= 3 * FPS]
    bar = BARS["seam_acceleration"]
    ref_acc = {"real": summary([x for j in real for x in seam_acceleration(j, [len(j) // 2])], bar),
               "single": summary([x for _, j in singles for x in seam_acceleration(j, [len(j) // 2])], bar)}
    ref_root = {"real": [x for j in real for x in seam_root(j, [len(j) // 2])],
                "single": [x for _, j in singles for x in seam_root(j, [len(j) // 2])]}
    near = [x for tl, s in zip(timelines, seams) for x in seam_flips(tl.features, s)]
    failing = [i for i, x in enumerate(acc) if x > bar]
    root_failing = [i for i, x in enumerate(root) if max(x["jump_ratio"], x["turn_jump_ratio"]) > BARS["seam_root"]]
    where = [(ti, k + 1) for ti, s in enumerate(seams) for k in range(len(s))]     # (timeline, seam) of acc[i], root[i]
    shares = {"real": flip_share(bench.test.motions), "single": flip_share([f for f, _ in singles]),
              "timeline": flip_share([tl.features for tl in timelines])}
    skate = seam_skate([(tl.joints, s) for tl, s in zip(timelines, seams)])
    ref_skate = {"real": seam_skate([(j, [len(j) // 2]) for j in real]),
                 "single": seam_skate([(j, [len(j) // 2]) for _, j in singles])}
    ref = lambda key: {k: summary([x[key] for x in v], BARS["seam_root"]) for k, v in ref_root.items()}  # noqa: E731
    return {"count": len(acc), "acceleration_ratio": summary(acc),
            "acceleration_within_bar": int(np.sum(np.asarray(acc) <= BARS["seam_acceleration"])),
            "failing": [{"timeline": where[i][0], "order": list(tl_orders[where[i][0]]), "seam": where[i][1],
                         "acceleration_ratio": acc[i], "flip_m": near[i]} for i in failing],
            "failing_on_flip": int(sum(near[i] > FLIP_M for i in failing)),
            "flip_share_of_frames": shares,
            "uneased_acceleration_ratio": summary(acc_uneased, BARS["seam_acceleration"]),
            "reference_acceleration_ratio": ref_acc,
            "skate": skate, "reference_skate": ref_skate,
            "root_step_ratio": summary([x["step_ratio"] for x in root]),
            "root_turn_ratio": summary([x["turn_ratio"] for x in root]),
            "root_step_cm": summary([x["step_cm"] for x in root]),
            "root_turn_deg": summary([x["turn_deg"] for x in root]),
            "root_jump_ratio": summary([x["jump_ratio"] for x in root]),
            "root_turn_jump_ratio": summary([x["turn_jump_ratio"] for x in root]),
            "root_within_bar": len(root) - len(root_failing),
            "root_failing": [{"timeline": where[i][0], "order": list(tl_orders[where[i][0]]), "seam": where[i][1],
                              "jump_ratio": root[i]["jump_ratio"], "turn_jump_ratio": root[i]["turn_jump_ratio"]}
                             for i in root_failing],
            "reference_root_step_ratio": ref("step_ratio"), "reference_root_turn_ratio": ref("turn_ratio"),
            "reference_root_jump_ratio": ref("jump_ratio"), "reference_root_turn_jump_ratio": ref("turn_jump_ratio"),
            "real_clips": len(real)}


def kept_and_loops(model, r: Runs, a, prompt: dict[str, str]) -> tuple[dict, dict]:
    """Kept parts (in-betweening, lower or upper body kept; the timeline's overlap) and loops, on the first single
    motion of each action."""
    firsts = [r.singles[r.single_action.index(x)] for x in a.actions]
    kept = {"timeline_overlap_mm": r.overlap_mm, "inbetween_mm": 0.0, "lower_mm": 0.0, "upper_mm": 0.0}
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
    return kept, {"count": len(firsts), "ends": E.LOOP_ENDS, "pose_cm": summary(loops["pose_cm"]),
                  "wrap_acceleration_ratio": summary(loops["wrap_acceleration"]),
                  "travel_cm": summary(loops["travel_cm"]), "in_place_travel_cm": summary(loops["in_place_travel_cm"])}


def time_figures(r: Runs, a, prompt: dict[str, str], frames: int, log=print) -> dict:
    """A timeline's time against a single motion's, from the interleaved runs and (``time_ratio``) at each of
    ``a.time_threads``."""
    t_tl, t_single, t_tl_sampling, t_single_sampling = r.t_tl, r.t_single, r.t_tl_sampling, r.t_single_sampling
    tl_frame_rows, single_frame_rows = r.tl_frame_rows, r.single_frame_rows
    ratio = float(np.median(t_tl) / np.median(t_single))
    by_threads = {str(n): time_ratio(a, n, [[prompt[x] for x in o] for o in r.orders[:a.time_timelines]], frames, log)
                  for n in a.time_threads}
    return {"timeline_s": summary(t_tl), "single_s": summary(t_single), "ratio_of_medians": ratio,
            "timeline_frames": int(len(r.timelines[0].features)), "single_frames": frames,
            # where the time goes: sampling (the model's steps) against the rest (seam easing, decoding, stitching)
            "timeline_sampling_s": summary(t_tl_sampling), "single_sampling_s": summary(t_single_sampling),
            # the model's work: Σ rows × frames over its calls (a timeline's windows begun together, as the page)
            "timeline_frame_rows": tl_frame_rows, "single_frame_rows": single_frame_rows,
            "work_ratio": tl_frame_rows / single_frame_rows,
            "us_per_frame_row": {"timeline": float(np.median(t_tl_sampling)) * 1e6 / tl_frame_rows,
                                 "single": float(np.median(t_single_sampling)) * 1e6 / single_frame_rows},
            "by_threads": by_threads}


def measure(model, bench, a, log=print) -> dict:
    """Every measure of the benchmark on ``model`` (an Editor), the fields of the ``editing`` result JSON."""
    labels = bench.labels
    missing = [x for x in a.actions if x not in labels]
    if missing:
        raise EditingError(f"--actions: {', '.join(missing)} not in the dataset's vocabulary ({', '.join(labels[:6])}, …)")
    prompt = {x: load_prompts(bench.prompts_file, labels)[x][0] for x in a.actions}
    frames = E.segment_frames(a.seconds)
    r = run_interleaved(model, prompt, frames, a, log)
    sem = semantics(bench, r, a.actions, prompt)
    seams = seam_figures(bench, r)
    kept, loops = kept_and_loops(model, r, a, prompt)
    return {"actions": list(a.actions), "prompts": prompt, "segment_seconds": a.seconds, "timelines": len(r.timelines),
            "orders": [list(o) for o in r.orders], "seams": seams, "semantics": sem, "kept": kept, "loops": loops,
            "time": time_figures(r, a, prompt, frames, log)}


def timed_editor(a, threads: int):
    """The Editor the time bar runs: the shipped file of ``a.variant`` through ONNX Runtime on ``threads`` threads, or
    (``a.ckpt``) those PyTorch weights on ``a.device`` with the shipped entry's sampling settings (guidance, where
    it stops, x̂0 smoothing), so the same steps run on either."""
    if a.ckpt is None:
        variant = page_variant(a.model, a.models_dir) if a.variant == "page" else a.variant
        return E.Editor.open(open_model(a.model, models_dir=a.models_dir, threads=threads, variant=variant), steps=a.steps)
    import torch

    torch.set_num_threads(threads)
    entry = mf.load(paths.models_dir(a.models_dir))["models"].get(a.model)
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
    plain = {x: p[0] for x, p in load_prompts(a.prompts, list(a.actions)).items()}
    return [[plain[x] for x in o] for o in orders(list(a.actions), a.time_timelines, a.seed)]


def page_variant(model: str, models_dir: Path | None) -> str | None:
    """The file the page runs for a shipped model: its entry's ``defaultVariant`` (None: the fp32 file, also when the
    manifest cannot be read, which ``open_model`` then reports)."""
    try:
        return mf.load(paths.models_dir(models_dir))["models"].get(model, {}).get("defaultVariant")
    except mf.ManifestError:
        return None
