"""Checkpoints are never poisoned and never trusted: a non-finite loss stops the run (exit 2, naming the step and
the term) without writing over the last good ckpt.pt; a corrupt file, one holding code objects or one of another
model answers one line naming the file (exit 2); every read is torch.load(weights_only=True)."""

import pickle

import pytest
import torch

from emdm import checkpoints
from emdm.model import objectives
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress", "--task", "action"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def test_nan_loss_stops_without_overwriting_the_last_good_checkpoint(dataset, tmp_path, monkeypatch, capsys):
    good = tmp_path / "good"
    assert train_main(["--data", str(dataset), "--out", str(good), "--steps", "5", "--stop-at", "2", *TINY]) == 0
    calls = {"n": 0}
    real = objectives.masked_mse

    def poisoned(a, b, mask, scale=None):           # the recon term of the 3rd step goes NaN
        calls["n"] += 1
        out = real(a, b, mask, scale)
        return out * float("nan") if calls["n"] == 3 else out
    monkeypatch.setattr(objectives, "masked_mse", poisoned)
    out = tmp_path / "run"
    rc = train_main(["--data", str(dataset), "--out", str(out), "--steps", "5", "--ckpt-every", "2", "--log-every", "100",
                     "--weights-out", str(tmp_path / "w.pt"), *TINY])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 2
    assert err.startswith("emdm.train: step 3: loss term recon is not finite (then loss_g); stopped,"), err
    assert f"{out / 'ckpt.pt'} left as it was (step 2)" in err
    st = torch.load(out / "ckpt.pt", weights_only=True)
    ref = torch.load(good / "ckpt.pt", weights_only=True)
    assert st["step"] == 2
    for key in ("G", "G_ema", "D"):
        for name, v in st[key].items():
            assert torch.equal(v, ref[key][name]), f"{key}.{name}: ckpt.pt is not the good step-2 checkpoint"
    assert not (tmp_path / "w.pt").exists()           # nor are poisoned weights shipped


def test_nan_is_caught_between_log_rows_before_a_checkpoint(dataset, tmp_path, monkeypatch, capsys):
    """The flag lives on the device and is read before every save, not only every --log-every steps."""
    calls = {"n": 0}
    real = objectives.masked_mse

    def poisoned(a, b, mask, scale=None):
        calls["n"] += 1
        return real(a, b, mask, scale) * (float("inf") if calls["n"] == 2 else 1.0)
    monkeypatch.setattr(objectives, "masked_mse", poisoned)
    rc = train_main(["--data", str(dataset), "--out", str(tmp_path / "r"), "--steps", "3", "--log-every", "1000",
                     "--ckpt-every", "3", *TINY])
    assert rc == 2 and "step 2: loss term recon is not finite" in capsys.readouterr().err
    assert not (tmp_path / "r" / "ckpt.pt").exists()


class Payload:
    def __reduce__(self):
        return (print, ("code ran from a checkpoint",))


@pytest.mark.parametrize("case", ["garbage", "code", "other-model", "truncated"])
def test_unusable_checkpoint_answers_one_line(dataset, tmp_path, capsys, case):
    out = tmp_path / "run"
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "1", *TINY]) == 0
    ck = out / "ckpt.pt"
    if case == "garbage":
        ck.write_bytes(b"not a checkpoint at all")
    elif case == "truncated":
        ck.write_bytes(ck.read_bytes()[:1000])
    elif case == "code":
        torch.save({"meta": {}, "x": Payload()}, ck)
    capsys.readouterr()
    flags = ["--preset", "web"] if case == "other-model" else []
    rc = train_main(["--data", str(dataset), "--out", str(out), "--steps", "2", *TINY, *flags])
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2 and "code ran" not in cap.out + cap.err
    assert lines[-1].startswith(f"emdm.train: {ck}: ") and "Traceback" not in cap.err
    want = {"garbage": "cannot read", "truncated": "cannot read", "code": "holds objects other than tensors",
            "other-model": "another model/task/objective (generator"}[case]
    assert want in lines[-1], lines[-1]


def test_export_and_init_weights_read_with_weights_only(dataset, tmp_path):
    from emdm.export import ExportError, load_generator

    bad = tmp_path / "bad.pt"
    torch.save({"meta": {}, "step": 1, "G_ema": {}, "x": Payload()}, bad)
    with pytest.raises(ExportError, match="holds objects other than tensors"):
        load_generator(bad)
    with pytest.raises(checkpoints.CheckpointError, match="bad.pt: holds objects"):
        checkpoints.load_weights_file(bad)
    (tmp_path / "p.pt").write_bytes(pickle.dumps({"a": 1}))
    with pytest.raises(checkpoints.CheckpointError, match="p.pt: cannot read"):
        checkpoints.load_file(tmp_path / "p.pt")
