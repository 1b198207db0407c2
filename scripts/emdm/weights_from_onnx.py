"""A shipped model's training weights read back from its exported ONNX file, for a model whose training weights
were never kept (the DDIM baseline, ``diffusion-t2m-web``): without them ``train --init-weights`` (a GPU slice,
scripts/gpu/lease-train.sh) has nothing to continue from.

    python -m emdm.weights_from_onnx diffusion-t2m-web [--models-dir public/models]

writes ``<model>.weights.f16.pt`` beside it (the ``--weights-out`` format, float16, as ``export --ship-weights``)
and names it the entry's ``trainingWeights`` in manifest.json. The fp32 ONNX file holds every weight of the
generator: the exporter keeps most under their parameter names and stores the Linear weights it feeds to MatMul
transposed, under names of its own (``val_31``); those are matched to the unfilled parameters by shape, in the order
the graph first uses them, which is the order the generator's forward pass uses its layers. Nothing is trusted to
that matching: the rebuilt generator must give the ONNX file's outputs (``emdm.export.parity``, within
``--tolerance``) or nothing is written. The meta is the manifest entry's (task, objective, condition, preset,
supported steps, training history and flags), the mean/std its meanStd file's, and ``recovered_from`` names the ONNX
file and its sha256.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import onnx
import torch
from onnx import numpy_helper

from emdm import manifest as mf
from emdm import paths
from emdm.checkpoints import portable_meta, save_weights_file
from emdm.export import parity
from emdm.model.generator import Generator, Preset
from emdm.model.open import ModelError, read_meanstd, verified_file
from emdm.paths import display_path

TOLERANCE = 1e-4


class RecoverError(RuntimeError):
    """One line naming the model or file and what is wrong."""


def _first_use(graph: onnx.GraphProto) -> dict[str, int]:
    """Initializer name -> index of the first node that reads it."""
    order: dict[str, int] = {}
    for i, node in enumerate(graph.node):
        for name in node.input:
            order.setdefault(name, i)
    return order


def generator_from_onnx(onnx_path: Path | str, entry: dict, tolerance: float = TOLERANCE) -> tuple[Generator, float]:
    """(the generator ``entry`` describes with the weights of ``onnx_path``, its largest parity difference);
    RecoverError where a weight cannot be found or the rebuilt generator does not give the file's outputs."""
    onnx_path = Path(onnx_path)
    try:
        model = onnx.load(str(onnx_path))
    except Exception as e:  # noqa: BLE001 - onnx's own exception types; re-raised as one line
        why = str(e).splitlines()[0] if str(e) else type(e).__name__
        raise RecoverError(f"{onnx_path}: cannot read as ONNX ({why})") from None
    inits = {i.name: numpy_helper.to_array(i) for i in model.graph.initializer}
    try:
        G = Generator(int(entry["condition"]["dim"]), Preset(**entry["preset"]), int(entry["featureDim"]),
                      int(entry["zDim"]), int(entry["maxFrames"]))
    except (KeyError, TypeError, ValueError) as e:
        raise RecoverError(f"{onnx_path}: its manifest entry does not describe a generator ({e})") from None
    state = G.state_dict()
    found: dict[str, torch.Tensor] = {}
    for name, ref in state.items():
        if name in inits and tuple(inits[name].shape) == tuple(ref.shape):
            found[name] = torch.from_numpy(inits[name].copy())
    first = _first_use(model.graph)
    spare = sorted((n for n, a in inits.items() if n not in state and a.ndim == 2 and n in first), key=first.get)
    for name, ref in state.items():                # the rest: MatMul weights, stored transposed, in forward order
        if name in found:
            continue
        want = tuple(ref.shape)
        pick = next((n for n in spare if inits[n].shape[::-1] == want), None)
        if pick is None:
            raise RecoverError(f"{onnx_path}: no weight of shape {list(want[::-1])} left for {name!r}; not a file "
                               "emdm.export wrote for this generator")
        spare.remove(pick)
        found[name] = torch.from_numpy(np.ascontiguousarray(inits[pick].T))
    G.load_state_dict({k: v.float() for k, v in found.items()})
    G.eval()
    try:
        worst = max(parity(G, onnx_path).values())
    except Exception as e:  # noqa: BLE001 - onnxruntime's own exception types; re-raised as one line
        raise RecoverError(f"{onnx_path}: the rebuilt generator cannot be checked against it: {e}") from None
    if not worst <= tolerance:
        raise RecoverError(f"{onnx_path}: the weights read back give outputs {worst:.3g} from the file's (tolerance "
                           f"{tolerance}); nothing written")
    return G, worst


def recovered_meta(entry: dict, G: Generator, mean: np.ndarray, std: np.ndarray, onnx_name: str, sha: str) -> dict:
    """The --weights-out meta of a generator read back from its ONNX file: what --init-weights, export and the
    evaluation read, from the manifest entry."""
    tr = entry.get("training", {})
    return {
        "task": entry["task"], "objective": entry.get("objective", "ddgan"), "cond_dim": G.cond_dim,
        "condition": entry["condition"], "generator": G.config(), "supported_steps": list(entry["supportedSteps"]),
        "mean": [float(v) for v in mean], "std": [float(v) for v in std],
        "dataset": tr.get("dataset", "dataset"), "clips": tr.get("clips"), "device": tr.get("device"),
        "batch": tr.get("batch"), "world": 1, "init": tr.get("continuedFrom"),
        "args": dict(tr.get("flags") or {}),
        "recovered_from": {"onnx": onnx_name, "sha256": sha},
    }


def recover(name: str, models_dir: Path | str = paths.MODELS_DIR, tolerance: float = TOLERANCE) -> tuple[Path, float]:
    """Write ``<name>.weights.f16.pt`` from the model's fp32 ONNX file and name it in the manifest; (its path, the
    parity difference)."""
    models_dir = Path(models_dir)
    try:
        man = mf.load(models_dir)
    except mf.ManifestError as e:
        raise RecoverError(str(e)) from None
    entry = man["models"].get(name)
    if entry is None:
        raise RecoverError(f"{models_dir / mf.MANIFEST_NAME}: no model {name!r} (have: {', '.join(man['models'])})")
    if entry.get("trainingWeights"):
        raise RecoverError(f"model {name!r} already ships training weights ({entry['trainingWeights']}); nothing to do")
    try:       # both as the manifest lists them (size and sha256), as a model is opened
        onnx_path = verified_file(man, models_dir, entry["onnx"], f"model {name!r}'s ONNX file", "onnx")
        mean, std = read_meanstd(verified_file(man, models_dir, entry["meanStd"], f"model {name!r}'s meanStd file",
                                               "meanStd"))
    except ModelError as e:
        raise RecoverError(str(e)) from None
    sha = man["files"][entry["onnx"]]["sha256"]
    G, worst = generator_from_onnx(onnx_path, entry, tolerance)
    tr = entry.get("training", {})
    dst = models_dir / f"{name}.weights.f16.pt"
    save_weights_file(dst, G.state_dict(), step=int(tr.get("steps", 0)), wall=float(tr.get("wallSeconds", 0.0)),
                      meta=portable_meta(recovered_meta(entry, G, mean, std, onnx_path.name, sha)),
                      last_losses=dict(tr.get("losses") or {}), dtype="float16")
    entry = {**entry, "trainingWeights": dst.name, "files": sorted({*entry.get("files", []), dst.name})}
    mf.update_entry("models", name, entry, models_dir)
    return dst, worst


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.weights_from_onnx", description=__doc__.split("\n\n")[0])
    ap.add_argument("model", help="a model of the manifest without trainingWeights (e.g. diffusion-t2m-web)")
    ap.add_argument("--models-dir", type=Path, default=paths.MODELS_DIR)
    ap.add_argument("--tolerance", type=float, default=TOLERANCE, help="largest parity difference allowed")
    a = ap.parse_args(argv)
    try:
        dst, worst = recover(a.model, a.models_dir, a.tolerance)
    except RecoverError as e:
        print(f"emdm.weights_from_onnx: {e}", file=sys.stderr)
        return 2
    print(f"emdm.weights_from_onnx: {display_path(dst)} "
          f"({dst.stat().st_size / 2**20:.1f} MiB, float16), parity with the ONNX file {worst:.2e}; named in the "
          "manifest as trainingWeights")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
