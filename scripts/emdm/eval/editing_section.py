"""RESULTS.md's "Beyond one prompt" section from the editing benchmark's JSON (``emdm.eval.report`` calls
``section`` for each ``editing`` result and ``time_section`` for the ``editing-time`` ones)."""

from __future__ import annotations

from emdm.eval.editing_measures import FLIP_FRAMES, SEAM_SKATE_FRAMES, skate_figure
from emdm.eval.plausibility import FLIP_M


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
            f"(a walk turning on through a seam at its own rate)"
            + "".join(f"; over 1.5× at the seam into segment {f['seam'] + 1} of {' → '.join(f['order'])} (position "
                      f"{_f(f['jump_ratio'])}×, heading {_f(f['turn_jump_ratio'])}×)" for f in s.get("root_failing", [])))


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
