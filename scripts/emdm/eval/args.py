"""The command-line options the per-action benchmarks share (coverage, realism, the pose grid): which model to
sample, with which sampling settings. One definition, so every benchmark spells and defaults them alike."""
from __future__ import annotations

import argparse
from pathlib import Path

VARIANT_HELP = "with --model: fp32 (default) or a manifest variant, e.g. int8 (the page's)"


def add_model_source(ap: argparse.ArgumentParser, required: bool = True, model_help: str | None = None) -> None:
    """--model | --ckpt (one of them; ``required``), --models-dir, --variant."""
    src = ap.add_mutually_exclusive_group(required=required)
    src.add_argument("--model", default=None,
                     help=model_help or "a shipped model of public/models/manifest.json (ONNX Runtime)")
    src.add_argument("--ckpt", type=Path, help="an emdm.train checkpoint (PyTorch, EMA weights)")
    ap.add_argument("--models-dir", type=Path, default=None)
    ap.add_argument("--variant", default=None, help=VARIANT_HELP)


def add_sampling_settings(ap: argparse.ArgumentParser) -> None:
    """--guidance-min-time and --x0-smoothing, each defaulting to the model's manifest entry (``--guidance``, whose
    type differs between benchmarks, each adds itself)."""
    ap.add_argument("--guidance-min-time", type=float, default=None, metavar="T",
                    help="guide only steps whose time is above T (default: the manifest's guidanceMinTime, else 0 = "
                         "every step)")
    ap.add_argument("--x0-smoothing", type=float, default=None, metavar="SIGMA",
                    help="smooth x̂0 along time (σ frames) at every step but the last (default: the manifest's "
                         "x0Smoothing, else 0 = off)")
