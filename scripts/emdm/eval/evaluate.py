"""Run one evaluation and write its result JSON (read by ``python -m emdm.eval.report``).

    python -m emdm.eval.evaluate text   --source real                       # real-vs-real row
    python -m emdm.eval.evaluate text   --ckpt runs/t2m/ckpt.pt --steps 10  # a trained model
    python -m emdm.eval.evaluate action --ckpt runs/a2m/ckpt.pt --steps 10
    python -m emdm.eval.evaluate timing --model runs/t2m/ckpt.pt=1,2,4,10 --model runs/ddim/ckpt.pt=10,50,100

Defaults: dataset ``data/dataset``, split ``test``, evaluators ``runs/eval/{matcher,classifier}.pt``,
20 repeats, output ``docs/results/json/<task>-<variant>-<steps>.json`` (``--out-dir`` another folder). A result
there that measured more (clips, repeats, or a model trained longer) is not replaced without ``--replace``: a trial
run names its own folder. On a shared CPU prefix with
``nice -n 19``; ``--threads`` (default 1) sets torch's threads.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import torch

from emdm import manifest as mf
from emdm.data.dataset import cached_text_embeddings
from emdm.eval import data as evdata
from emdm.eval import evaluators as E
from emdm.eval.metrics import R_PRECISION_POOL
from emdm.eval.protocol import Conditions, RealSource, evaluate_action, evaluate_text
from emdm.eval.results import RESULTS_DIR, SCHEMA, dataset_info, evaluator_info, hardware, slug, write_result
from emdm.eval.sources import ModelSource, variant_of
from emdm.manifest import ManifestError
from emdm.model.open import ModelError, is_checkpoint, open_model
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, RUNS_DIR, display_path, MODELS_DIR


class EvaluateError(ValueError):
    """An input of an evaluation cannot be used; one line naming the file and what is wrong."""


def load_evaluator(path: Path, kind: str):
    """``evaluators.load``, with a missing or unreadable checkpoint as an EvaluateError."""
    try:
        return E.load(path, kind)
    except (OSError, ValueError) as e:
        raise EvaluateError(str(e)) from None


def run_quality(a) -> Path:
    if a.out:
        check_writable(a.out)                             # before anything is measured
    source = None
    if a.source != "real":
        source = ModelSource(ckpt=a.ckpt, model=a.model, onnx_variant=a.variant, models_dir=a.models_dir, steps=a.steps, guidance=a.guidance,
                             guidance_min_time=a.guidance_min_time, x0_smoothing=a.x0_smoothing, batch_size=a.batch, threads=a.threads, device=a.device, name=a.name or "")
        if source.task != a.task:
            raise SystemExit(f"error: {a.ckpt or a.model} is a {source.task} model, not {a.task}")
    test = evdata.load_split(a.dataset, a.split, max_items=a.max_items or None,
                             require_action=a.task == "action")
    check_size(a, test)
    if source is None:
        source = RealSource(test, info={"variant": "real"})
    elif a.task == "action":
        check_labels(f"{a.ckpt or a.model}: the action model", source.cond_spec.get("labels"), test)
    if a.name:
        source.name = a.name
    out = a.out or (a.out_dir or RESULTS_DIR / "json") / (slug(a.task, source.info.get("variant"),
                                                                 source.info.get("steps")) + ".json")
    check_writable(out)
    if not (a.out or a.out_dir or a.replace):
        keep_larger(out, len(test), a.repeats, source.info.get("train_steps"))
    path = a.matcher if a.task == "text" else a.classifier
    ev = load_evaluator(path, "matcher" if a.task == "text" else "classifier")
    if a.task == "action":
        retrain = f"python -m emdm.eval.evaluators classifier --dataset {display_path(Path(a.dataset))}"
        check_labels(f"{display_path(path)}: the action classifier (retrain it: {retrain})",
                     getattr(ev, "meta", {}).get("labels"), test)
    t0 = time.time()
    if a.task == "text":
        caps = evdata.caption_embeddings(test)
        res = evaluate_text(ev, test, caps, source, repeats=a.repeats, seed=a.seed, mm_texts=a.mm_texts,
                            mm_repeats=a.mm_repeats, plaus_n=a.plaus_n)
    else:
        res = evaluate_action(ev, test, source, repeats=a.repeats, seed=a.seed, plaus_n=a.plaus_n)
    result = {"schema": SCHEMA, "name": source.name, "kind": source.kind, "info": source.info,
              "dataset": dataset_info(Path(a.dataset), a.split), "hardware": hardware(),
              "load_avg_1min_end": os.getloadavg()[0],
              "evaluator": evaluator_info(ev, path), "minutes": (time.time() - t0) / 60,
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds"), **res}
    return write_result(result, out)


def check_size(a, test) -> None:
    """The split is large enough for the task's metrics (R-precision draws a pool of clips)."""
    if a.task == "text" and len(test) < R_PRECISION_POOL:
        given = f" (--max-items {a.max_items})" if a.max_items else ""
        raise EvaluateError(f"{display_path(Path(a.dataset))}/{a.split}.txt: {len(test)} clips{given}; R-precision "
                            f"needs at least {R_PRECISION_POOL}: pass --max-items {R_PRECISION_POOL} or more, "
                            "or 0 (all)")


def check_labels(who: str, labels, test) -> None:
    """``labels`` (a model's or classifier's action vocabulary, in its order) are the split's: an action model or
    classifier of another dataset build would read the clips' action ids as other actions."""
    if labels is None or list(labels) == list(test.action_labels):
        return
    missing = [x for x in test.action_labels if x not in labels]
    what = (f"has no {', '.join(missing)}" if missing else "orders them otherwise")
    raise EvaluateError(f"{who} knows {len(labels)} actions, the dataset {display_path(Path(test.root))} "
                        f"{len(test.action_labels)}, and {what}: it was trained on another dataset build")


def keep_larger(out: Path, n: int, repeats: int, train_steps) -> None:
    """Refuse to replace a result that measured more (more clips or repeats, or a model trained longer) than this run
    will: a trial run on a few clips, or a small model's, would overwrite the committed row of the same name."""
    try:
        old = json.loads(out.read_text())
    except (OSError, ValueError):
        return
    old_steps = (old.get("info") or {}).get("train_steps")
    larger = [f"{old.get('n')} clips (this run {n})" if int(old.get("n") or 0) > n else "",
              f"{old.get('repeats')} repeats (this run {repeats})" if int(old.get("repeats") or 0) > repeats else "",
              f"a model trained {old_steps} steps (this one {train_steps})"
              if old_steps and train_steps is not None and old_steps > train_steps else ""]
    larger = [x for x in larger if x]
    if larger:
        raise EvaluateError(f"{display_path(out)} holds a larger measurement ({'; '.join(larger)}): write this one "
                            f"elsewhere with --out-dir DIR (suite: --results DIR), or pass --replace to replace it")


def run_timing(a) -> Path:
    out = check_writable(a.out or (a.out_dir or RESULTS_DIR / "json") / f"timing-{a.runtime}.json")
    rows = []
    load_before = os.getloadavg()[0]
    for spec in a.model:
        if "=" not in spec:
            raise SystemExit(f"error: --model {spec!r}: expected CKPT=STEPS[,STEPS...]")
        ckpt, steps = spec.rsplit("=", 1)
        is_ckpt = is_checkpoint(ckpt)
        opened = open_model(Path(ckpt) if is_ckpt else ckpt, threads=a.threads, device=a.device)
        for T in [int(s) for s in steps.split(",")]:
            src = ModelSource(opened=opened, steps=T, guidance=a.guidance, batch_size=1, threads=a.threads, device=a.device)
            if src.task == "text":
                emb = cached_text_embeddings([a.prompt], evdata.TEXT_ENCODER, os.environ.get("EMDM_EVAL_CACHE") or evdata.CACHE_DIR)
                cond = Conditions(lengths=np.array([a.frames]), text_emb=emb)
            else:
                cond = Conditions(lengths=np.array([a.frames]), labels=np.array([0]))
            src.generate(cond, 0)                                  # warm-up
            ms = []
            for r in range(a.runs):
                t0 = time.perf_counter()
                src.generate(cond, r + 1)                          # returns numpy: the GPU has finished
                ms.append((time.perf_counter() - t0) * 1000)
            rows.append({"variant": src.info["variant"], "sampler": src.info["sampler"], "steps": T,
                         "frames": a.frames, "ms_per_motion": ms, "guidance": a.guidance, "batch": 1,
                         "threads": a.threads,
                         "source": display_path(ckpt) if is_ckpt else ckpt, "engine": src.info["runtime"], "preset": src.info["preset"]})
            print(f"{src.name}: {np.mean(ms):.1f} ms / motion, {np.mean(ms) / a.frames:.3f} ms / frame", flush=True)
    result = {"schema": SCHEMA, "task": "timing", "runtime": a.runtime, "hardware": hardware(),
              "load_avg_1min": [load_before, os.getloadavg()[0]],
              "note": "batch 1 (with guidance: one batched call of 2), one warm-up run; emdm.sample loop",
              "created": datetime.now(timezone.utc).isoformat(timespec="seconds"), "rows": rows}
    return write_result(result, out)


def import_bench(a) -> Path:
    """Convert the TypeScript core benchmark's JSON (``node scripts/bench/core-bench.mjs --json F``:
    {frames, reps, rows: [{env, model, threads, guidance, results: [{steps, msPerMotion, ...}]}]}, or
    the demo page's EMDM-vs-DDIM benchmark, tests/e2e/page-bench.spec.ts with EMDM_BENCH_JSON=F, which
    adds ``source`` and ``loadAverage`` [start, end]) into timing JSON: runtime ``browser-wasm``
    (Chromium rows) or ``node-wasm``; the variant of each model comes from its manifest entry's
    objective and training flags."""
    src = Path(a.bench)
    try:
        bench = json.loads(src.read_text())
        frames = int(bench["frames"])
        rows_in = bench["rows"]
    except (OSError, json.JSONDecodeError, KeyError, TypeError, ValueError) as e:
        raise SystemExit(f"error: {src}: not a core-bench JSON ({e})")
    models = mf.load(a.models_dir or MODELS_DIR)["models"]
    by_runtime: dict[str, list[dict]] = {}
    for i, r in enumerate(rows_in):
        name = r["model"].split(":")[0]
        if name not in models:
            raise SystemExit(f"error: {src}: rows[{i}].model {name!r} is not in the manifest")
        e = models[name]
        flags = e.get("training", {}).get("flags", {})
        runtime = "browser-wasm" if str(r["env"]).startswith("chromium") else "node-wasm"
        if a.threads_filter and int(r["threads"]) != a.threads_filter:
            continue
        if a.only_model and name != a.only_model:
            continue
        for x in r["results"]:
            by_runtime.setdefault(runtime, []).append({
                "variant": variant_of({"objective": e.get("objective", "ddgan"), "args": flags}),
                "sampler": "DDIM" if e.get("objective") == "diffusion" else "DDGAN", "steps": int(x["steps"]),
                "frames": frames, "ms_per_motion": [float(x["msPerMotion"])], "guidance": r.get("guidance"),
                "threads": int(r["threads"]), "env": r["env"], "source": r["model"], "reps": bench.get("reps"),
                "model_calls": x.get("modelCalls")})
    written = []
    for runtime, rows in by_runtime.items():
        result = {"schema": SCHEMA, "task": "timing", "runtime": runtime,
                  "hardware": f"{hardware().split(' (')[0]}; {rows[0]['env']}, ORT-web WASM",
                  "note": f"median of {bench.get('reps', '?')} runs from {src.name} "
                          f"({bench.get('source', 'scripts/bench/core-bench.mjs')}): text encoding + all steps + decode",
                  "load_avg_1min": [a.load_avg, a.load_avg] if a.load_avg else _load_pair(bench.get("loadAverage")),
                  "created": datetime.now(timezone.utc).isoformat(timespec="seconds"), "rows": rows}
        written.append(write_result(result, (a.out_dir or RESULTS_DIR / "json") / f"timing-{runtime}.json"))
    if not written:
        raise SystemExit(f"error: {src}: no rows")
    return written[-1]


def _load_pair(v) -> list[float] | None:
    """A benchmark's own [start, end] load average, when it recorded one."""
    if isinstance(v, list) and len(v) == 2 and all(isinstance(x, (int, float)) for x in v):
        return [round(float(x), 2) for x in v]
    return None


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.evaluate", description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="task", required=True)
    for task in ("text", "action"):
        p = sub.add_parser(task)
        src = p.add_mutually_exclusive_group(required=True)
        src.add_argument("--source", choices=["real"])
        src.add_argument("--ckpt", type=Path, help="an emdm.train checkpoint (PyTorch, EMA weights)")
        src.add_argument("--model", help="a shipped model of public/models/manifest.json (ONNX Runtime)")
        p.add_argument("--models-dir", type=Path, default=None, help="with --model: folder of manifest.json")
        p.add_argument("--variant", default=None, help="with --model: fp32 (default) or a manifest variant, e.g. int8")
        p.add_argument("--steps", type=int, default=10)
        p.add_argument("--guidance", type=float, default=2.5)
        p.add_argument("--guidance-min-time", type=float, default=None, metavar="T",
                       help="guide only steps whose time is above T (default: the manifest's guidanceMinTime, else 0)")
        p.add_argument("--x0-smoothing", type=float, default=None, metavar="SIGMA",
                       help="smooth x̂0 along time (σ frames) at every step but the last (default: the manifest's x0Smoothing, else 0)")
        p.add_argument("--name", default=None, help="row label (default from the checkpoint's flags)")
        p.add_argument("--dataset", type=Path, default=DATASET_DIR)
        p.add_argument("--split", default="test")
        p.add_argument("--max-items", type=int, default=0, help="evaluate at most this many clips (0 = all)")
        p.add_argument("--repeats", type=int, default=20)
        p.add_argument("--seed", type=int, default=0)
        p.add_argument("--plaus-n", type=int, default=200)
        p.add_argument("--batch", type=int, default=64)
        p.add_argument("--matcher", type=Path, default=RUNS_DIR / "eval" / "matcher.pt")
        p.add_argument("--classifier", type=Path, default=RUNS_DIR / "eval" / "classifier.pt")
        p.add_argument("--mm-texts", type=int, default=100)
        p.add_argument("--mm-repeats", type=int, default=30)
        p.add_argument("--threads", type=int, default=1)
        p.add_argument("--device", default="cpu", help="with --ckpt: cpu or cuda (the generator's device)")
        p.add_argument("--out", type=Path, default=None)
        p.add_argument("--out-dir", type=Path, default=None,
                       help="write <task>-<variant>-<steps>.json here (default docs/results/json)")
        p.add_argument("--replace", action="store_true",
                       help="replace a default-path result even if it measured more (clips, repeats, training)")
    p = sub.add_parser("timing")
    p.add_argument("--model", action="append", required=True,
                   help="CKPT=STEPS[,STEPS...] or MANIFEST_MODEL=STEPS[,...] (repeatable)")
    p.add_argument("--frames", type=int, default=196)
    p.add_argument("--runs", type=int, default=5)
    p.add_argument("--guidance", type=float, default=2.5)
    p.add_argument("--prompt", default="a person walks forward and waves")
    p.add_argument("--runtime", default="python-cpu")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--device", default="cpu", help="with checkpoints: cpu or cuda")
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--out-dir", type=Path, default=None, help="write timing-<runtime>.json here")
    p = sub.add_parser("import-bench", help="timing JSON from scripts/bench/core-bench.mjs --json output")
    p.add_argument("bench", type=Path)
    p.add_argument("--models-dir", type=Path, default=None)
    p.add_argument("--threads-filter", type=int, default=0, help="keep only rows with this thread count (0 = all)")
    p.add_argument("--load-avg", type=float, default=0.0, help="the machine's load average during the benchmark, if known")
    p.add_argument("--only-model", default=None, help="keep only rows of this manifest model (e.g. emdm-t2m-web)")
    p.add_argument("--out-dir", type=Path, default=None)
    p.add_argument("--threads", type=int, default=1)
    return ap


def main(argv: list[str] | None = None) -> int:
    """The CLI: an unusable model, evaluator checkpoint or --out is one line naming it, exit status 2."""
    a = build_parser().parse_args(argv)
    torch.set_num_threads(a.threads)
    try:
        if a.task == "timing":
            out = run_timing(a)
        elif a.task == "import-bench":
            out = import_bench(a)
        else:
            out = run_quality(a)
    except (ModelError, EvaluateError, OutputRefused, ManifestError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
