"""public/models/manifest.json: the shipped one verifies, and the writer refuses broken input."""

from __future__ import annotations

import json

import pytest

from emdm import manifest as mf


def test_shipped_manifest_verifies_every_file():
    assert mf.verify() == [], "a shipped file differs from public/models/manifest.json"
    m = mf.load()
    assert m["schema"] == 1 and len(m["skeleton"]["joints"]) == 22
    assert set(mf.referenced_files(m)) <= set(m["files"])


def test_update_entry_records_size_and_sha256(tmp_path):
    (tmp_path / "enc").mkdir()
    (tmp_path / "enc/a.bin").write_bytes(b"abc")
    mf.update_entry("textEncoders", "x", {"kind": "minilm", "dim": 3, "dir": "enc", "files": ["enc/a.bin"]}, tmp_path)
    data = json.loads((tmp_path / "manifest.json").read_text())
    assert data["files"]["enc/a.bin"] == {
        "bytes": 3, "sha256": "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"}
    assert mf.verify(tmp_path) == []
    (tmp_path / "enc/a.bin").write_bytes(b"abd")
    assert any("sha256 differs" in p for p in mf.verify(tmp_path))


def test_missing_file_and_bad_section_are_named(tmp_path):
    with pytest.raises(mf.ManifestError, match=r"enc/missing.onnx: listed in the manifest but missing"):
        mf.update_entry("textEncoders", "x", {"files": ["enc/missing.onnx"]}, tmp_path)
    with pytest.raises(mf.ManifestError, match="unknown manifest section"):
        mf.update_entry("other", "x", {"files": []}, tmp_path)


def test_malformed_manifest_names_line_and_field(tmp_path):
    (tmp_path / "manifest.json").write_text('{"schema": 1,\n "files": }')
    with pytest.raises(mf.ManifestError, match=r"manifest.json:2:\d+: invalid JSON"):
        mf.load(tmp_path)
    (tmp_path / "manifest.json").write_text('{"schema": 7}')
    with pytest.raises(mf.ManifestError, match="field 'schema' is 7"):
        mf.load(tmp_path)


def test_an_int_past_floats_range_is_a_field_error():
    """JSON's 10**400 is a Python int that math.isfinite cannot take (OverflowError): a field error like any other."""
    entry = {"task": "text", "condition": {"type": "text", "encoder": "e", "dim": 4}, "onnx": "m.onnx",
             "meanStd": "m.f32", "guidance": 10**400}
    with pytest.raises(mf.ManifestError, match="field 'models.m.guidance' is 1000"):
        mf.check_model_entry(entry, "m", "manifest.json")
