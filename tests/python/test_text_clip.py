"""The CLIP (EMDM's encoder) path in Python: EMDM's truncation rule, the real CLIP tokenizer, and a
randomly initialised text tower of the real configuration (pretrained weights are unobtainable
here) run through PyTorch and through its exported ONNX file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from emdm import paths
from emdm.text import TextEncoderError
from emdm.text import fixtures as fx
from emdm.text.clip import CONTEXT, PADDED_LENGTH, ClipTextEncoder, ClipTokenizer, emdm_clip_ids, random_text_model

SOT, EOT = 49406, 49407
CLIP_DIR = paths.shared_data_dir() / "clip-vit-base-patch32"
needs_clip = pytest.mark.skipif(
    not (CLIP_DIR / "tokenizer.json").is_file(),
    reason=f"needs the real CLIP tokenizer/config at {CLIP_DIR} (the shared data folder beside the checkout, "
           f"or set EMDM_SHARED_DATA)")


def test_short_prompt_is_padded_with_zeros_to_77():
    ids = emdm_clip_ids([SOT, 320, 1125, EOT], EOT)
    assert len(ids) == PADDED_LENGTH and ids[:4] == [SOT, 320, 1125, EOT] and set(ids[4:]) == {0}


def test_long_prompt_keeps_20_tokens_and_ends_with_eot():
    raw = [SOT] + list(range(1000, 1030)) + [EOT]
    ids = emdm_clip_ids(raw, EOT)
    assert ids[:CONTEXT - 1] == raw[:CONTEXT - 1] and ids[CONTEXT - 1] == EOT
    assert ids[CONTEXT:] == [0] * (PADDED_LENGTH - CONTEXT)
    exact = [SOT] + list(range(1000, 1020)) + [EOT]  # exactly 20 text tokens: unchanged
    assert emdm_clip_ids(exact, EOT)[:CONTEXT] == exact


def test_truncation_rejects_ids_without_end_token():
    with pytest.raises(TextEncoderError, match="last id must be the end token"):
        emdm_clip_ids([SOT, 320], EOT)
    with pytest.raises(TextEncoderError, match="at least"):
        emdm_clip_ids([EOT], EOT)


@needs_clip
def test_real_tokenizer_gives_known_clip_ids():
    tok = ClipTokenizer(CLIP_DIR)
    assert tok.ids("a photo of a cat") == [49406, 320, 1125, 539, 320, 2368, 49407]
    assert tok.eot_id == EOT


@needs_clip
def test_clip_token_fixture_is_up_to_date():
    saved = json.loads(fx.CLIP_FIXTURE.read_text(encoding="utf-8"))
    assert saved == fx.clip_fixture(CLIP_DIR), "run `python -m emdm.text.fixtures`"
    long_ids = saved["emdm_ids"][saved["prompts"].index(fx.CLIP_PROMPTS[2])]
    assert long_ids[CONTEXT - 1] == EOT and long_ids[CONTEXT] == 0  # the fixture exercises truncation


@needs_clip
def test_weightless_folder_is_refused_with_a_clear_message():
    with pytest.raises(TextEncoderError, match="no CLIP weights"):
        ClipTextEncoder(CLIP_DIR)


@pytest.fixture(scope="module")
def random_clip():
    if not (CLIP_DIR / "config.json").is_file():
        pytest.skip(f"needs the real CLIP config at {CLIP_DIR}")
    return ClipTextEncoder(CLIP_DIR, model=random_text_model(CLIP_DIR, seed=0), tokenizer_dir=CLIP_DIR)


def test_random_tower_has_the_real_shape_and_emdm_truncation(random_clip):
    long = fx.CLIP_PROMPTS[2]  # 26 text tokens
    assert len(random_clip.tokenizer.ids(long)) > CONTEXT
    v = random_clip.encode(["a photo of a cat", "", "a person 🕺 dances", "<b>x</b>", long, long + " and sleeps"])
    assert v.shape == (6, 512) and v.dtype == np.float32 and np.isfinite(v).all()
    # words beyond EMDM's 20-token context change nothing; an early difference does
    np.testing.assert_array_equal(v[4], v[5])
    assert np.abs(v[0] - v[1]).max() > 1e-3
    ids, total = random_clip.token_ids(long)
    assert random_clip.max_tokens == CONTEXT == len(ids) and total == len(random_clip.tokenizer.ids(long))
    assert ids[-1] == EOT and ids == fx.clip_fixture(CLIP_DIR)["emdm_ids"][2][:CONTEXT]
    from emdm.text import truncation_notice

    assert truncation_notice(random_clip, long).startswith(f"prompt truncated to {CONTEXT} tokens")
    assert truncation_notice(random_clip, "a photo of a cat") is None


def test_exported_onnx_equals_pytorch(random_clip, tmp_path):
    import onnxruntime as ort

    from emdm.text import export_clip

    prompts = tmp_path / "prompts.json"
    prompts.write_text(json.dumps(fx.CLIP_PROMPTS))
    models = tmp_path / "models"
    assert export_clip.main(["--source", str(CLIP_DIR), "--random-init", "--seed", "0", "--models-dir", str(models),
                             "--reference", str(prompts)]) == 0
    entry = json.loads((models / "manifest.json").read_text())["textEncoders"]["clip-vit-b32"]
    assert entry["kind"] == "clip" and entry["dim"] == 512 and entry["maxTokens"] == CONTEXT   # counting [SOT], [EOT]
    sess = ort.InferenceSession(str(models / entry["onnx"]), providers=["CPUExecutionProvider"])
    ids = random_clip.tokenizer.emdm_ids(fx.CLIP_PROMPTS)
    got = sess.run(["text_embeds"], {"input_ids": ids})[0]
    ref = random_clip.encode(fx.CLIP_PROMPTS)   # same seed → same weights as the exported tower
    np.testing.assert_allclose(got, ref, atol=1e-4)
    saved = json.loads((models / "text/clip-vit-b32/reference.json").read_text())
    np.testing.assert_allclose(np.array(saved["embeddings"]), ref, atol=1e-6)
