"""The condition vector c the step model is given, from a model's ``condition`` spec (manifest format): a text
model's prompt through its text encoder, an action model's label as a one-hot row, or zeros (unconditional)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm.sampler.settings import SampleError
from emdm.text import TextEncoderError, load_encoder, truncation_notice


def make_condition(spec: dict, text: str | None, action: str | None, uncond: bool,
                   models_dir: Path | str | None = None) -> np.ndarray:
    """The condition vector for a model's ``condition`` spec; a text model's encoder is read from ``models_dir``
    (default ``emdm.paths.models_dir()``: $EMDM_MODELS_DIR or public/models)."""
    dim = int(spec["dim"])
    given = sum(v is not None and v is not False for v in (text, action)) + int(bool(uncond))
    if given != 1:
        raise SampleError("give exactly one of --text, --action, --uncond")
    if uncond:
        return np.zeros(dim, np.float32)
    if spec["type"] == "text":
        return text_condition(spec, text, models_dir)
    if action is None:
        raise SampleError("this is an action model: use --action LABEL (or its index) or --uncond")
    labels = list(spec["labels"])
    if action in labels:
        idx = labels.index(action)
    elif action.isdigit() and int(action) < len(labels):
        idx = int(action)
    else:
        raise SampleError(f"unknown action {action!r}; labels: {', '.join(labels)}")
    c = np.zeros(dim, np.float32)
    c[idx] = 1.0
    return c


def text_condition(spec: dict, text: str | None, models_dir: Path | str | None) -> np.ndarray:
    """A text model's prompt encoded (a prompt longer than the encoder reads is cut there, with a notice on stderr)."""
    dim = int(spec["dim"])
    if text is None:
        raise SampleError("this is a text model: use --text or --uncond")
    if not text.strip():
        raise SampleError("--text is empty: say what the character should do (or use --uncond)")
    try:
        enc = load_encoder(spec["encoder"], models_dir=models_dir)
    except (TextEncoderError, mf.ManifestError) as e:
        raise SampleError(str(e)) from None
    emb = np.asarray(enc.encode([text]), np.float32)[0]
    notice = truncation_notice(enc, text)      # the page shows the same notice under its prompt box
    if notice:
        print(notice, file=sys.stderr)
    if emb.shape != (dim,):
        raise SampleError(f"text encoder {spec['encoder']} gave {emb.shape}, model expects ({dim},)")
    return emb


def denormalise(x: np.ndarray, mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    """Normalised features (the sampler's x̂0) → the model's feature units: x·std + mean."""
    return x * std + mean
