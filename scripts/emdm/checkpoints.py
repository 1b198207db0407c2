"""The two files ``emdm.train`` writes, and reading them back safely.

    <out>/ckpt.pt       the training state: G, G_ema, D, optimisers, RNG states, data order, meta (exact resume)
    --weights-out FILE  the shipped-weights format: the EMA generator alone (+ meta, step, wall, last losses),
                        read by ``emdm.export.load_generator``, ``emdm.sample --ckpt`` and ``--init-weights``

Both are written atomically (a temporary file, then a rename: an interrupted save never leaves half a file) and
hold tensors and plain values only, so every read uses ``torch.load(..., weights_only=True)``: a file from
someone else cannot run code. A file that is missing, corrupt, holds other objects, lacks a key or belongs to
another model raises :class:`CheckpointError`, whose message is one line naming the file and the problem.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

WEIGHTS_KEYS = ("step", "wall", "meta", "last_losses", "G_ema")
TRAIN_KEYS = ("step", "wall", "meta", "G", "G_ema", "opt_g", "D", "opt_d", "batcher", "rng")


class CheckpointError(ValueError):
    """A checkpoint file cannot be used; the message names the file and what is wrong (one line)."""


def atomic_save(obj, path: Path | str) -> None:
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def _numpy_scalar_globals() -> list:
    """numpy scalars (np.float64 in a meta dict) are plain values too: allow exactly their constructors."""
    import numpy as np

    core = getattr(np, "_core", None) or np.core
    return [core.multiarray.scalar, np.dtype] + [type(np.dtype(t)) for t in
                                                 (np.float16, np.float32, np.float64, np.int32, np.int64, np.bool_)]


def torch_load(path: Path | str, map_location="cpu"):
    """``torch.load(path, weights_only=True)``: tensors, containers, plain and numpy scalar values only."""
    with torch.serialization.safe_globals(_numpy_scalar_globals()):
        return torch.load(path, map_location=map_location, weights_only=True)


def load_file(path: Path | str, need: tuple[str, ...] = ("meta",), what: str = "checkpoint written by emdm.train",
              map_location="cpu") -> dict:
    """``torch.load(path, weights_only=True)`` → dict holding every key in ``need``, or CheckpointError."""
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path}: {what} not found")
    try:
        st = torch_load(path, map_location)
    except Exception as e:  # noqa: BLE001 - re-raised as one line naming the file
        msg = str(e)
        cause = msg.split("WeightsUnpickler error:", 1)[1] if "WeightsUnpickler error:" in msg else msg
        cause = " ".join(cause.split("Check the documentation")[0].split())
        cause = cause.split(". Please use")[0] or type(e).__name__
        if "Unsupported global" in cause:
            raise CheckpointError(f"{path}: holds objects other than tensors and plain values, refused "
                                  f"(torch.load weights_only=True): {cause[:200]}") from e
        raise CheckpointError(f"{path}: cannot read as a {what} (corrupt or not a torch file): "
                              f"{type(e).__name__}: {cause[:200]}") from e
    if not isinstance(st, dict):
        raise CheckpointError(f"{path}: not a {what} (holds a {type(st).__name__}, expected a dict)")
    missing = [k for k in need if k not in st]
    if missing:
        raise CheckpointError(f"{path}: not a {what} (missing {', '.join(map(repr, missing))})")
    if "meta" in need and not isinstance(st["meta"], dict):
        raise CheckpointError(f"{path}: not a {what} ('meta' is a {type(st['meta']).__name__}, expected a dict)")
    return st


def check_same_model(path: Path | str, meta: dict, generator: dict, task: str, objective: str, hint: str) -> None:
    """CheckpointError unless ``meta`` describes the same generator config, task and objective."""
    diff = [f"{name} {meta.get(name)!r}, this run {want!r}"
            for name, want in (("task", task), ("objective", objective), ("generator", generator))
            if meta.get(name) != want]
    if diff:
        raise CheckpointError(f"{path}: trained with another model/task/objective ({'; '.join(diff)}); {hint}")


def load_state_dict(path: Path | str, module: torch.nn.Module, state: dict, key: str) -> None:
    """``module.load_state_dict(state)``, with a mismatch reported as CheckpointError naming file and key."""
    try:
        module.load_state_dict(state)
    except (RuntimeError, TypeError, AttributeError) as e:
        first = (str(e).strip().splitlines() or [type(e).__name__])[0]
        raise CheckpointError(f"{path}: {key!r} does not fit this model: {first[:200]}") from e


def save_weights_file(path: Path, state: dict, *, step: int, wall: float, meta: dict, last_losses: dict,
                      dtype: str = "float32") -> None:
    """The --weights-out format: a generator's state dict (on the CPU, as ``dtype``) with its meta and
    progress, read by ``emdm.export.load_generator`` and ``--init-weights`` (tensors and plain values only)."""
    dt = getattr(torch, dtype)
    weights = {k: v.detach().to("cpu", dt) for k, v in state.items()}
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_save({"step": int(step), "wall": float(wall), "meta": {**meta, "weights_dtype": dtype},
                 "last_losses": last_losses, "G_ema": weights}, path)


def load_weights_file(path: Path | str) -> dict:
    """A --weights-out file (or a ckpt.pt, which holds the same keys and more), weights as float32."""
    st = load_file(path, WEIGHTS_KEYS[:3] + ("G_ema",), what="--weights-out file or emdm.train checkpoint")
    if not isinstance(st["G_ema"], dict):
        raise CheckpointError(f"{path}: 'G_ema' is not a state dict")
    st["G_ema"] = {k: v.float() for k, v in st["G_ema"].items()}
    return st
