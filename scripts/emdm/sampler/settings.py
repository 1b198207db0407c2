"""One object for how a motion is sampled (the TypeScript twin is ``SamplingSettings`` in src/sampler/): the update
rule, the step count, guidance and its interval, x̂0 smoothing and inpainting. The sampling loop
(``emdm.sampler.sampler``) takes it instead of a dozen positional parameters:

    settings = open_model("emdm-t2m-web").settings(steps=10)      # from_entry(entry, steps, mean=, std=) underneath
    x = sample_features(step, cond, 120, settings, seed=3)
    x = sample_features(step, cond, 120, dataclasses.replace(settings, known=known, keep=keep), seed=3)

Bad settings are a ``SampleError`` (one line naming the field) when the loop starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from emdm import manifest as mf

MAX_SEED = 2**32 - 1      # the page's seeds are uint32
MAX_STEPS = mf.MAX_STEPS
MAX_X0_SMOOTHING = mf.MAX_X0_SMOOTHING  # σ in frames (a σ of 50 already averages a 196-frame clip almost flat)
# the manifest's training objective → the update rule that samples it (the manifest key stays "objective")
METHOD_OF_OBJECTIVE = {"ddgan": "ddgan", "diffusion": "ddim"}


class SampleError(ValueError):
    """A bad argument or a bad result, said in one line (the CLI prints it and exits with status 2)."""


@dataclass(frozen=True, eq=False)
class SamplingSettings:
    """How to sample. ``method``: a name in ``emdm.sampler.registry.SAMPLERS`` ("ddgan": the DDGAN posterior with
    fresh z and ε every step; "ddim": DDIM, η = 0, z zeroed). ``guidance``: the classifier-free guidance scale (1 or
    an all-zero condition: one conditional row). ``guidance_min_time``: guide only the steps whose time is above it
    (the manifest's guidanceMinTime; 0 = every step). ``x0_smoothing``: σ in frames of x̂0's pose smoothing at every
    step but the last (the manifest's x0Smoothing; 0 = off). ``speed_cap``: each motion's median root speed at most
    this multiple of its first step's conditional x̂0's (``emdm.sampler.sampler``, "Root speed cap"; 0 = off), which
    needs ``root_norm``: the mean and std of root velocity channels 1 and 2 (m1, m2, s1, s2; the
    model's meanstd). Inpainting: ``known`` (frames, D) normalised features and ``keep`` (frames, D) 0/1, imposed at
    the steps with t ≤ ``keep_from_time`` and the last. ``z_dim`` and ``feature_dim``: the model's latent and feature
    sizes (its manifest's zDim and featureDim)."""
    method: str = "ddgan"
    steps: int = 10
    guidance: float = 1.0
    guidance_min_time: float = 0.0
    x0_smoothing: float = 0.0
    speed_cap: float = 0.0
    root_norm: tuple[float, float, float, float] | None = None
    known: np.ndarray | None = None
    keep: np.ndarray | None = None
    keep_from_time: float = 1.0
    z_dim: int = 64
    feature_dim: int = 263

    @classmethod
    def from_entry(cls, entry: dict, steps: int | None = None, guidance: float | None = None,
                   mean: np.ndarray | None = None, std: np.ndarray | None = None) -> "SamplingSettings":
        """A manifest model entry's own settings (defaultSteps, guidance, guidanceMinTime, x0Smoothing, speedCap, zDim,
        its objective's method); ``steps``/``guidance`` given override them. ``mean``/``std``: the model's
        normalisation, whose root velocity channels a speedCap needs (``root_norm``)."""
        norm = None if mean is None or std is None else root_norm_of(mean, std)
        return cls(method=method_of(entry.get("objective", "ddgan")),
                   steps=int(entry.get("defaultSteps", 10)) if steps is None else steps,
                   guidance=float(entry.get("guidance", 2.5)) if guidance is None else guidance,
                   guidance_min_time=float(entry.get("guidanceMinTime", 0.0)),
                   x0_smoothing=float(entry.get("x0Smoothing", 0.0)), speed_cap=float(entry.get("speedCap", 0.0)),
                   root_norm=norm, z_dim=int(entry.get("zDim", 64)), feature_dim=int(entry.get("featureDim", 263)))

    def check(self, methods) -> None:
        """Each field in its range (``methods``: the registered method names); a SampleError names the first bad one."""
        if self.method not in methods:
            raise SampleError(f"method must be one of {', '.join(sorted(methods))}, got {self.method!r}")
        if not (math.isfinite(self.guidance_min_time) and self.guidance_min_time >= 0):
            raise SampleError(f"guidance_min_time must be a finite time ≥ 0 (0 = guide every step), "
                              f"got {self.guidance_min_time}")
        check_x0_smoothing(self.x0_smoothing)
        check_speed_cap(self.speed_cap, self.root_norm)
        if not (math.isfinite(self.keep_from_time) and self.keep_from_time >= 0):
            raise SampleError(f"keep_from_time must be a finite time ≥ 0 (1 = impose the kept part at every step), "
                              f"got {self.keep_from_time}")


def method_of(objective: str) -> str:
    """The update rule for a manifest's ``objective`` ("ddgan" → "ddgan", "diffusion" → "ddim")."""
    if objective not in METHOD_OF_OBJECTIVE:
        raise SampleError(f"objective must be one of {', '.join(METHOD_OF_OBJECTIVE)}, got {objective!r}")
    return METHOD_OF_OBJECTIVE[objective]


def check_x0_smoothing(sigma: float, name: str = "x0_smoothing") -> float:
    """σ in frames, in 0..MAX_X0_SMOOTHING (0 = off); anything else is a SampleError naming ``name``."""
    if (isinstance(sigma, bool) or not isinstance(sigma, (int, float, np.floating))
            or not (math.isfinite(sigma) and 0 <= sigma <= MAX_X0_SMOOTHING)):
        raise SampleError(f"{name} must be a finite σ ≥ 0 in frames (0 = off), got {sigma!r} (at most {MAX_X0_SMOOTHING:g})")
    return float(sigma)


def root_norm_of(mean: np.ndarray, std: np.ndarray) -> tuple[float, float, float, float]:
    """A model's normalisation of root velocity channels 1 and 2, (m1, m2, s1, s2): what ``speed_cap`` needs."""
    return float(mean[1]), float(mean[2]), float(std[1]), float(std[2])


def check_speed_cap(cap: float, root_norm) -> float:
    """``speed_cap`` ≥ 0 (0 = off) and, when on, four finite ``root_norm`` values with positive stds."""
    if isinstance(cap, bool) or not isinstance(cap, (int, float, np.floating)) or not (math.isfinite(cap) and cap >= 0):
        raise SampleError(f"speed_cap must be a finite multiple ≥ 0 of the first step's root speed (0 = off), got {cap!r}")
    if cap > 0:
        norm = None if root_norm is None else np.asarray(root_norm, np.float64).ravel()
        if norm is None or norm.size != 4 or not np.all(np.isfinite(norm)) or not (norm[2] > 0 and norm[3] > 0):
            raise SampleError("speed_cap needs root_norm: the mean and std of root velocity channels 1 and 2 "
                              f"(m1, m2, s1, s2; the model's meanstd, stds > 0), got {root_norm!r}; pass mean= and "
                              "std= to SamplingSettings.from_entry, or use OpenedModel.settings()")
    return float(cap)


def check_steps(steps: int | None, entry: dict, name: str, option: str = "--steps") -> int:
    """The step count to run: ``steps`` (None: the model's default) if the model supports it, as the page.
    ``option``: how the caller's user gave it (the CLI's "--steps", Python's "steps"), for the error."""
    supported = entry.get("supportedSteps")
    if steps is None:
        return int(entry.get("defaultSteps", 10))
    sep = ": " if option.startswith("-") else "="
    if supported:
        if steps not in supported:
            raise SampleError(f"{option}{sep}{steps} is not supported by model {name!r}; use one of {list(supported)}")
    elif not 1 <= steps <= MAX_STEPS:
        raise SampleError(f"{option} must be in 1..{MAX_STEPS}, got {steps}")
    return steps
