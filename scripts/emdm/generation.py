"""``emdm.generate``: one call from a prompt to a motion, for a program that installed the package.

    import emdm
    m = emdm.generate("a person walks forward", seconds=6, seed=1, models_dir="path/to/models")
    m.joints            # (frames, 22, 3) float32, metres, Y up, 20 fps (emdm.skeleton.JOINT_NAMES)
    m.features          # (frames, 263) float32, de-normalised HumanML3D features
    m.write_bvh("walk.bvh"); m.write_glb("walk.glb")

The models are not inside the package: ``models_dir`` (else ``$EMDM_MODELS_DIR``, else the repository's
public/models; ``emdm.paths.models_dir``) is a copy of the repository's public/models folder. The same loop as
``emdm-sample`` (``emdm.sampler.sample_features``, the shipped ONNX step model through onnxruntime, the text
encoder of the same folder), so a prompt, seed and step count give the same motion as the CLI; torch is never
imported. Bad input (a prompt that is empty, a length the model cannot make, an unsupported step count, a models
folder without a manifest) is a :class:`emdm.sampler.SampleError` whose message is one line. A prompt far from
what the model does well (the model's capabilities file; ``emdm.prompt_check``) still generates, with a
:class:`PromptWarning` that says so, as the page's notice and the CLI do ("… does not read as English …", "… reads as
kick, which the model does not do well yet …", and the closest prompts that work).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from emdm import prompt_check
from emdm import skeleton as sk
from emdm.model.open import ModelError, open_shipped
from emdm.motion.features import recover_joints
from emdm.sampler import MAX_SEED, SampleError, check_steps, denormalise, make_condition, sample_features
from emdm.writers.bvh import write_bvh
from emdm.writers.glb import write_glb

DEFAULT_MODEL = "emdm-t2m-web"


class PromptWarning(UserWarning):
    """``emdm.generate``'s prompt is far from what the model does well (the message says why and what works)."""


@dataclass(frozen=True)
class Motion:
    """A generated motion: joints (frames, 22, 3) metres and features (frames, 263), at ``fps``."""
    joints: np.ndarray
    features: np.ndarray
    fps: float = float(sk.FPS)

    @property
    def seconds(self) -> float:
        return self.joints.shape[0] / self.fps

    def write_bvh(self, path: Path | str, units: str = "m") -> Path:
        """A BVH file (``emdm.writers.bvh``; metres, or ``units="cm"``)."""
        return write_bvh(self.joints, path, self.fps, units)

    def write_glb(self, path: Path | str) -> Path:
        """A binary glTF 2.0 file: skinned skeleton with one animation (``emdm.writers.glb``)."""
        return write_glb(self.joints, path, self.fps)


def generate(prompt: str, *, seconds: float = 6.0, seed: int = 0, steps: int | None = None,
             models_dir: Path | str | None = None, model: str = DEFAULT_MODEL, variant: str | None = None,
             guidance: float | None = None, threads: int = 1) -> Motion:
    """The motion ``prompt`` describes (a text model) or names (an action model's label), ``seconds`` long.

    ``seed`` (uint32) fixes the random draws; ``steps`` is one of the model's supportedSteps (None: its default);
    ``model`` a name in the folder's manifest.json and ``variant`` one of its variants (None: fp32)."""
    if not isinstance(prompt, str) or not prompt.strip():
        raise SampleError(f"prompt must be a non-empty string saying what the character should do, got {prompt!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or not 0 <= seed <= MAX_SEED:
        raise SampleError(f"seed must be an integer in 0..{MAX_SEED}, got {seed!r}")
    try:
        opened = open_shipped(model, models_dir=models_dir, variant=variant, threads=threads)
    except ModelError as e:
        raise SampleError(str(e)) from None
    entry = opened.meta
    max_frames = opened.max_frames
    if isinstance(seconds, bool) or not isinstance(seconds, (int, float)) or not math.isfinite(seconds):
        raise SampleError(f"seconds must be a finite number, got {seconds!r}")
    frames = round(seconds * sk.FPS)
    if not 1 <= frames <= max_frames:
        raise SampleError(f"seconds must give 1..{max_frames} frames at {sk.FPS} fps "
                          f"(at most {max_frames / sk.FPS:g} s), got {seconds!r}")
    steps = check_steps(steps, entry, model, "steps")          # before the prompt is encoded
    spec = entry["condition"]
    text, action = (prompt, None) if spec["type"] == "text" else (None, prompt)
    cond = make_condition(spec, text, action, False, models_dir)
    if text is not None:
        try:
            far = prompt_check.prompt_notice(model, cond, models_dir, text)
        except prompt_check.CapabilitiesError as e:      # advisory, as on the page and the CLI: say it and generate
            far = f"no prompt check: {e}"
        if far:
            warnings.warn(far, PromptWarning, stacklevel=2)
    g = float(entry.get("guidance", 2.5)) if guidance is None else guidance
    if not (math.isfinite(g) and g >= 0):
        raise SampleError(f"guidance must be a finite number ≥ 0, got {guidance!r}")
    x = sample_features(opened.step, cond, frames, opened.settings(steps, g), seed)
    feats = denormalise(x[0], opened.mean, opened.std).astype(np.float32)
    if not np.isfinite(feats).all():
        raise SampleError(f"model {model!r} returned non-finite numbers; check its files against the manifest's sha256")
    return Motion(recover_joints(feats).astype(np.float32), feats)
