"""CLIP ViT-B/32 text tower — EMDM's (and MDM's) text encoder — with EMDM's truncation.

EMDM tokenises with ``clip.tokenize(text, context_length=22, truncate=True)`` (at most 20 text tokens
between [SOT] and [EOT]; a longer prompt is cut and its last kept slot becomes [EOT]), zero-pads to
CLIP's 77 positions and takes the projected [EOT] embedding (512-d, not normalised).
``emdm_clip_ids`` is that rule (mirrored by ``src/text/clipTokens.ts``); ``ClipTextEncoder`` runs the
text tower through transformers' ``CLIPTextModelWithProjection`` from a local folder (with weights)
or the Hub. Pretrained weights are not available on every machine; the tests use the real tokenizer
and a randomly initialised tower of the real configuration (``random_text_model``).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from emdm.text.minilm import TextEncoderError, check_texts

MAX_TEXT_TOKENS = 20
CONTEXT = MAX_TEXT_TOKENS + 2
PADDED_LENGTH = 77
PAD_ID = 0
SOT_TOKEN = "<|startoftext|>"
EOT_TOKEN = "<|endoftext|>"
HUB_ID = "openai/clip-vit-base-patch32"


def emdm_clip_ids(ids: Sequence[int], eot_id: int, context: int = CONTEXT, padded_length: int = PADDED_LENGTH) -> list[int]:
    """[SOT] … [EOT] ids → EMDM's truncated (≤ ``context``) and zero-padded (``padded_length``) ids."""
    ids = list(ids)
    if len(ids) < 2:
        raise TextEncoderError(f"emdm_clip_ids: expected at least [SOT, EOT], got {len(ids)} ids")
    if ids[-1] != eot_id:
        raise TextEncoderError(f"emdm_clip_ids: the last id must be the end token {eot_id}, got {ids[-1]}")
    if len(ids) > context:
        ids = ids[:context]
        ids[-1] = eot_id
    return ids + [PAD_ID] * (padded_length - len(ids))


class ClipTokenizer:
    """CLIP's BPE tokenizer from a ``tokenizer.json`` (HuggingFace ``tokenizers``; no truncation/padding)."""

    def __init__(self, folder: Path | str):
        from tokenizers import Tokenizer

        path = Path(folder) / "tokenizer.json"
        if not path.is_file():
            raise TextEncoderError(f"{path}: missing; a CLIP folder needs tokenizer.json (transformers.js layout)")
        self.tok = Tokenizer.from_file(str(path))
        self.tok.no_truncation()
        self.tok.no_padding()
        eot = self.tok.token_to_id(EOT_TOKEN)
        if eot is None:
            raise TextEncoderError(f"{path}: no {EOT_TOKEN} token; is this a CLIP tokenizer?")
        self.eot_id = int(eot)

    def ids(self, text: str) -> list[int]:
        """Untruncated ids with [SOT] … [EOT]."""
        return list(self.tok.encode(text).ids)

    def emdm_ids(self, texts: Sequence[str]) -> np.ndarray:
        """(N, 77) int64: EMDM's truncated, zero-padded ids."""
        return np.array([emdm_clip_ids(self.ids(t), self.eot_id) for t in texts], dtype=np.int64)


def text_config(folder: Path | str):
    """The CLIPTextConfig (with projection_dim) from a CLIP folder's config.json."""
    from transformers import CLIPConfig, CLIPTextConfig

    path = Path(folder) / "config.json"
    if not path.is_file():
        raise TextEncoderError(f"{path}: missing; a CLIP folder needs config.json")
    import json

    raw = json.loads(path.read_text())
    if raw.get("model_type") == "clip_text_model":
        return CLIPTextConfig.from_pretrained(str(folder))
    cfg = CLIPConfig.from_pretrained(str(folder))
    tc = cfg.text_config
    tc.projection_dim = cfg.projection_dim
    return tc


def random_text_model(folder: Path | str, seed: int = 0):
    """A randomly initialised CLIPTextModelWithProjection of the folder's real configuration."""
    import torch
    from transformers import CLIPTextModelWithProjection

    cfg = text_config(folder)
    cfg._attn_implementation = "eager"
    torch.manual_seed(seed)
    return CLIPTextModelWithProjection(cfg).eval()


class ClipTextEncoder:
    """``encode(list[str]) -> float32 [N, 512]``: EMDM's CLIP text features (projected, not normalised)."""

    kind = "clip"

    def __init__(self, source: Path | str = HUB_ID, *, encoder_id: str = "clip-vit-b32", model=None,
                 tokenizer_dir: Path | str | None = None):
        self.id = encoder_id
        src = Path(source)
        if model is None:
            from transformers import CLIPTextModelWithProjection

            if src.exists() and not any(src.glob("*.safetensors")) and not any(src.glob("*.bin")):
                raise TextEncoderError(
                    f"{src}: no CLIP weights (*.safetensors / *.bin) in this folder; pass a folder with the "
                    f"pretrained openai/clip-vit-base-patch32 weights or the Hub id")
            model = CLIPTextModelWithProjection.from_pretrained(str(source), attn_implementation="eager").eval()
        self.model = model
        tdir = Path(tokenizer_dir) if tokenizer_dir is not None else src
        if not (tdir / "tokenizer.json").is_file():
            from transformers import AutoTokenizer

            tmp = AutoTokenizer.from_pretrained(str(source))
            self.tokenizer = ClipTokenizer.__new__(ClipTokenizer)
            self.tokenizer.tok = tmp.backend_tokenizer
            self.tokenizer.tok.no_truncation()
            self.tokenizer.tok.no_padding()
            self.tokenizer.eot_id = int(self.tokenizer.tok.token_to_id(EOT_TOKEN))
        else:
            self.tokenizer = ClipTokenizer(tdir)
        self.dim = int(self.model.config.projection_dim)
        self.max_tokens = CONTEXT

    def token_ids(self, text: str) -> tuple[list[int], int]:
        """(EMDM's ids of ``text`` without the padding, at most ``max_tokens``; how many the whole prompt has)."""
        raw = self.tokenizer.ids(check_texts([text], self.id)[0])
        ids = emdm_clip_ids(raw, self.tokenizer.eot_id, padded_length=0)
        return ids, len(raw)

    def encode(self, texts: Sequence[str], batch_size: int = 64) -> np.ndarray:
        import torch

        texts = check_texts(texts, self.id)
        if batch_size < 1:
            raise TextEncoderError(f"{self.id}.encode: batch_size must be >= 1, got {batch_size}")
        out = np.zeros((len(texts), self.dim), np.float32)
        for s in range(0, len(texts), batch_size):
            ids = torch.from_numpy(self.tokenizer.emdm_ids(texts[s : s + batch_size]))
            with torch.no_grad():
                out[s : s + len(ids)] = self.model(input_ids=ids).text_embeds.float().numpy()
        return out
