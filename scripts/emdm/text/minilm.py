"""all-MiniLM-L6-v2 sentence encoder running THE SHIPPED int8 ONNX file (what the browser runs).

Tokenisation uses the shipped tokenizer.json through HuggingFace ``tokenizers`` (the same file
transformers.js reads); the ONNX graph returns token vectors; sentences are mean-pooled over real
tokens and L2-normalised (384-d). A prompt is cut to ``max_tokens`` word pieces counting [CLS] and
[SEP] (the manifest's ``maxTokens``; the page cuts at the same token, src/text/encoder.ts).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from emdm.text.pooling import l2_normalize, mean_pool

ONNX_REL = "onnx/model_quantized.onnx"


class TextEncoderError(ValueError):
    """Bad input to, or a broken file of, a text encoder (the message names which)."""


def check_texts(texts: Sequence[str], who: str) -> list[str]:
    if isinstance(texts, str):
        raise TextEncoderError(f"{who}.encode: expected a list of strings, got one string (wrap it in a list)")
    out = []
    for i, t in enumerate(texts):
        if not isinstance(t, str):
            raise TextEncoderError(f"{who}.encode: texts[{i}] is {type(t).__name__}, expected str")
        out.append(t)
    return out


class MiniLMEncoder:
    """``encode(list[str]) -> float32 [N, 384]``, unit-length rows."""

    kind = "minilm"

    def __init__(self, model_dir: Path | str, *, encoder_id: str = "all-MiniLM-L6-v2", threads: int | None = None,
                 max_tokens: int | None = None):
        """``max_tokens``: the manifest's ``maxTokens`` (default: the folder's tokenizer_config.json)."""
        import onnxruntime as ort
        from tokenizers import Tokenizer

        self.id = encoder_id
        self.dir = Path(model_dir)
        onnx_path = self.dir / ONNX_REL
        tok_path = self.dir / "tokenizer.json"
        for p in (onnx_path, tok_path, self.dir / "tokenizer_config.json"):
            if not p.is_file():
                raise TextEncoderError(f"{p}: missing; run `python -m emdm.text.export_minilm --out {self.dir}` "
                                       "to build the encoder folder")
        cfg = json.loads((self.dir / "tokenizer_config.json").read_text())
        self.max_tokens = int(max_tokens if max_tokens is not None else cfg.get("model_max_length", 128))
        if self.max_tokens < 2:
            raise TextEncoderError(f"{self.id}: maxTokens must be >= 2 ([CLS] and [SEP]), got {self.max_tokens}")
        try:
            self.tokenizer = Tokenizer.from_file(str(tok_path))
        except Exception as e:   # tokenizers raises a bare Exception for a malformed file
            raise TextEncoderError(f"{tok_path}: not a tokenizer file ({str(e).splitlines()[0] if str(e) else e!r}); "
                                   "restore the encoder folder or run `python -m emdm.text.export_minilm`") from None
        self.tokenizer.no_padding()
        self.tokenizer.enable_truncation(self.max_tokens)
        self.untruncated = Tokenizer.from_file(str(tok_path))
        self.untruncated.no_padding()
        self.untruncated.no_truncation()
        so = ort.SessionOptions()
        if threads:
            so.intra_op_num_threads = threads
        so.log_severity_level = 3
        self.session = ort.InferenceSession(str(onnx_path), so, providers=["CPUExecutionProvider"])
        out = self.session.get_outputs()[0]
        self.dim = int(out.shape[-1]) if isinstance(out.shape[-1], int) else 384
        self.input_names = [i.name for i in self.session.get_inputs()]

    def token_ids(self, text: str) -> tuple[list[int], int]:
        """(the ids the encoder runs on ``text``, at most ``max_tokens``; how many the whole prompt has)."""
        text = check_texts([text], self.id)[0]
        return list(self.tokenizer.encode(text).ids), len(self.untruncated.encode(text).ids)

    def _run(self, encs) -> np.ndarray:
        n, t = len(encs), max(len(e.ids) for e in encs)
        ids = np.zeros((n, t), np.int64)
        mask = np.zeros((n, t), np.int64)
        types = np.zeros((n, t), np.int64)
        for i, e in enumerate(encs):
            ids[i, : len(e.ids)] = e.ids
            mask[i, : len(e.ids)] = 1
            types[i, : len(e.ids)] = e.type_ids
        feeds = {"input_ids": ids, "attention_mask": mask, "token_type_ids": types}
        hidden = self.session.run(None, {k: feeds[k] for k in self.input_names})[0]
        return l2_normalize(mean_pool(hidden, mask))

    def encode(self, texts: Sequence[str], batch_size: int = 64) -> np.ndarray:
        """Embed ``texts`` (float32 [N, dim], unit rows). Prompts are grouped by token length, so no
        padding is ever computed; the shipped file computes in float32 (int8 weights only), so a
        prompt's vector does not depend on its batch (to ~1e-7) and equals the browser's."""
        texts = check_texts(texts, self.id)
        if batch_size < 1:
            raise TextEncoderError(f"{self.id}.encode: batch_size must be >= 1, got {batch_size}")
        out = np.zeros((len(texts), self.dim), np.float32)
        if not texts:
            return out
        encs = self.tokenizer.encode_batch(texts)
        by_len: dict[int, list[int]] = {}
        for i, e in enumerate(encs):
            by_len.setdefault(len(e.ids), []).append(i)
        for idx in by_len.values():
            for s in range(0, len(idx), batch_size):
                chunk = idx[s : s + batch_size]
                out[chunk] = self._run([encs[i] for i in chunk])
        return out
