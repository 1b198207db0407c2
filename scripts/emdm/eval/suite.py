"""The whole evaluation in one command: real-vs-real rows, every given model at its step counts,
Python CPU timings, then docs/RESULTS.md.

    python -m emdm.eval.suite --text runs/t2m-web/ckpt.pt --action runs/a2m-web/ckpt.pt \\
        [--diffusion runs/t2m-diffusion/ckpt.pt] [--naive runs/t2m-naive/ckpt.pt] [--nodcond runs/t2m-nodcond/ckpt.pt] \\
        [--repeats 20] [--max-items 0] [--skip-real] [--device cuda --batch 512]

A model is an ``emdm.train`` checkpoint (``.pt``) or the name of a shipped model in
public/models/manifest.json, opened by ``emdm.model.open`` in each evaluation; the suite stops at the first
evaluation that cannot run (a bad file or name: its one-line error, and the same exit status 2). EMDM-style
models are evaluated at ``--steps`` (default 10); the diffusion baseline at ``--ddim-steps`` (default 10,50,100). Each run writes its JSON under
docs/results/json/ as it finishes, so an interrupted suite keeps what it measured, and the report rewrites
docs/RESULTS.md. ``--results DIR`` puts both elsewhere (DIR/json/, DIR/RESULTS.md): a trial run on a few clips or a
small model belongs there. Without it, a committed result that measured more (clips, repeats, or a model trained
longer) stops the suite with one line instead of being replaced, unless ``--replace``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from emdm.eval import evaluate, report
from emdm.model.open import is_checkpoint
from emdm.outdir import OutputRefused, check_writable


def _where(model: str) -> list[str]:
    return ["--ckpt", model] if is_checkpoint(model) else ["--model", model]


def plan(a) -> list[list[str]]:
    where = (["--out-dir", str(a.results / "json")] if a.results else []) + (["--replace"] if a.replace else [])
    common = ["--repeats", str(a.repeats), "--max-items", str(a.max_items), "--threads", str(a.threads),
              "--device", a.device, "--batch", str(a.batch),
              "--mm-texts", str(a.mm_texts), "--mm-repeats", str(a.mm_repeats), "--plaus-n", str(a.plaus_n), *where]
    runs: list[list[str]] = []
    real = ["--source", "real", "--repeats", str(a.real_repeats), "--max-items", str(a.max_items), *where]
    if not a.skip_real:
        runs.append(["text", *real])
        if a.action:
            runs.append(["action", *real])
    for model in (a.text, a.naive, a.nodcond):
        if model:
            for T in a.steps:
                runs.append(["text", *_where(model), "--steps", str(T), *common])
    if a.diffusion:
        for T in a.ddim_steps:
            runs.append(["text", *_where(a.diffusion), "--steps", str(T), *common])
    if a.action:
        for T in a.steps:
            runs.append(["action", *_where(a.action), "--steps", str(T), *common])
    timing = [f"{m}={','.join(map(str, a.timing_steps))}" for m in (a.text,) if m]
    if a.diffusion:
        timing.append(f"{a.diffusion}={','.join(map(str, a.ddim_steps))}")
    if timing and a.timing_runs > 0:
        runs.append(["timing", *sum((["--model", t] for t in timing), []), "--runs", str(a.timing_runs),
                     "--threads", str(a.threads), "--device", a.device,
                     "--runtime", "python-cuda" if a.device.startswith("cuda") else "python-cpu",
                     *(["--out-dir", str(a.results / "json")] if a.results else [])])
    return runs


def main(argv: list[str] | None = None) -> int:
    ints = lambda s: [int(x) for x in s.split(",") if x]  # noqa: E731
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.suite", description=__doc__.split("\n\n")[0])
    ap.add_argument("--text", help="EMDM text model (checkpoint .pt or manifest name)")
    ap.add_argument("--action", help="EMDM action model")
    ap.add_argument("--diffusion", help="diffusion baseline (train.py --objective diffusion)")
    ap.add_argument("--naive", help="naive DDGAN (train.py --geo-weight 0 --no-d-cond)")
    ap.add_argument("--nodcond", help="DDGAN + L_geo with D unconditioned (train.py --no-d-cond)")
    ap.add_argument("--steps", type=ints, default=[10])
    ap.add_argument("--ddim-steps", type=ints, default=[10, 50, 100])
    ap.add_argument("--timing-steps", type=ints, default=[1, 2, 4, 5, 8, 10])
    ap.add_argument("--timing-runs", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--real-repeats", type=int, default=20)
    ap.add_argument("--max-items", type=int, default=0)
    ap.add_argument("--mm-texts", type=int, default=100)
    ap.add_argument("--mm-repeats", type=int, default=30)
    ap.add_argument("--plaus-n", type=int, default=200)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu", help="cpu or cuda: where checkpoints' generators run")
    ap.add_argument("--batch", type=int, default=64, help="motions per batched sampling call")
    ap.add_argument("--skip-real", action="store_true")
    ap.add_argument("--dry-run", action="store_true", help="print the evaluate commands only")
    ap.add_argument("--results", type=Path, default=None,
                    help="write the JSONs to DIR/json and the report to DIR/RESULTS.md (default docs/results, "
                         "docs/RESULTS.md)")
    ap.add_argument("--replace", action="store_true",
                    help="replace committed results even where they measured more (clips, repeats, training)")
    a = ap.parse_args(argv)
    if a.results is not None:
        try:
            check_writable(a.results, folder=True, option="--results")
        except OutputRefused as e:
            print(f"error: {e}", file=sys.stderr)
            return 2
    runs = plan(a)
    for r in runs:
        print("python -m emdm.eval.evaluate " + " ".join(r), flush=True)
        if not a.dry_run:
            rc = evaluate.main(r)
            if rc:                  # its one-line error is printed under its command; later rows would fail alike
                return rc
    if not a.dry_run:
        report.main(["--results", str(a.results), "--out", str(a.results / "RESULTS.md")] if a.results else [])
    return 0


if __name__ == "__main__":
    sys.exit(main())
