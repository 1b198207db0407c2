"""Open a model for sampling: the one place that turns a shipped model or a checkpoint into what the sampling
loop (``emdm.sampler.sample_features``) needs, for ``emdm.sample``, ``emdm.export`` and the evaluation
(``emdm.eval.sources`` and through it ``evaluate``, ``coverage``, ``suite``).

    from emdm.model.open import open_model
    m = open_model("emdm-t2m-web", variant="int8")            # a name: public/models/manifest.json
    m = open_model(Path("runs/t2m/ckpt.pt"), device="cuda")   # a Path: emdm.train checkpoint or --weights-out file
    x0 = m.step(x_t, z, cond, t, mask)                         # numpy in, numpy out
    feats = x * m.std + m.mean

* A **shipped model** is a name in ``<models_dir>/manifest.json``. Its ONNX step file (``onnx``, or
  ``variants[variant]`` such as int8/fp16) runs through onnxruntime on the CPU, its ``meanStd`` file (float32
  mean[263] then std[263]) de-normalises. Both files are checked against the size and sha256 the manifest lists
  under ``files``, as the page checks what it downloads: a missing, changed or unlisted file is refused.
* A **checkpoint** (``ckpt.pt`` or a ``--weights-out`` file) is read by ``emdm.checkpoints`` with
  ``torch.load(weights_only=True)`` (a file from someone else cannot run code); its EMA generator (``weights="G"``:
  the raw one) runs through PyTorch on ``device``, mean/std come from its meta.

``OpenedModel.meta`` is a manifest-like entry (task, objective, condition, zDim, maxFrames, guidance, defaultSteps;
supportedSteps where the manifest lists them), ``.info`` where the model came from (for result files). Anything
wrong is a :class:`ModelError` whose message is one line naming the file and what is wrong; the CLIs print it and
exit with status 2.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm.paths import display_path
from emdm.sampler.settings import SamplingSettings, check_steps

StepFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]

INPUTS = ["x_t", "z", "cond", "t", "mask"]     # the ONNX step model's inputs; its output is "x0"
FEATURES = 263
DEFAULT_GUIDANCE = 2.5                         # a checkpoint's (the manifest gives a shipped model's)
DEFAULT_STEPS = 10


class ModelError(ValueError):
    """A model cannot be opened; the message is one line naming the file (or manifest) and what is wrong."""


def _first_line(e: BaseException) -> str:
    return ((str(e).strip().splitlines() or [""])[0] or type(e).__name__)[:240]


# ----------------------------------------------------------------------------- the pieces

def ort_session(path: Path | str, threads: int = 1):
    """An onnxruntime CPU session (``threads`` intra-op threads, one inter-op)."""
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = threads
    so.inter_op_num_threads = 1
    so.log_severity_level = 3
    return ort.InferenceSession(str(path), so, providers=["CPUExecutionProvider"])


def onnx_step(path: Path | str, threads: int = 1) -> StepFn:
    """The step function of an exported step model; a file onnxruntime cannot load, or one that is not an
    EMDM step model (inputs x_t, z, cond, t, mask; output x0), is a ModelError."""
    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: ONNX step model not found")
    try:
        sess = ort_session(path, threads)
    except Exception as e:  # noqa: BLE001 - onnxruntime's own exception types; re-raised as one line
        raise ModelError(f"{path}: cannot load as an ONNX model (corrupt or not ONNX): {_first_line(e)}") from None
    have = [i.name for i in sess.get_inputs()]
    outs = [o.name for o in sess.get_outputs()]
    if sorted(have) != sorted(INPUTS) or "x0" not in outs:
        raise ModelError(f"{path}: not an EMDM step model (inputs {have}, outputs {outs}; expected inputs {INPUTS} "
                         "and output x0)")

    def step(x, z, c, t, mask):
        return sess.run(["x0"], {"x_t": x, "z": z, "cond": c, "t": t, "mask": mask})[0]
    return step


def torch_step(G, device: str = "cpu") -> StepFn:
    """A step function over a PyTorch generator; ``device`` "cuda" moves G there (numpy in, numpy out)."""
    import torch

    dev = torch.device(device)
    G = G.to(dev)

    def step(x, z, c, t, mask):
        with torch.no_grad():
            args = (torch.from_numpy(np.ascontiguousarray(a)).to(dev) for a in (x, z, c, t, mask))
            return G(*args).cpu().numpy()
    return step


def read_meanstd(path: Path | str) -> tuple[np.ndarray, np.ndarray]:
    """(mean, std) from a meanStd file: float32 little-endian, mean[263] then std[263]."""
    path = Path(path)
    try:
        arr = np.fromfile(path, dtype="<f4")
    except OSError as e:
        raise ModelError(f"{path}: cannot read the mean/std file ({e.strerror})") from None
    if arr.shape != (2 * FEATURES,):
        raise ModelError(f"{path}: expected {2 * FEATURES} float32 values (mean[{FEATURES}], std[{FEATURES}]), "
                         f"got {arr.shape[0]}")
    return arr[:FEATURES], arr[FEATURES:]


def load_generator(path: Path | str, weights: str = "G_ema"):
    """(generator in eval mode with the chosen weights, the checkpoint's meta, summary {steps, wall_s, losses})
    from an emdm.train checkpoint or --weights-out file, read with weights_only=True."""
    # lazy: torch; opening a shipped ONNX model needs numpy and onnxruntime only
    from emdm.checkpoints import CheckpointError, load_file, load_state_dict
    from emdm.model.generator import Generator

    path = Path(path)
    if not path.is_file():
        raise ModelError(f"{path}: checkpoint not found")
    try:                                     # tensors and plain values only: a checkpoint cannot run code
        st = load_file(path, need=())
    except CheckpointError as e:
        raise ModelError(str(e)) from None
    for key in ("meta", weights, "step"):
        if key not in st:
            raise ModelError(f"{path}: not an emdm.train checkpoint (missing {key!r})")
    meta = st["meta"]
    gcfg = meta.get("generator") if isinstance(meta, dict) else None
    need = ("cond_dim", "preset", "feature_dim", "z_dim", "max_frames")
    if not isinstance(gcfg, dict) or any(k not in gcfg for k in need):
        raise ModelError(f"{path}: not an emdm.train checkpoint (meta lacks the generator config {need})")
    if not isinstance(st[weights], dict):
        raise ModelError(f"{path}: {weights!r} is not a state dict")
    try:
        G = Generator(gcfg["cond_dim"], gcfg["preset"], gcfg["feature_dim"], gcfg["z_dim"], gcfg["max_frames"])
        load_state_dict(path, G, {k: v.float() for k, v in st[weights].items()}, weights)   # float16 files too
    except CheckpointError as e:
        raise ModelError(str(e)) from None
    except (TypeError, ValueError, KeyError, AttributeError) as e:
        raise ModelError(f"{path}: the generator config in its meta is not usable: {_first_line(e)}") from None
    G.eval()
    summary = {"steps": int(st["step"]), "wall_s": float(st.get("wall", 0.0)), "losses": st.get("last_losses", {})}
    return G, meta, summary


def variant_file(entry: dict, name: str, variant: str | None) -> str:
    """The ONNX file of ``variant`` (None/"fp32": the model's ``onnx``); an unknown one is a ModelError."""
    if variant in (None, "fp32"):
        return entry["onnx"]
    variants = entry.get("variants") or {}
    if variant not in variants:
        raise ModelError(f"--variant: model {name!r} has no variant {variant!r}; use one of "
                         f"{', '.join(['fp32', *variants])}")
    return variants[variant]


def verified_file(manifest: dict, models_dir: Path, rel: str, what: str, field: str = "files") -> Path:
    """``manifest.verified_file`` (inside ``models_dir``, listed, its size and sha256) as a ModelError."""
    try:
        return mf.verified_file(manifest, models_dir, rel, what, field)
    except mf.ManifestError as e:
        raise ModelError(str(e)) from None


# ----------------------------------------------------------------------------- the opened model

@dataclass
class OpenedModel:
    """A model ready to sample: ``step(x_t, z, cond, t, mask) -> x0``, mean/std, and what it is."""
    step: StepFn
    mean: np.ndarray
    std: np.ndarray
    meta: dict                 # manifest-like entry: task, objective, condition, zDim, maxFrames, guidance, ...
    info: dict                 # origin for result files: model/onnx or checkpoint, runtime, training steps, ...
    path: Path                 # the ONNX step file or the checkpoint
    name: str                  # the manifest name, or the checkpoint's path as given
    kind: str                  # "shipped" or "checkpoint"
    variant: str = "fp32"
    flags: dict = field(default_factory=dict)     # the training flags (train.py arguments)
    generator: Any = None      # checkpoint: the PyTorch generator (eval mode)
    checkpoint_meta: dict | None = None           # checkpoint: its meta as emdm.train wrote it
    summary: dict | None = None                   # checkpoint: {steps, wall_s, losses}
    models_dir: Path | None = None                # shipped: the models folder it came from (its text encoder too)

    @property
    def task(self) -> str:
        return self.meta["task"]

    @property
    def objective(self) -> str:
        return self.meta.get("objective", "ddgan")

    @property
    def condition(self) -> dict:
        return self.meta["condition"]

    @property
    def z_dim(self) -> int:
        return int(self.meta.get("zDim", 64))

    @property
    def max_frames(self) -> int:
        return int(self.meta.get("maxFrames", 196))

    @property
    def supported_steps(self) -> list[int] | None:
        """The step counts it was trained for (the manifest's supportedSteps; a checkpoint's meta)."""
        steps = self.meta.get("supportedSteps")
        if steps is None and self.checkpoint_meta is not None:
            steps = self.checkpoint_meta.get("supported_steps")
        return list(steps) if steps else None

    def settings(self, steps: int | None = None, guidance: float | None = None):
        """Its sampling settings as the page's (``SamplingSettings.from_entry`` of its entry with its mean/std, which
        its speed cap needs); ``steps`` (checked against ``supported_steps``) and ``guidance`` given override them."""
        checked = check_steps(steps, {**self.meta, "supportedSteps": self.supported_steps}, self.name, "steps")
        return SamplingSettings.from_entry(self.meta, checked, guidance, self.mean, self.std)


def is_checkpoint(ref: str | Path) -> bool:
    """Whether a model reference given as text (``--model`` of timing/suite) names a checkpoint file (.pt)
    rather than a manifest model."""
    return isinstance(ref, Path) or str(ref).endswith(".pt")


def has_separator(ref: str) -> bool:
    """Whether a model reference given as text holds a path separator: a file path, never a manifest name."""
    return "/" in ref or os.sep in ref or (os.altsep is not None and os.altsep in ref)


def not_a_checkpoint(ref: str) -> str:
    """Why ``ref``, a reference that reads as a file path, is not a checkpoint this can open (one line naming it)."""
    p = Path(ref)
    if p.is_dir():
        hint = f"; did you mean {p / 'ckpt.pt'}?" if (p / "ckpt.pt").is_file() else ""
        return f"{ref}: is a folder, not a checkpoint file{hint}"
    what = "emdm.train's ckpt.pt or a --weights-out file"
    if p.exists():
        return f"{ref}: not a .pt file (a checkpoint is {what})"
    near = p.with_suffix(".pt") if p.suffix else None
    hint = f"; did you mean {near}?" if near is not None and near.is_file() else ""
    return f"{ref}: no such checkpoint file (a checkpoint is an existing .pt file: {what}){hint}"


def open_checkpoint(path: Path | str, *, device: str = "cpu", weights: str = "G_ema") -> OpenedModel:
    path = Path(path)
    G, meta, summary = load_generator(path, weights)
    missing = [k for k in ("task", "condition", "mean", "std") if k not in meta]
    if missing:
        raise ModelError(f"{path}: not an emdm.train checkpoint (meta lacks {', '.join(map(repr, missing))})")
    mean, std = np.asarray(meta["mean"], np.float32), np.asarray(meta["std"], np.float32)
    if mean.shape != (G.feature_dim,) or std.shape != (G.feature_dim,):
        raise ModelError(f"{path}: meta mean/std have shapes {mean.shape}, {std.shape}; expected ({G.feature_dim},)")
    entry = {"task": meta["task"], "condition": meta["condition"], "objective": meta.get("objective", "ddgan"),
             "zDim": G.z_dim, "guidance": DEFAULT_GUIDANCE, "defaultSteps": DEFAULT_STEPS, "maxFrames": G.max_frames}
    info = {"checkpoint": display_path(path), "runtime": "pytorch" + ("-cuda" if device.startswith("cuda") else ""),
            "train_steps": summary["steps"] + int((meta.get("init") or {}).get("steps", 0)),
            "train_wall_min": round(summary["wall_s"] / 60, 1), "device": meta.get("device"),
            "preset": meta["generator"]["preset"], "dataset": meta.get("dataset")}
    return OpenedModel(step=torch_step(G, device), mean=mean, std=std, meta=entry, info=info, path=path,
                       name=str(path), kind="checkpoint", flags=dict(meta.get("args", {})), generator=G,
                       checkpoint_meta=meta, summary=summary)


def open_shipped(name: str, *, models_dir: Path | str | None = None, variant: str | None = None,
                 threads: int = 1) -> OpenedModel:
    try:
        models_dir = paths.require_models_dir(models_dir)
        man = mf.load(models_dir)
    except (paths.ModelsDirError, mf.ManifestError) as e:
        raise ModelError(str(e)) from None
    where = models_dir / mf.MANIFEST_NAME
    if name not in man["models"]:
        have = f"(have: {', '.join(man['models']) or 'none'})"
        if has_separator(name) or Path(name).exists() or Path(name).suffix:     # a file path: a checkpoint's typo?
            raise ModelError(f"{not_a_checkpoint(name)}, nor a model of {where} {have}")
        raise ModelError(f"{where}: no model {name!r} {have}")
    try:                                      # every field sampling reads: its type and a bounded size
        entry = mf.check_model_entry(man["models"][name], name, where)
    except mf.ManifestError as e:
        raise ModelError(str(e)) from None
    onnx_file = variant_file(entry, name, variant)
    label = "its ONNX step file" if variant in (None, "fp32") else f"its {variant} ONNX step file"
    ms_path = verified_file(man, models_dir, entry["meanStd"], f"model {name!r} names it as its meanStd",
                            f"models.{name}.meanStd")
    onnx_path = verified_file(man, models_dir, onnx_file, f"model {name!r} names it as {label}",
                              f"models.{name}." + ("onnx" if variant in (None, "fp32") else f"variants.{variant}"))
    mean, std = read_meanstd(ms_path)
    step = onnx_step(onnx_path, threads)
    tr = entry.get("training", {})
    info = {"model": name, "onnx": onnx_file, "runtime": "onnxruntime",
            "train_steps": (tr.get("steps") or 0) + int(tr.get("continuedFrom", {}).get("steps", 0)) or None,
            "train_wall_min": round(tr.get("wallSeconds", 0) / 60, 1), "device": tr.get("device"),
            "preset": entry.get("preset"), "dataset": tr.get("dataset")}
    return OpenedModel(step=step, mean=mean, std=std, meta=entry, info=info, path=onnx_path, name=name,
                       kind="shipped", variant=variant or "fp32", flags=dict(tr.get("flags", {})), models_dir=models_dir)


def quantises_per_call(onnx: Path | str) -> bool:
    """Whether an ONNX file quantises activations at run time (a DynamicQuantizeLinear node: the int8 variants). Its
    rows then round by a scale shared with the whole batch, so a request's result depends on what it is batched with
    (the TypeScript ``quantisesPerCall``)."""
    return b"DynamicQuantizeLinear" in Path(onnx).read_bytes()


def open_model(name_or_path: str | Path, *, models_dir: Path | str | None = None, variant: str | None = None,
               device: str = "cpu", threads: int = 1, weights: str = "G_ema") -> OpenedModel:
    """A model ready to sample. A ``Path`` is a checkpoint (PyTorch on ``device``); a ``str`` is a model of
    ``models_dir``/manifest.json (default public/models), the ONNX file of ``variant`` through onnxruntime
    (``threads``) on the CPU; a ``str`` naming an existing .pt file is opened as a checkpoint, one that reads as another
    path (a separator; or, not in the manifest, a suffix or an existing file) is refused as not a checkpoint file.
    Raises ModelError (one line) for anything that cannot be used."""
    if isinstance(name_or_path, str) and Path(name_or_path).suffix == ".pt" and Path(name_or_path).is_file():
        name_or_path = Path(name_or_path)              # a checkpoint given as text
    if isinstance(name_or_path, Path):
        if variant not in (None, "fp32"):
            raise ModelError(f"--variant {variant!r} needs a shipped model (--model); the checkpoint {name_or_path} "
                             "has only its fp32 weights")
        return open_checkpoint(name_or_path, device=device, weights=weights)
    if has_separator(name_or_path):
        raise ModelError(not_a_checkpoint(name_or_path))
    if device != "cpu":
        raise ModelError(f"model {name_or_path!r} runs through onnxruntime on the CPU; --device {device} needs a "
                         "checkpoint (--ckpt)")
    return open_shipped(name_or_path, models_dir=models_dir, variant=variant, threads=threads)
