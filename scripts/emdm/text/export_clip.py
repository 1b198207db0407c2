"""Export CLIP's text tower (EMDM's encoder) to the transformers.js layout and register it.

    python -m emdm.text.export_clip --source DIR_WITH_WEIGHTS [--models-dir public/models] [--name clip-vit-b32]
    python -m emdm.text.export_clip --source ../shared/data/clip-vit-base-patch32 --random-init \
        --models-dir /tmp/m --reference prompts.json     # tests: random tower of the real config

Writes <models-dir>/text/<name>/{config.json, tokenizer.json, tokenizer_config.json, onnx/text_model.onnx}
(fp32; transformers.js's CLIPTextModelWithProjection reads onnx/text_model.onnx) and the manifest
entry textEncoders[<name>] (kind "clip", dim 512). ``--reference`` (a JSON list of prompts) also
writes reference.json beside the model: EMDM token ids and PyTorch embeddings, for cross-checks.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm.model.quiet import quiet_onnx_tools
from emdm.text.clip import CONTEXT, PADDED_LENGTH, ClipTextEncoder, ClipTokenizer, random_text_model

ONNX_REL = "onnx/text_model.onnx"
FILES = ("config.json", "tokenizer.json", "tokenizer_config.json", ONNX_REL)


def export_onnx(model, path: Path) -> None:
    import torch

    class Tower(torch.nn.Module):
        def __init__(self, m):
            super().__init__()
            self.m = m

        def forward(self, input_ids):
            o = self.m(input_ids=input_ids)
            return o.text_embeds, o.last_hidden_state

    ids = torch.zeros((2, PADDED_LENGTH), dtype=torch.long)
    ids[:, 0] = 49406
    ids[0, 1:4] = torch.tensor([320, 1125, 49407])
    ids[1, 1:6] = torch.tensor([320, 2368, 539, 320, 49407])
    batch = torch.export.Dim("batch", min=1, max=1024)
    path.parent.mkdir(parents=True, exist_ok=True)
    with torch.no_grad(), quiet_onnx_tools():
        prog = torch.onnx.export(Tower(model).eval(), (ids,), dynamo=True, opset_version=18,
                                 input_names=["input_ids"], output_names=["text_embeds", "last_hidden_state"],
                                 dynamic_shapes={"input_ids": {0: batch}}, external_data=False)
    prog.save(str(path))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", type=Path, required=True, help="CLIP folder: config.json + tokenizer.json (+ weights unless --random-init)")
    ap.add_argument("--models-dir", type=Path, default=mf.DEFAULT_MODELS_DIR)
    ap.add_argument("--name", default="clip-vit-b32")
    ap.add_argument("--random-init", action="store_true", help="random weights of the real config (testing the path)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--reference", type=Path, help="JSON list of prompts: write reference.json (ids + PyTorch embeddings)")
    args = ap.parse_args(argv)
    src: Path = args.source
    for name in ("config.json", "tokenizer.json", "tokenizer_config.json"):
        if not (src / name).is_file():
            print(f"export_clip: {src / name} missing", file=sys.stderr)
            return 2
    model = random_text_model(src, args.seed) if args.random_init else None
    enc = ClipTextEncoder(src, encoder_id=args.name, model=model, tokenizer_dir=src)
    out = args.models_dir / "text" / args.name
    out.mkdir(parents=True, exist_ok=True)
    for name in ("config.json", "tokenizer.json", "tokenizer_config.json"):
        shutil.copyfile(src / name, out / name)
    export_onnx(enc.model, out / ONNX_REL)
    rel = out.resolve().relative_to(args.models_dir.resolve()).as_posix()
    entry = {
        "kind": "clip", "dim": enc.dim, "pooling": "eos", "normalize": False, "maxTokens": CONTEXT, "dtype": "fp32",
        "dir": rel, "onnx": f"{rel}/{ONNX_REL}",
        "source": "random init of the openai/clip-vit-base-patch32 text config (testing only)" if args.random_init
        else f"CLIP text tower from {src.name}",
        "files": [f"{rel}/{f}" for f in FILES],
    }
    mf.update_entry("textEncoders", args.name, entry, args.models_dir)
    if args.reference:
        prompts = json.loads(args.reference.read_text())
        if not isinstance(prompts, list) or not all(isinstance(p, str) for p in prompts):
            print(f"export_clip: {args.reference}: expected a JSON list of strings", file=sys.stderr)
            return 2
        tok = ClipTokenizer(src)
        ids = tok.emdm_ids(prompts)
        emb = enc.encode(prompts)
        (out / "reference.json").write_text(json.dumps({
            "prompts": prompts, "ids": ids.tolist(),
            "embeddings": [[float(x) for x in row] for row in emb.astype(np.float64)],
        }))
    print(f"export_clip: wrote {out / ONNX_REL} ({(out / ONNX_REL).stat().st_size / 1e6:.1f} MB), entry textEncoders.{args.name}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
