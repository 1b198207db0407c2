"""``python -m emdm.train``'s command line (its options and their defaults; :mod:`emdm.train` runs them)."""

from __future__ import annotations

import argparse
from pathlib import Path

from emdm.model.generator import PRESETS
from emdm.sampler.schedule import SUPPORTED_STEPS

DESCRIPTION = "Train the EMDM generator (DDGAN with geometric losses, or the plain diffusion baseline)."


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m emdm.train", description=DESCRIPTION,
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--data", type=Path, default=None, help="HumanML3D-layout dataset folder (default: emdm.paths.DATASET_DIR)")
    p.add_argument("--split", default="train")
    p.add_argument("--task", choices=["text", "action"], default="text")
    p.add_argument("--encoder", default="all-MiniLM-L6-v2", help="text encoder id (emdm.text)")
    p.add_argument("--out", type=Path, required=True, help="run folder (checkpoint, log, text-embedding cache)")
    p.add_argument("--preset", choices=sorted(PRESETS), default="web", help="generator preset")
    p.add_argument("--objective", choices=["ddgan", "diffusion"], default="ddgan")
    p.add_argument("--steps", type=int, default=20000, help="total optimisation steps (cosine LR horizon)")
    p.add_argument("--batch", type=int, default=64, help="batch per process")
    p.add_argument("--lr-g", type=float, default=None, help="generator LR at batch 64 (default 2e-5 text, 3e-5 action)")
    p.add_argument("--lr-d", type=float, default=1.25e-4, help="discriminator LR at batch 64")
    p.add_argument("--lr-scale", choices=["none", "sqrt", "linear"], default="none",
                   help="scale --lr-g/--lr-d by (global batch / 64)^½ or ^1 (global batch = --batch × processes)")
    p.add_argument("--lr-min", type=float, default=1e-5, help="cosine decay floor")
    p.add_argument("--warmup", type=int, default=0, help="linear LR warm-up steps")
    p.add_argument("--betas", type=float, nargs=2, default=(0.5, 0.9))
    p.add_argument("--ema", type=float, default=0.9999)
    p.add_argument("--ema-warmup", action=argparse.BooleanOptionalAction, default=True,
                   help="use decay min(ema, (1+n)/(10+n)) so short runs do not keep the initial weights")
    p.add_argument("--geo-weight", type=float, default=100.0, help="R: weight of L_geo in the G loss (0 = naive DDGAN)")
    p.add_argument("--geo-weight-t1", type=float, default=None, metavar="R1",
                   help="R at t = 1 (DDGAN): a sample's L_geo weight is R^(1−t)·R1^t, so the steps with a small "
                        "R lean on the discriminator more than on the mean motion MSE asks for (default: R at every t)")
    p.add_argument("--lambda-geo", type=float, default=1.0, help="λ: weight of the joint terms inside L_geo")
    p.add_argument("--w-pos", type=float, default=1.0)
    p.add_argument("--w-vel", type=float, default=1.0)
    p.add_argument("--w-foot", type=float, default=1.0)
    p.add_argument("--w-bone", type=float, default=0.0,
                   help="weight of L_bone, the squared relative bone-length error (not in the paper: 0 = its recipe)")
    p.add_argument("--adv-weight", type=float, default=1.0, help="weight of the G adversarial term")
    p.add_argument("--r1-gamma", type=float, default=0.02)
    p.add_argument("--r1-every", type=int, default=15)
    p.add_argument("--d-cond", action=argparse.BooleanOptionalAction, default=True, help="condition D on c")
    p.add_argument("--d-width", type=int, default=None,
                   help="D's first hidden width (default 1024, as released; 64 with --preset tiny: its checkpoint "
                        "stays small)")
    p.add_argument("--cond-drop", type=float, default=0.1, help="probability of the zero (unconditional) condition")
    p.add_argument("--supported-steps", default=",".join(map(str, SUPPORTED_STEPS)))
    p.add_argument("--time-draw", choices=["steps", "pairs"], default="steps",
                   help="DDGAN training times: 'steps' draws T uniformly from --supported-steps then k (most samples "
                        "at t = 1 and at each T's last step), 'pairs' every (T, k) equally (more at 10 steps' t = 0.9..0.7)")
    p.add_argument("--min-frames", type=int, default=40)
    p.add_argument("--random-crop", type=float, default=0.0,
                   help="probability of training on a random sub-window (≥ --min-frames) of a clip; teaches short "
                        "lengths and saves compute")
    p.add_argument("--crop-min", type=int, default=40, help="shortest random sub-window (frames)")
    p.add_argument("--balance-alpha", type=float, default=1.0,
                   help="draw clips by action with P(action) ∝ n_action^α (1 = every clip equally often, as before; "
                        "0 = every action equally often); clips without an action form one group")
    p.add_argument("--limit", type=int, default=None, help="use at most this many clips (smoke tests)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None, help="torch CPU threads per process")
    p.add_argument("--device", default=None, help="cpu | cuda (default: cuda when available)")
    p.add_argument("--amp", choices=["off", "bf16"], default="off", help="bfloat16 autocast of G and D (losses in float32)")
    p.add_argument("--compile", action="store_true", help="torch.compile G and D (the R1 steps run D eagerly)")
    p.add_argument("--log-every", type=int, default=10)
    p.add_argument("--ckpt-every", type=int, default=0, help="also checkpoint every N steps (0 = off)")
    p.add_argument("--ckpt-minutes", type=float, default=5.0, help="checkpoint every M minutes of wall time")
    p.add_argument("--time-limit-min", type=float, default=None, help="checkpoint and stop after M minutes")
    p.add_argument("--stop-at", type=int, default=None, help="checkpoint and stop at this step (testing resume)")
    p.add_argument("--no-resume", action="store_true", help="start fresh even if <out>/ckpt.pt exists")
    p.add_argument("--allow-other-data", action="store_true",
                   help="resume <out>/ckpt.pt even though it was trained on another dataset than --data")
    p.add_argument("--init-weights", type=Path, default=None,
                   help="start G (and its EMA) from a --weights-out file of an earlier run of the same model; "
                        "D and the optimisers start fresh. Its steps are recorded as the run's 'init' in meta")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="tqdm progress bar")
    p.add_argument("--weights-out", type=Path, default=None,
                   help="at the end also write the EMA generator alone (+ meta) to this file: what export, sample "
                        "and the evaluation read, ~1/50 of ckpt.pt (D and the optimisers stay out)")
    p.add_argument("--weights-minutes", type=float, default=None, metavar="M",
                   help="also write --weights-out every M minutes of wall time while training (a run cut short, "
                        "e.g. at the end of a GPU lease, still leaves its latest weights; 0 = at every log step)")
    p.add_argument("--weights-dtype", choices=["float32", "float16"], default="float32",
                   help="storage type of --weights-out (float16 halves it again; loaded back as float32)")
    return p


def supported_steps(text: str) -> list[int]:
    """``--supported-steps``' step counts, sorted; ValueError unless they are positive integers."""
    try:
        steps = sorted({int(s) for s in str(text).split(",") if s.strip()})
    except ValueError:
        steps = []
    if not steps or min(steps) < 1:
        raise ValueError(f"--supported-steps: expected positive integers, got {text!r}")
    return steps


def check_args(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """``parser.error`` (exit 2) for options that cannot run together; asked before anything is read or written."""
    if args.weights_minutes is not None and (args.weights_out is None or not args.weights_minutes >= 0):
        parser.error("--weights-minutes needs --weights-out and a number of minutes ≥ 0")
    if args.geo_weight_t1 is not None and not (args.geo_weight_t1 > 0 and args.geo_weight > 0
                                               and args.objective == "ddgan"):
        parser.error(f"--geo-weight-t1 {args.geo_weight_t1:g}: needs a number > 0, --geo-weight > 0 and the ddgan "
                     "objective (it sets how L_geo's weight changes with t)")
    if args.d_width is None:   # the released D (1024) beside a tiny G made a 1.3 GB checkpoint for a smoke test
        args.d_width = 64 if args.preset == "tiny" else 1024
    if args.d_width < 1:
        parser.error(f"--d-width {args.d_width}: needs a width ≥ 1")
    try:
        supported_steps(args.supported_steps)
    except ValueError as e:
        parser.error(str(e))
