"""Motion sources for the protocols: a trained model, sampled by ``emdm.sampler.sample_features`` (the
one sampling loop the project has; DDIM for ``--objective diffusion`` checkpoints).

``sample_features`` takes one condition vector and one length per call. To evaluate hundreds of
different captions/lengths without a Python loop per motion, ``batched_features`` calls it once per
batch with a step-function wrapper that substitutes each row's own condition and padding mask into
the batched call: the contract of docs/ARCHITECTURE.md says the batch is ``[c, 0]`` under guidance
and G never attends padded frames, so this is the documented loop run on a padded batch, each
motion then cropped to its length.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emdm.eval.data import TEXT_ENCODER
from emdm.eval.protocol import Conditions
from emdm.model.open import DEFAULT_GUIDANCE, OpenedModel, open_model
from emdm.sampler import SamplingSettings, sample_features
from emdm.sampler.settings import method_of, root_norm_of
from emdm import text as text_encoders      # .encode_texts looked up at each call: tests replace it


def variant_of(meta: dict) -> str:
    """The comparison a checkpoint belongs to, from its training flags."""
    args = meta.get("args", {})
    if meta.get("objective") == "diffusion":
        return "diffusion"
    geo = float(args.get("geo_weight", 100.0))
    d_cond = bool(args.get("d_cond", True))
    if d_cond:
        return "emdm" if geo > 0 else "ddgan-geo0"
    return "ddgan-nodcond" if geo > 0 else "ddgan-naive"


def batched_features(step, conds: np.ndarray, lengths: np.ndarray, settings: SamplingSettings,
                     seed: int) -> list[np.ndarray]:
    """Normalised x̂_0 for B rows with their own condition (B, C) and length (B,), via
    ``emdm.sampler.sample_features`` on one padded batch; returns B arrays (length_i, 263)."""
    conds = np.asarray(conds, np.float32)
    lengths = np.asarray(lengths, np.int64)
    b = len(lengths)
    if conds.shape[0] != b:
        raise ValueError(f"batched_features: {conds.shape[0]} conditions for {b} lengths")
    frames = int(lengths.max())
    mask = (np.arange(frames)[None, :] < lengths[:, None]).astype(np.float32)
    any_cond = bool(np.any(conds != 0))

    def row_step(x, z, c, t, m):
        rows = x.shape[0]
        if rows == 2 * b:                     # guidance: [c, 0] with the same x and z
            c = np.concatenate([conds, np.zeros_like(conds)])
            m = np.concatenate([mask, mask])
        elif rows == b:
            c, m = conds, mask
        else:
            raise RuntimeError(f"sample_features called the step with batch {rows}, expected {b} or {2 * b}")
        return step(x, z, c, t, m)

    # a non-zero stand-in makes sample_features apply guidance; the wrapper swaps in the real rows
    stand_in = np.ones(conds.shape[1], np.float32) if any_cond else np.zeros(conds.shape[1], np.float32)
    settings = settings if any_cond else dataclasses.replace(settings, guidance=1.0)
    x = sample_features(row_step, stand_in, frames, settings, seed, lengths)
    return [x[i, : lengths[i]] for i in range(b)]


@dataclass
class ModelSource:
    """A trained generator sampled with ``steps`` steps and guidance: either an ``emdm.train``
    checkpoint (``ckpt``, EMA weights through PyTorch) or a shipped model of the manifest (``model``,
    its ONNX step file through onnxruntime, ``onnx_variant`` e.g. "int8" — what the browser runs), opened by
    ``emdm.model.open`` (a bad file or name is its ModelError, one line); or ``opened``, a model already opened
    there (several step counts of one model share it)."""
    ckpt: Path | None = None
    model: str | None = None
    onnx_variant: str | None = None
    models_dir: Path | None = None           # default public/models
    steps: int = 10
    guidance: float = DEFAULT_GUIDANCE
    guidance_min_time: float | None = None   # guided only where t > this (None: the manifest's guidanceMinTime, else 0)
    x0_smoothing: float | None = None        # σ of x̂_0's smoothing along time (None: the manifest's x0Smoothing, else 0)
    speed_cap: float | None = None           # the sampler's root speed cap (None: the manifest's speedCap, else 0 = off)
    batch_size: int = 64
    threads: int = 1
    device: str = "cpu"                      # with ckpt=: "cuda" runs the generator on the GPU
    name: str = ""
    kind: str = "model"
    info: dict = field(default_factory=dict)
    opened: OpenedModel | None = None

    def __post_init__(self):
        if self.opened is None:
            if (self.ckpt is None) == (self.model is None):
                raise ValueError("ModelSource: give exactly one of ckpt=, model= or opened=")
            self.opened = open_model(Path(self.ckpt) if self.ckpt is not None else self.model,
                                     models_dir=self.models_dir, variant=self.onnx_variant, device=self.device,
                                     threads=self.threads)
        m = self.opened
        if m.kind == "checkpoint":
            self.ckpt, self.model = m.path, None
        else:
            self.ckpt, self.model = None, m.name
        self.step, self.task, self.objective, self.cond_spec = m.step, m.task, m.objective, m.condition
        self.mean, self.std, self.z_dim, self.max_frames = m.mean, m.std, m.z_dim, m.max_frames
        self.flags, self.origin = m.flags, m.info
        if self.guidance_min_time is None:
            self.guidance_min_time = float(m.meta.get("guidanceMinTime", 0.0))
        if self.x0_smoothing is None:
            self.x0_smoothing = float(m.meta.get("x0Smoothing", 0.0))
        if self.speed_cap is None:
            self.speed_cap = float(m.meta.get("speedCap", 0.0))
        variant = variant_of({"objective": self.objective, "args": self.flags})
        sampler = "DDIM" if self.objective == "diffusion" else "DDGAN"
        if not self.name:
            label = {"emdm": "EMDM", "diffusion": "Diffusion + DDIM", "ddgan-naive": "Naive DDGAN",
                     "ddgan-nodcond": "DDGAN, D w/o cond", "ddgan-geo0": "DDGAN, R = 0"}[variant]
            self.name = f"{label} ({self.steps} steps)"
        self.info = {"variant": variant, "sampler": sampler, "steps": self.steps, "guidance": self.guidance,
                     **({"guidance_min_time": self.guidance_min_time} if self.guidance_min_time else {}),
                     **({"x0_smoothing": self.x0_smoothing} if self.x0_smoothing else {}),
                     **({"speed_cap": self.speed_cap} if self.speed_cap else {}),
                     "geo_weight": self.flags.get("geo_weight"), "d_cond": self.flags.get("d_cond"),
                     **self.origin, **self.info}

    @property
    def settings(self) -> SamplingSettings:
        """How this source samples: its method, steps, guidance (and interval), x̂_0 smoothing, root speed cap (with
        the model's root velocity normalisation) and z size."""
        norm = root_norm_of(self.mean, self.std) if self.speed_cap else None
        return SamplingSettings(method_of(self.objective), self.steps, self.guidance, self.guidance_min_time,
                                self.x0_smoothing, self.speed_cap, norm, z_dim=self.z_dim)

    def conditions_of(self, cond: Conditions) -> np.ndarray:
        spec = self.cond_spec
        who = self.ckpt or self.model
        if spec["type"] == "text":
            if cond.text_emb is None and cond.texts is None:
                raise ValueError(f"{who}: a text model needs text conditions")
            encoder = spec.get("encoder", TEXT_ENCODER)
            if encoder != TEXT_ENCODER or cond.text_emb is None:   # the model reads another encoder's vectors
                if cond.texts is None:
                    raise ValueError(f"{who}: model conditions on {encoder!r}; the captions' text is needed")

                return np.asarray(text_encoders.encode_texts(cond.texts, encoder_id=encoder), np.float32)
            if cond.text_emb.shape[1] != spec["dim"]:
                raise ValueError(f"{who}: model expects {spec['dim']}-d text embeddings "
                                 f"({spec.get('encoder')}), got {cond.text_emb.shape[1]}")
            return cond.text_emb.astype(np.float32)
        if cond.labels is None:
            raise ValueError(f"{who}: an action model needs action labels")
        onehot = np.zeros((len(cond.labels), spec["dim"]), np.float32)
        onehot[np.arange(len(cond.labels)), cond.labels] = 1.0
        return onehot

    def generate(self, cond: Conditions, seed: int) -> list[np.ndarray]:
        c = self.conditions_of(cond)
        lengths = np.minimum(cond.lengths, self.max_frames)
        order = np.argsort(lengths, kind="stable")            # similar lengths per batch: less padding
        out: list[np.ndarray | None] = [None] * len(lengths)
        for s in range(0, len(order), self.batch_size):
            idx = order[s:s + self.batch_size]
            xs = batched_features(self.step, c[idx], lengths[idx], self.settings, seed * 100003 + s)
            for i, x in zip(idx, xs):
                out[i] = x * self.std + self.mean
        return out  # type: ignore[return-value]
