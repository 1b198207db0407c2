"""emdm.weights_from_onnx: a model's training weights read back from its exported ONNX file (the DDIM baseline
shipped without them, so no GPU slice could continue it), checked against the file's outputs before anything is
written."""

import json

import pytest
import torch

from emdm.checkpoints import load_weights_file
from emdm.export import main as export_main
from emdm.train import main as train_main
from emdm.weights_from_onnx import RecoverError, generator_from_onnx, main as recover_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress"]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    ds = write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)
    out = tmp_path_factory.mktemp("run")
    assert train_main(["--data", str(ds), "--task", "action", "--out", str(out), "--steps", "3", *TINY]) == 0
    return ds, out / "ckpt.pt"


@pytest.fixture()
def exported(trained, tmp_path):
    models = tmp_path / "models"
    assert export_main(["--ckpt", str(trained[1]), "--name", "emdm-a2m-test", "--out", str(models),
                        "--variants", ""]) == 0
    return models


def test_the_weights_read_back_are_the_trained_ones(trained, exported, capsys):
    ckpt = torch.load(trained[1], weights_only=True)
    entry = json.loads((exported / "manifest.json").read_text())["models"]["emdm-a2m-test"]
    assert "trainingWeights" not in entry
    G, worst = generator_from_onnx(exported / entry["onnx"], entry)
    assert worst < 1e-4
    for k, v in G.state_dict().items():
        assert torch.equal(v, ckpt["G_ema"][k]), k                     # every weight exactly, transposed ones too

    assert recover_main(["emdm-a2m-test", "--models-dir", str(exported)]) == 0
    assert "parity with the ONNX file" in capsys.readouterr().out
    man = json.loads((exported / "manifest.json").read_text())
    entry2 = man["models"]["emdm-a2m-test"]
    assert entry2["trainingWeights"] == "emdm-a2m-test.weights.f16.pt" and entry2["trainingWeights"] in entry2["files"]
    assert man["files"]["emdm-a2m-test.weights.f16.pt"]["bytes"] > 0
    st = load_weights_file(exported / "emdm-a2m-test.weights.f16.pt")
    assert st["meta"]["weights_dtype"] == "float16" and st["meta"]["task"] == "action"
    assert st["meta"]["recovered_from"]["onnx"] == entry["onnx"]
    assert st["meta"]["generator"] == ckpt["meta"]["generator"] and st["meta"]["condition"] == ckpt["meta"]["condition"]
    for k, v in st["G_ema"].items():
        assert torch.equal(v, ckpt["G_ema"][k].half().float()), k

    # a second time: nothing to do; and training continues from the file read back
    assert recover_main(["emdm-a2m-test", "--models-dir", str(exported)]) == 2
    assert "already ships training weights" in capsys.readouterr().err
    run = exported.parent / "cont"
    assert train_main(["--data", str(trained[0]), "--task", "action", "--out", str(run), "--steps", "1", *TINY,
                       "--init-weights", str(exported / "emdm-a2m-test.weights.f16.pt")]) == 0
    assert torch.load(run / "ckpt.pt", weights_only=True)["meta"]["init"]["runs"][-1]["file"] == \
        "emdm-a2m-test.weights.f16.pt"


def test_a_wrong_matching_is_caught_by_the_outputs(exported, monkeypatch):
    """The transposed weights are matched by shape in the order the graph uses them; were that order not the
    forward pass's (here: reversed, so the layers' same-shaped weights trade places), the rebuilt generator's
    outputs differ from the file's and nothing is returned."""
    import emdm.weights_from_onnx as W

    entry = json.loads((exported / "manifest.json").read_text())["models"]["emdm-a2m-test"]
    real = W._first_use
    monkeypatch.setattr(W, "_first_use", lambda graph: {k: -v for k, v in real(graph).items()})
    with pytest.raises(RecoverError, match="nothing written"):
        generator_from_onnx(exported / entry["onnx"], entry)


def test_bad_requests_are_named(exported, tmp_path, capsys):
    assert recover_main(["no-such-model", "--models-dir", str(exported)]) == 2
    assert "no model 'no-such-model'" in capsys.readouterr().err
    onnx_file = exported / "emdm-a2m-test.onnx"
    data = bytearray(onnx_file.read_bytes())
    data[-1] ^= 0xFF                                                       # one byte changed: not the file listed
    onnx_file.write_bytes(bytes(data))
    assert recover_main(["emdm-a2m-test", "--models-dir", str(exported)]) == 2
    err = capsys.readouterr().err
    assert "emdm-a2m-test.onnx" in err and "sha256" in err
    onnx_file.write_bytes(bytes(data[:1000]))                             # truncated: its size is not the one listed
    assert recover_main(["emdm-a2m-test", "--models-dir", str(exported)]) == 2
    err = capsys.readouterr().err
    assert "emdm-a2m-test.onnx" in err and "bytes" in err
    assert not (exported / "emdm-a2m-test.weights.f16.pt").exists()
    assert recover_main(["x", "--models-dir", str(tmp_path / "none")]) == 2
