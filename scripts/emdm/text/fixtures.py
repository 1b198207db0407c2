"""Write the cross-language text fixtures in tests/fixtures/text/ (checked by pytest and vitest).

    python -m emdm.text.fixtures

- minilm_vectors.json: prompts (ordinary captions and hostile input: empty, 10,000 characters,
  emoji, right-to-left scripts, HTML, one word piece under and over the token limit) and their
  384-d vectors from the SHIPPED int8 ONNX file (Python: onnxruntime + tokenizers), with the token
  ids the encoder runs (cut to the manifest's maxTokens) and each prompt's whole token count.
  vitest runs transformers.js on the same file and requires the same ids and cosine >= 0.999 per
  prompt; pytest requires the file to match a fresh computation.
- clip_tokens.json: CLIP token ids (untruncated, and EMDM's 77 truncated/padded ids) of prompts from
  the real tokenizer in ../shared/data/clip-vit-base-patch32; transformers.js must produce the same.
"""

from __future__ import annotations

import json
from pathlib import Path

from emdm import paths
from emdm.text import load_encoder
from emdm.text.clip import ClipTokenizer, emdm_clip_ids

FIXTURE_DIR = paths.FIXTURES_DIR / "text"
MINILM_FIXTURE = FIXTURE_DIR / "minilm_vectors.json"
CLIP_FIXTURE = FIXTURE_DIR / "clip_tokens.json"
LONG_PROMPT = ("a person walks forward slowly, turns around and waves with the left hand; " * 200)[:10_000]

MINILM_PROMPTS = [
    "a person walks forward and then turns around",
    "someone jumps up and down twice",
    "the man kicks with his left leg",
    "a woman dances happily in a circle",
    "A person is running in a circle, then stops and waves with the right hand.",
    "walk",
    "an elderly man walks slowly, exhausted",
    "",
    "   ",
    LONG_PROMPT,
    "a person 🕺 dances 💃🏽 with joy 🎉",
    "شخص يمشي إلى الأمام ثم يستدير",
    "אדם הולך קדימה",
    "<b>a person</b> <script>alert('walks')</script> &amp; jumps",
    "Ünïcödé àccents: café, naïve, Übermensch",
    "人が前に歩いてから振り返る",
    ("walk " * 126).strip(),          # 126 word pieces + [CLS] + [SEP] = 128: exactly the limit
    ("walk " * 127).strip(),          # one over: cut to 128, [SEP] kept
]

CLIP_PROMPTS = [
    "a photo of a cat",
    "a person walks forward and then turns around",
    "a person walks forward, then turns left and jumps twice while waving both hands above the head happily and finally sits down on the floor",
    "",
    "A MAN kicks!!",
    "a person 🕺 dances with joy",
    "<b>walk</b> &amp; run",
    "café naïve",
]


def minilm_fixture() -> dict:
    enc = load_encoder("all-MiniLM-L6-v2")
    vecs = enc.encode(MINILM_PROMPTS)
    tokens = [enc.token_ids(p) for p in MINILM_PROMPTS]
    return {
        "encoder": enc.id,
        "source": "python: onnxruntime + tokenizers on public/models/text/all-MiniLM-L6-v2 (emdm.text.fixtures)",
        "dim": enc.dim,
        "maxTokens": enc.max_tokens,
        "prompts": MINILM_PROMPTS,
        "ids": [ids for ids, _ in tokens],
        "tokens": [total for _, total in tokens],
        "vectors": [[round(float(x), 7) for x in v] for v in vecs],
    }


def clip_fixture(tokenizer_dir: Path | None = None) -> dict:
    tok = ClipTokenizer(tokenizer_dir or paths.shared_file("clip-vit-base-patch32"))
    raw = [tok.ids(p) for p in CLIP_PROMPTS]
    return {
        "tokenizer": "openai/clip-vit-base-patch32 (../shared/data/clip-vit-base-patch32/tokenizer.json)",
        "eot": tok.eot_id,
        "prompts": CLIP_PROMPTS,
        "raw_ids": raw,
        "emdm_ids": [emdm_clip_ids(r, tok.eot_id) for r in raw],
    }


def write(path: Path, data: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, ensure_ascii=False, separators=(",", ":")) + "\n", encoding="utf-8")


def main() -> int:
    write(MINILM_FIXTURE, minilm_fixture())
    print(f"fixtures: wrote {MINILM_FIXTURE}")
    write(CLIP_FIXTURE, clip_fixture())
    print(f"fixtures: wrote {CLIP_FIXTURE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
