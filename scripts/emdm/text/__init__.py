"""Text encoders: one interface, two implementations.

    enc = load_encoder("all-MiniLM-L6-v2")      # the shipped default (int8 ONNX + tokenizers)
    enc.dim                                      # 384
    enc.encode(["a person walks"])              # float32 [N, 384], L2-normalised (mean pooling)
    encode_texts(texts, encoder_id=..., batch_size=...)

``"clip-vit-b32"`` (or any id of kind ``clip``) loads EMDM's paper encoder, CLIP ViT-B/32's text
tower, from a local folder (``model_dir=``) or the Hub name; see :mod:`emdm.text.clip`.
The shipped encoders are found through ``public/models/manifest.json`` (``textEncoders``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Protocol

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm.text.clip import ClipTextEncoder
from emdm.text.minilm import MiniLMEncoder, TextEncoderError

DEFAULT_ENCODER = "all-MiniLM-L6-v2"
CLIP_ENCODER = "clip-vit-b32"

__all__ = ["DEFAULT_ENCODER", "CLIP_ENCODER", "TextEncoder", "TextEncoderError", "load_encoder", "encode_texts",
           "truncation_notice"]


class TextEncoder(Protocol):
    id: str
    kind: str
    dim: int
    max_tokens: int          # tokens read, counting the encoder's own ([CLS] … [SEP], [SOT] … [EOT])

    def encode(self, texts: Sequence[str], batch_size: int = ...) -> np.ndarray: ...

    def token_ids(self, text: str) -> tuple[list[int], int]: ...


def truncation_notice(enc: TextEncoder, text: str) -> str | None:
    """The line to show when ``text`` is longer than the encoder reads (None when it fits).
    The page says the same under its prompt box (web/ui/controls.ts)."""
    ids, total = enc.token_ids(text)
    if total <= len(ids):
        return None
    return (f"prompt truncated to {len(ids)} tokens: {enc.id} reads at most {enc.max_tokens} "
            f"(counting its start and end tokens); the prompt has {total}, the rest is ignored")


_CACHE: dict[tuple[str, str], TextEncoder] = {}


def load_encoder(encoder_id: str = DEFAULT_ENCODER, *, models_dir: Path | str | None = None,
                 model_dir: Path | str | None = None) -> TextEncoder:
    """Load a text encoder by id.

    ``all-MiniLM-L6-v2`` (and any manifest entry of kind ``minilm``): the shipped ONNX folder named by
    the manifest under ``models_dir`` (default ``emdm.paths.models_dir()``: $EMDM_MODELS_DIR or public/models), or ``model_dir`` directly.
    ``clip-vit-b32`` / a manifest entry of kind ``clip``: CLIP's text tower via transformers from
    ``model_dir`` (a local folder with weights) or the Hub id ``openai/clip-vit-base-patch32``.
    """
    given, models_dir = models_dir, paths.models_dir(models_dir)      # an argument, $EMDM_MODELS_DIR or public/models
    key = (encoder_id, str(model_dir or models_dir))
    if key in _CACHE:
        return _CACHE[key]
    if encoder_id == CLIP_ENCODER or encoder_id.startswith("clip"):
        enc: TextEncoder = ClipTextEncoder(model_dir or "openai/clip-vit-base-patch32", encoder_id=encoder_id)
    elif model_dir is not None:
        enc = MiniLMEncoder(model_dir, encoder_id=encoder_id)
    else:
        try:
            manifest = mf.load(paths.require_models_dir(given))
        except paths.ModelsDirError as e:
            raise TextEncoderError(str(e)) from None
        entry = manifest["textEncoders"].get(encoder_id)
        if entry is None:
            known = ", ".join(sorted(manifest["textEncoders"])) or "none"
            raise TextEncoderError(
                f"{Path(models_dir) / mf.MANIFEST_NAME}: no textEncoders entry {encoder_id!r} (known: {known}); "
                f"run `python -m emdm.text.export_minilm{export_where(models_dir)}` (a folder `emdm.export --out` "
                f"wrote needs its text encoder too)")
        if entry.get("kind") != "minilm":
            raise TextEncoderError(f"manifest textEncoders.{encoder_id}: field 'kind' is {entry.get('kind')!r}, "
                                   f"this loader runs 'minilm' folders (use model_dir= for clip)")
        folder = verified_folder(manifest, models_dir, encoder_id, entry)
        enc = MiniLMEncoder(folder, encoder_id=encoder_id, max_tokens=entry.get("maxTokens"))
    _CACHE[key] = enc
    return enc


def export_where(models_dir: Path | str) -> str:
    """The ``--models-dir`` a fix-it hint must name: none for the default folder."""
    return "" if Path(models_dir).resolve() == Path(mf.DEFAULT_MODELS_DIR).resolve() else f" --models-dir {models_dir}"


def verified_folder(manifest: dict, models_dir: Path, encoder_id: str, entry: dict) -> Path:
    """The encoder's folder (inside ``models_dir``) once every file its entry lists (``files``: the ONNX file, the
    tokenizer's) has the size and sha256 the manifest's ``files`` gives, as the page checks them before use."""
    where = f"textEncoders.{encoder_id}"
    remedy = ("restore the folder from the repository's public/models or run "
              f"`python -m emdm.text.export_minilm{export_where(models_dir)}`")
    try:
        folder = mf.file_path(models_dir, entry.get("dir"), f"{where}.dir")   # inside models_dir
        listed = entry.get("files")
        if not isinstance(listed, list) or not listed:
            raise mf.ManifestError(f"{Path(models_dir) / mf.MANIFEST_NAME}: field '{where}.files' must list the "
                                   f"encoder's files (their sha256 under 'files'); {remedy}")
        for rel in listed:
            mf.verified_file(manifest, models_dir, rel, f"text encoder {encoder_id!r} lists it", f"{where}.files",
                             remedy)
    except mf.ManifestError as e:
        raise TextEncoderError(str(e)) from None
    return folder


def encode_texts(texts: Sequence[str], encoder_id: str = DEFAULT_ENCODER, batch_size: int = 64,
                 **load_kwargs) -> np.ndarray:
    """Embed texts with a (cached) encoder: float32 [N, dim]."""
    return load_encoder(encoder_id, **load_kwargs).encode(texts, batch_size=batch_size)
