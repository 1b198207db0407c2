"""The two files ``emdm.train`` writes, and reading them back safely.

    <out>/ckpt.pt       the training state: G, G_ema, D, optimisers, RNG states, data order, meta (exact resume)
    --weights-out FILE  the shipped-weights format: the EMA generator alone (+ meta, step, wall, last losses),
                        read by ``emdm.export.load_generator``, ``emdm.sample --ckpt`` and ``--init-weights``

Both are written atomically (a temporary file, then a rename: an interrupted save never leaves half a file) and
hold tensors and plain values only, so every read uses ``torch.load(..., weights_only=True)``: a file from
someone else cannot run code. A file that is missing, corrupt, holds other objects, lacks a key or belongs to
another model raises :class:`CheckpointError`, whose message is one line naming the file and the problem.

Both carry a checksum of what they hold (``CHECKSUM_KEY``: sha256 over every tensor's dtype, shape and bytes and every
plain value, ``content_sha256``), checked on every read: a flipped byte that torch.load would take is refused, naming
the file. A file without one (written before it existed) is still read; where the file's folder has a manifest.json
listing it (the shipped ``public/models/*.weights.f16.pt``), its sha256 there is checked instead.
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

import numpy as np
import torch

from emdm import manifest as mf
from emdm.paths import display_path

WEIGHTS_KEYS = ("step", "wall", "meta", "last_losses", "G_ema")
TRAIN_KEYS = ("step", "wall", "meta", "G", "G_ema", "opt_g", "D", "opt_d", "batcher", "rng")


CHECKSUM_KEY = "content_sha256"


class CheckpointError(ValueError):
    """A checkpoint file cannot be used; the message names the file and what is wrong (one line)."""


def _digest(obj, h) -> None:
    if isinstance(obj, torch.Tensor):
        t = obj.detach().to("cpu").contiguous().reshape(-1)
        h.update(f"T{t.dtype}{tuple(obj.shape)}:".encode())
        h.update(t.view(torch.uint8).numpy() if t.numel() else b"")     # the buffer itself, no copy
    elif isinstance(obj, dict):
        h.update(b"{%d" % len(obj))
        for k, v in obj.items():
            _digest(k, h)
            _digest(v, h)
    elif isinstance(obj, (list, tuple)):
        h.update(b"[%d" % len(obj))
        for v in obj:
            _digest(v, h)
    else:                                        # plain values; a numpy scalar as its Python value (same repr on numpy 1, 2)
        v = obj.item() if isinstance(obj, np.generic) else obj
        h.update(f"{type(v).__name__}:{v!r};".encode())


def content_sha256(state: dict) -> str:
    """sha256 of a checkpoint's contents without ``CHECKSUM_KEY``: each tensor's dtype, shape and bytes, each plain
    value, in order. The same before saving and after loading (on any device)."""
    h = hashlib.sha256()
    _digest({k: v for k, v in state.items() if k != CHECKSUM_KEY}, h)
    return h.hexdigest()


def atomic_save(obj, path: Path | str) -> None:
    """Write ``obj`` (a dict) with its checksum (``CHECKSUM_KEY``) to a temporary file, then rename it to ``path``."""
    path = Path(path)
    tmp = path.with_name(path.name + ".tmp")
    if isinstance(obj, dict):
        obj = {**obj, CHECKSUM_KEY: content_sha256(obj)}
    torch.save(obj, tmp)
    os.replace(tmp, path)


def check_integrity(path: Path, st: dict, what: str) -> None:
    """CheckpointError unless ``st`` matches its stored checksum; a file without one is checked against the sha256 of a
    manifest.json beside it that lists it (the shipped weights), else read as it is (written before checksums)."""
    if CHECKSUM_KEY in st:
        if st[CHECKSUM_KEY] != content_sha256(st):
            raise CheckpointError(f"{path}: checksum mismatch: its contents differ from what was saved (a corrupt "
                                  f"{what}); restore it or use an earlier one")
        return
    man = path.parent / mf.MANIFEST_NAME
    if not man.is_file():
        return
    try:
        listed = mf.load(path.parent)["files"].get(path.name)
    except mf.ManifestError:
        return                                   # not a manifest this file can be checked against
    if listed is not None and mf.sha256_file(path) != listed["sha256"]:
        raise CheckpointError(f"{path}: sha256 differs from {man} (a changed or corrupt file); restore it")


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
    check_integrity(path, st, what)
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


def dataset_identity(root: Path, split: str) -> dict:
    """What identifies a dataset for a resume: its path (relative to the repository when inside it: the meta goes into
    shipped weights) and a sha256 over the files that define it (info.json where there is one, the split's list of
    clips, Mean.npy and Std.npy)."""
    h = hashlib.sha256()
    for name in ("info.json", f"{split}.txt", "Mean.npy", "Std.npy"):
        p = Path(root) / name
        h.update(name.encode() + (b":" + p.read_bytes() if p.is_file() else b"-") + b";")
    return {"path": display_path(root), "split": split, "sha256": h.hexdigest()}


def first_non_finite(module: torch.nn.Module | None) -> str | None:
    """The name of the first parameter or buffer of ``module`` holding NaN/Infinity, or None."""
    for k, v in (module.state_dict().items() if module is not None else ()):
        if v.is_floating_point() and not bool(torch.isfinite(v).all()):
            return k
    return None


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


def _read_weights_file(path: Path | str) -> dict:
    """A --weights-out file (or a ckpt.pt) as stored: its weights in the dtype they were saved in."""
    st = load_file(path, WEIGHTS_KEYS[:3] + ("G_ema",), what="--weights-out file or emdm.train checkpoint")
    if not isinstance(st["G_ema"], dict):
        raise CheckpointError(f"{path}: 'G_ema' is not a state dict")
    return st


def load_weights_file(path: Path | str) -> dict:
    """A --weights-out file (or a ckpt.pt, which holds the same keys and more), weights as float32."""
    st = _read_weights_file(path)
    st["G_ema"] = {k: v.float() for k, v in st["G_ema"].items()}
    return st


# the options of emdm.train whose values are paths on the machine that ran it (tests/python/test_checkpoints_portable.py
# checks this is all of them)
PATH_ARGS = ("data", "out", "init_weights", "weights_out")


def portable_meta(meta: dict) -> dict:
    """``meta`` for a file that leaves the machine it was made on (a shipped weights file): the run's path-valued
    options (``args``, PATH_ARGS) and its dataset's path (``data.path``) cut to their last name, so no machine's
    folders travel. Nothing that reads a weights file (``--init-weights``, export, the evaluation) reads those paths;
    a resume compares the dataset by its sha256."""
    out = dict(meta)

    def name(v):
        return Path(v).name if isinstance(v, str) and v else v
    if isinstance(meta.get("args"), dict):
        out["args"] = {k: (name(v) if k in PATH_ARGS else v) for k, v in meta["args"].items()}
    if isinstance(meta.get("data"), dict):
        out["data"] = {**meta["data"], "path": name(meta["data"].get("path"))}
    return out


def portable_weights_file(src: Path | str, dst: Path | str) -> Path:
    """A --weights-out file with ``portable_meta``; weights, their dtype, step, wall and losses as they were."""
    st = _read_weights_file(src)
    dtypes = {v.dtype for v in st["G_ema"].values()}
    if len(dtypes) != 1:
        raise CheckpointError(f"{src}: its weights mix dtypes {sorted(map(str, dtypes))}")
    dst = Path(dst)
    save_weights_file(dst, st["G_ema"], step=st["step"], wall=st["wall"], meta=portable_meta(st["meta"]),
                      last_losses=st.get("last_losses", {}), dtype=str(dtypes.pop()).removeprefix("torch."))
    return dst


def half_weights_file(src: Path | str, dst: Path | str) -> Path:
    """A --weights-out file (or ckpt.pt) as a float16 --weights-out file: the next call of a GPU lease continues
    from what the last one returned, at half the size it travels (scripts/gpu/lease.sh init). Read with every
    check, written atomically with a fresh checksum; meta, step, wall and losses are kept."""
    st = load_weights_file(src)
    dst = Path(dst)
    save_weights_file(dst, st["G_ema"], step=st["step"], wall=st["wall"], meta=st["meta"],
                      last_losses=st.get("last_losses", {}), dtype="float16")
    return dst


def main(argv: list[str] | None = None) -> int:
    """``python -m emdm.checkpoints half SRC DST`` (half_weights_file) or ``portable SRC DST`` (portable_weights_file;
    SRC may be DST)."""
    import argparse
    ap = argparse.ArgumentParser(prog="python -m emdm.checkpoints", description=main.__doc__)
    ap.add_argument("command", choices=["half", "portable"])
    ap.add_argument("src")
    ap.add_argument("dst")
    a = ap.parse_args(argv)
    try:
        out = (half_weights_file if a.command == "half" else portable_weights_file)(a.src, a.dst)
    except CheckpointError as e:
        print(f"emdm.checkpoints: {e}", file=sys.stderr)
        return 2
    dtype = load_weights_file(out)["meta"]["weights_dtype"]
    print(f"emdm.checkpoints: {display_path(out)} ({out.stat().st_size / 2**20:.1f} MiB, {dtype})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
