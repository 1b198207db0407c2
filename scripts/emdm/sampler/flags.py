"""The sampling-settings flags every command spells alike (``emdm.sample`` and the per-action benchmarks):
``--guidance-min-time`` and ``--x0-smoothing``, each defaulting to the model's manifest entry, and how they
override the entry's ``SamplingSettings`` (``--guidance``, whose type differs between commands, each adds itself)."""
from __future__ import annotations

import argparse
import dataclasses

from emdm.sampler.settings import SamplingSettings


def add_guidance_min_time(ap: argparse.ArgumentParser) -> None:
    """--guidance-min-time alone (default None: the model's manifest entry), for a command of single steps, which
    has no x̂0 smoothing between steps."""
    ap.add_argument("--guidance-min-time", type=float, default=None, metavar="T",
                    help="guide only steps whose time is above T, one batch row below (guidance in a limited "
                         "interval; default: the manifest's guidanceMinTime, else 0 = every step)")


def add_sampling_settings(ap: argparse.ArgumentParser) -> None:
    """--guidance-min-time and --x0-smoothing (default None: the model's manifest entry)."""
    add_guidance_min_time(ap)
    ap.add_argument("--x0-smoothing", type=float, default=None, metavar="SIGMA",
                    help="smooth x̂0 along time (Gaussian, σ frames) at every step but the last (default: the "
                         "manifest's x0Smoothing, else 0 = off)")


def with_flags(s: SamplingSettings, a: argparse.Namespace) -> SamplingSettings:
    """``s`` with the --guidance-min-time and --x0-smoothing given (None keeps the entry's)."""
    if a.guidance_min_time is not None:
        s = dataclasses.replace(s, guidance_min_time=a.guidance_min_time)
    return s if a.x0_smoothing is None else dataclasses.replace(s, x0_smoothing=a.x0_smoothing)
