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

Writes ``docs/results/json/editing-<model>.json`` (schema 1, task ``editing``); ``emdm.eval.editing_section`` renders
it for ``emdm.eval.report``. The load average is recorded: timings on a shared CPU are labelled with it.
This module is the command line; the runs are in ``editing_run``, the measures and bars in ``editing_measures``.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

from emdm.eval.coverage import PROMPTS_FILE, Benchmark, CoverageError
from emdm.eval.editing_measures import bars, time_bar
from emdm.eval.editing_run import (
    ACTIONS, LAST_ONLY, EditingError, measure, page_variant, time_orders, time_ratio)
from emdm.eval.judge import add_argument as add_judge_argument
from emdm.eval.results import RESULTS_DIR, SCHEMA, dataset_info, hardware, write_result
from emdm.manifest import ManifestError
from emdm.model.open import ModelError, open_model
from emdm.motion.edit import EditError, Editor, segment_frames
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, display_path


def run(a) -> Path:
    out = check_writable(a.out or (RESULTS_DIR / "json" / f"editing-{a.model}{f'-seed{a.seed}' if a.seed else ''}.json"))
    t0, load0 = time.time(), os.getloadavg()[0]
    variant = page_variant(a.model, a.models_dir) if a.variant == "page" else a.variant
    opened = open_model(a.model, models_dir=a.models_dir, threads=a.threads, variant=variant)
    model = Editor.open(opened, steps=a.steps)
    bench = Benchmark(a.dataset, a.split, a.classifier, a.prompts, seeds=1, seed=a.seed)
    m = measure(model, bench, a)
    result = {"schema": SCHEMA, "task": "editing", "name": a.model, "variant": opened.variant, "steps": a.steps,
              "guidance": model.settings.guidance, "guidance_min_time": model.settings.guidance_min_time,
              "x0_smoothing": model.settings.x0_smoothing,
              "seed": a.seed, **m, "bars": bars(m), "classifier": bench.judge.info(),
              "classifier_real_macro": bench.real.get("macro_accuracy"),
              "dataset": dataset_info(Path(a.dataset), a.split), "hardware": hardware(), "threads": a.threads,
              "seconds": round(time.time() - t0, 1), "load_avg_1min_start": load0, "load_avg_1min_end": os.getloadavg()[0],
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds")}
    return write_result(result, out)


def run_time_only(a) -> Path:
    """``--time-only``: the time bar alone (no dataset, classifier or quality measures), at each of ``--time-threads``;
    with ``--ckpt`` the PyTorch weights on ``--device`` (a GPU), the runtime the issue's bar is out of reach without
    on these CPUs. Writes ``editing-time-<model>-<runtime>.json`` (task ``editing-time``)."""
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
    """``hardware()`` without its torch thread count (a time row names its own threads); the GPU, when there is one,
    stays."""
    return hardware(torch_threads=False)


PAGE_KEYS = ("reps", "singleMs", "timelineMs", "steps", "environment", "load", "timelineWindowFrames")


def import_page(a) -> Path:
    """``--import-page FILE``: the page benchmark's figures (tests/e2e/page-bench.spec.ts "timeline against" writes
    timeline-time.json) as an ``editing-time`` result (runtime ``page-<backend>-<file>``) for RESULTS.md. Import it on
    the machine that measured it (its hardware is read here)."""
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


# ----------------------------------------------------------------------------------------------- CLI

def build_parser() -> argparse.ArgumentParser:
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
    add_judge_argument(ap)
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
