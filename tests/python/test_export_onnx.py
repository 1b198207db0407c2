"""ONNX export of one denoising step: parity with PyTorch, dynamic batch/length, variants, manifest."""

import json

import numpy as np
import onnx
import pytest

from emdm.export import PARITY_CASES, export_onnx, load_generator, main as export_main, parity
from emdm.model.open import read_meanstd
from emdm.sampler.schedule import make_schedule
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress"]


@pytest.fixture(scope="module")
def checkpoint(tmp_path_factory):
    ds = write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)
    out = tmp_path_factory.mktemp("run")
    train_main(["--data", str(ds), "--task", "action", "--out", str(out), "--steps", "3", *TINY])
    return out / "ckpt.pt"


@pytest.fixture(scope="module")
def exported(checkpoint, tmp_path_factory):
    models = tmp_path_factory.mktemp("models")
    assert export_main(["--ckpt", str(checkpoint), "--name", "emdm-a2m-test", "--out", str(models)]) == 0
    return models


def test_onnx_inputs_outputs_and_dynamic_axes(exported):
    m = onnx.load(str(exported / "emdm-a2m-test.onnx"))
    assert m.opset_import[0].version == 18
    dims = {i.name: [d.dim_param or d.dim_value for d in i.type.tensor_type.shape.dim] for i in m.graph.input}
    assert list(dims) == ["x_t", "z", "cond", "t", "mask"]
    assert dims["x_t"][2] == 263 and dims["z"][1] == 64 and dims["cond"][1] == 3
    assert isinstance(dims["x_t"][0], str) and isinstance(dims["x_t"][1], str)      # batch, frames dynamic
    assert dims["mask"] == dims["x_t"][:2] and dims["t"] == dims["x_t"][:1]
    assert [o.name for o in m.graph.output] == ["x0"]
    ops = {n.op_type for n in m.graph.node}
    assert "Selu" not in ops and "Elu" in ops                                        # WebGPU has Elu, not Selu


def test_parity_with_pytorch_on_several_batches_and_lengths(checkpoint, exported):
    G, _, _ = load_generator(checkpoint)
    errs = parity(G, exported / "emdm-a2m-test.onnx")
    assert set(errs) == {f"{b}x{n}" for b, n in PARITY_CASES}
    assert max(errs.values()) <= 1e-4, errs


def test_int8_variant_and_meanstd_and_manifest(checkpoint, exported):
    man = json.loads((exported / "manifest.json").read_text())
    e = man["models"]["emdm-a2m-test"]
    assert e["task"] == "action" and e["condition"]["labels"] == ["walk", "wave", "turn"]
    assert e["variants"] == {"int8": "emdm-a2m-test.int8.onnx", "fp16": "emdm-a2m-test.fp16.onnx"}
    full = (exported / "emdm-a2m-test.onnx").stat().st_size
    assert (exported / "emdm-a2m-test.int8.onnx").stat().st_size < 0.5 * full
    assert (exported / "emdm-a2m-test.fp16.onnx").stat().st_size < 0.75 * full
    assert e["variantRelErr"]["int8"] < 0.5 and e["variantRelErr"]["fp16"] < 0.02
    for f in e["files"]:
        assert man["files"][f]["bytes"] == (exported / f).stat().st_size
    sch = make_schedule(10)
    np.testing.assert_allclose(e["schedules"]["10"]["coef1"], sch.coef1, atol=1e-8)
    np.testing.assert_allclose(e["schedules"]["10"]["sigma"], sch.sigma, atol=1e-8)
    assert e["supportedSteps"] == [1, 2, 4, 5, 8, 10] and e["defaultSteps"] == 10
    assert e["training"]["steps"] == 3
    _, meta, _ = load_generator(checkpoint)
    mean, std = read_meanstd(exported / e["meanStd"])
    np.testing.assert_allclose(mean, meta["mean"], rtol=1e-6)
    np.testing.assert_allclose(std, meta["std"], rtol=1e-6)


def test_missing_checkpoint_is_named(tmp_path):
    from emdm.export import ExportError

    with pytest.raises(ExportError, match="nope.pt"):
        load_generator(tmp_path / "nope.pt")


def test_export_keeps_batch_one_and_long_inputs_working(checkpoint, tmp_path):
    G, _, _ = load_generator(checkpoint)
    path = export_onnx(G, tmp_path / "g.onnx")
    errs = parity(G, path, cases=((1, 196), (5, 3)))
    assert max(errs.values()) <= 1e-4


def test_guidance_min_time_is_written_and_kept_by_a_re_export(checkpoint, tmp_path, capsys):
    def entry():
        return json.loads((tmp_path / "manifest.json").read_text())["models"]["m"]

    base = ["--ckpt", str(checkpoint), "--name", "m", "--out", str(tmp_path), "--variants", ""]
    assert export_main(base + ["--guidance-min-time", "0.55"]) == 0
    assert entry()["guidanceMinTime"] == 0.55
    assert export_main(base) == 0                            # a re-export keeps the chosen threshold
    assert entry()["guidanceMinTime"] == 0.55
    assert export_main(base + ["--guidance-min-time", "-1"]) == 2
    assert "--guidance-min-time must be a finite time ≥ 0" in capsys.readouterr().err


def test_x0_smoothing_is_written_and_kept_by_a_re_export(checkpoint, tmp_path, capsys):
    def entry():
        return json.loads((tmp_path / "manifest.json").read_text())["models"]["m"]

    base = ["--ckpt", str(checkpoint), "--name", "m", "--out", str(tmp_path), "--variants", ""]
    assert export_main(base + ["--x0-smoothing", "1"]) == 0
    assert entry()["x0Smoothing"] == 1.0
    assert export_main(base) == 0                            # a re-export keeps the chosen smoothing
    assert entry()["x0Smoothing"] == 1.0
    assert export_main(base + ["--x0-smoothing", "0"]) == 0  # 0 turns it off: the field goes
    assert "x0Smoothing" not in entry()
    assert export_main(base + ["--x0-smoothing", "nan"]) == 2
    assert "--x0-smoothing must be a finite σ ≥ 0 in frames" in capsys.readouterr().err


def _one_error_line(capsys) -> str:
    err = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("W")]  # torch warnings
    assert len(err) == 1 and err[0].startswith("error: ") and "Traceback" not in err[0], err
    return err[0]


@pytest.mark.parametrize("name", ["../../x", "a/b", "..", ".", "", "a\\b", "x" * 101])
def test_a_name_that_is_not_a_model_id_writes_nothing(checkpoint, tmp_path, capsys, name):
    out = tmp_path / "a" / "b" / "models"
    assert export_main(["--ckpt", str(checkpoint), "--name", name, "--out", str(out), "--variants", ""]) == 2
    assert "--name" in _one_error_line(capsys)
    assert [p for p in tmp_path.rglob("*")] == [], "something was written"


def test_nan_weights_are_never_exported(checkpoint, tmp_path, capsys):
    """A checkpoint whose EMA weights are NaN: refused before anything is written (its parity error, NaN, would pass a
    `worst > tolerance` check), the manifest left as it was."""
    import torch

    from emdm.checkpoints import atomic_save

    st = torch.load(checkpoint, weights_only=True)
    for v in st["G_ema"].values():
        if v.is_floating_point():
            v.fill_(float("nan"))
    atomic_save(st, tmp_path / "nan.pt")
    out = tmp_path / "models"
    assert export_main(["--ckpt", str(tmp_path / "nan.pt"), "--name", "m", "--out", str(out), "--variants", ""]) == 2
    assert "holds NaN/Infinity; refusing to export" in _one_error_line(capsys)
    assert not out.exists() or list(out.iterdir()) == []


def test_a_nan_parity_error_fails_the_export_and_leaves_no_file(checkpoint, tmp_path, capsys, monkeypatch):
    import emdm.export as ex

    monkeypatch.setattr(ex, "parity", lambda G, path: {"1x1": 1e-6, "1x60": float("nan")})
    out = tmp_path / "models"
    assert export_main(["--ckpt", str(checkpoint), "--name", "m", "--out", str(out), "--variants", ""]) == 2
    assert "ONNX differs from PyTorch by nan, not ≤ --tolerance" in _one_error_line(capsys)
    assert list(out.iterdir()) == [], "a file of the failed export was left"


@pytest.mark.parametrize("content, expected", [
    (b'{"schema": 1, "models": {"m": \xff\xfe}}', r"manifest\.json: not UTF-8 text \(byte 30\)"),
    (b"\x00\x01 not json", r"manifest\.json:1:1: invalid JSON"),
    (b"[1, 2]", r"manifest\.json: expected a JSON object, got a list"),
    (b'{"schema": 1, "models": NaN}', r"manifest\.json: invalid JSON: NaN is not a JSON number"),
    (b"[" * 100000, r"manifest\.json: invalid JSON"),
])
def test_an_unreadable_manifest_in_out_is_one_line(checkpoint, tmp_path, capsys, content, expected):
    import re

    (tmp_path / "manifest.json").write_bytes(content)
    assert export_main(["--ckpt", str(checkpoint), "--name", "m", "--out", str(tmp_path), "--variants", ""]) == 2
    assert re.search(expected, _one_error_line(capsys))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["manifest.json"]

def test_guidance_is_written_and_kept_by_a_re_export(checkpoint, tmp_path, capsys):
    def entry():
        return json.loads((tmp_path / "manifest.json").read_text())["models"]["m"]

    base = ["--ckpt", str(checkpoint), "--name", "m", "--out", str(tmp_path), "--variants", ""]
    assert export_main(base) == 0                            # a first export: the default scale
    assert entry()["guidance"] == 2.5
    assert export_main(base + ["--guidance", "1.5"]) == 0
    assert entry()["guidance"] == 1.5
    assert export_main(base) == 0                            # a re-export keeps the chosen scale
    assert entry()["guidance"] == 1.5
    assert export_main(base + ["--guidance", "inf"]) == 2
    assert "--guidance must be a finite scale in 0..20" in capsys.readouterr().err
    assert entry()["guidance"] == 1.5                        # nothing written on bad input


def test_shipped_weights_name_the_run_s_files_by_name_only(checkpoint, tmp_path):
    """--ship-weights writes <name>.weights.f16.pt for --init-weights; its meta keeps the run's options but not the
    folders of the machine it ran on (emdm.checkpoints.portable_meta)."""
    from emdm.checkpoints import load_weights_file

    out = tmp_path / "m"
    assert export_main(["--ckpt", str(checkpoint), "--name", "emdm-a2m-test", "--out", str(out), "--variants", "",
                        "--ship-weights"]) == 0
    meta = load_weights_file(out / "emdm-a2m-test.weights.f16.pt")["meta"]
    assert meta["args"]["out"] == checkpoint.parent.name and meta["args"]["data"] == meta["data"]["path"]
    assert "/" not in meta["args"]["data"] and "/" not in meta["data"]["path"]
    assert json.loads((out / "manifest.json").read_text())["models"]["emdm-a2m-test"]["trainingWeights"] == \
        "emdm-a2m-test.weights.f16.pt"


def test_an_export_prints_its_figures_not_the_exporters_noise(checkpoint, tmp_path):
    """torch's dynamo exporter logged one line per torchvision operator it skipped (torchvision is not installed, and
    no model needs it) and onnxruntime's quantiser asked for a pre-processing step: 8 lines of noise around the
    parity and int8 figures. A fresh process, as a user runs it (both print once per process)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    scripts = str(Path(__file__).resolve().parents[2] / "scripts")
    env = {**os.environ, "PYTHONPATH": scripts + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = subprocess.run([sys.executable, "-m", "emdm.export", "--ckpt", str(checkpoint), "--name", "emdm-a2m-quiet",
                        "--out", str(tmp_path), "--variants", "int8"], env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    out = r.stdout + r.stderr
    assert "parity max abs err" in out and "max abs err / output std" in out, out
    assert "torchvision" not in out and "pre-processing before quantization" not in out, out
