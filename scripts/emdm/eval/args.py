"""The command-line options the per-action benchmarks share (coverage, realism, the pose grid): which model to
sample (the sampling-settings flags: emdm.sampler.flags, shared with emdm.sample). One definition, so every benchmark
spells and defaults them alike."""
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
