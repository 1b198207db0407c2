"""Resuming a run goes on only from what it stopped at: a checkpoint whose weights are NaN, or one trained on another
dataset than --data, is refused (one line, exit 2); log.csv holds each logged step once after a kill; a checkpoint's
checksum catches a flipped byte that torch.load would take."""

import csv
import shutil
import zipfile

import pytest
import torch

from emdm import checkpoints, paths
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress", "--task", "action"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def _last_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err[-2000:]
    return err.strip().splitlines()[-1]


def test_resuming_from_nan_weights_is_refused(dataset, tmp_path, capsys):
    out = tmp_path / "run"
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "4", "--stop-at", "2", *TINY]) == 0
    st = torch.load(out / "ckpt.pt", weights_only=True)
    next(v for v in st["G_ema"].values() if v.is_floating_point()).view(-1)[0] = float("nan")
    checkpoints.atomic_save(st, out / "ckpt.pt")
    capsys.readouterr()
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "4", *TINY]) == 2
    line = _last_line(capsys)
    assert line.startswith(f"emdm.train: {out / 'ckpt.pt'}: 'G_ema' weight ") and "holds NaN/Infinity" in line, line
    assert torch.load(out / "ckpt.pt", weights_only=True)["step"] == 2           # left as it was


def test_resuming_on_another_dataset_is_refused_unless_asked(dataset, tmp_path, capsys):
    other = write_synthetic_dataset(tmp_path / "other", n_clips=12, seed=5)
    out = tmp_path / "run"
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "4", "--stop-at", "2", *TINY]) == 0
    meta = torch.load(out / "ckpt.pt", weights_only=True)["meta"]
    assert meta["data"]["path"] == str(dataset) and len(meta["data"]["sha256"]) == 64
    capsys.readouterr()
    assert train_main(["--data", str(other), "--out", str(out), "--steps", "4", *TINY]) == 2
    line = _last_line(capsys)
    assert f"trained on {dataset} (sha256 " in line and f"but --data is {other} (sha256" in line, line
    assert "--allow-other-data" in line
    assert train_main(["--data", str(other), "--out", str(out), "--steps", "3", "--allow-other-data", *TINY]) == 0
    assert torch.load(out / "ckpt.pt", weights_only=True)["step"] == 3


def _steps(log) -> list[int]:
    with open(log, newline="") as f:
        return [int(r["step"]) for r in csv.DictReader(f)]


def test_log_rows_after_the_checkpoint_are_not_repeated_on_resume(dataset, tmp_path):
    """Killed after logging steps 3..4 but before checkpointing them: the resumed run logs them again, once."""
    out = tmp_path / "run"
    base = ["--data", str(dataset), "--out", str(out), "--steps", "6", "--log-every", "1", *TINY]
    assert train_main([*base, "--stop-at", "2"]) == 0
    shutil.copy(out / "ckpt.pt", tmp_path / "step2.pt")
    assert train_main([*base, "--stop-at", "4"]) == 0
    assert _steps(out / "log.csv") == [1, 2, 3, 4]
    shutil.copy(tmp_path / "step2.pt", out / "ckpt.pt")          # the kill: steps 3, 4 logged, not checkpointed
    assert train_main(base) == 0
    assert _steps(out / "log.csv") == [1, 2, 3, 4, 5, 6]


def _flip_tensor_byte(path, member_suffix="data/0", at=5):
    """Flip one byte inside a tensor's stored bytes (a zip member torch.load reads without a check)."""
    with zipfile.ZipFile(path) as z:
        info = next(i for i in z.infolist() if i.filename.endswith(member_suffix))
    raw = bytearray(path.read_bytes())
    name_len = int.from_bytes(raw[info.header_offset + 26:info.header_offset + 28], "little")
    extra_len = int.from_bytes(raw[info.header_offset + 28:info.header_offset + 30], "little")
    raw[info.header_offset + 30 + name_len + extra_len + at] ^= 0x40
    path.write_bytes(bytes(raw))


def test_a_flipped_byte_in_a_checkpoint_is_refused_naming_the_file(dataset, tmp_path, capsys):
    out = tmp_path / "run"
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "2", "--weights-out",
                       str(tmp_path / "w.pt"), *TINY]) == 0
    for f in (out / "ckpt.pt", tmp_path / "w.pt"):
        checkpoints.load_file(f)                                            # the file as written reads
        _flip_tensor_byte(f)
        torch.load(f, weights_only=True)                                    # torch itself takes the flipped byte
        with pytest.raises(checkpoints.CheckpointError, match=rf"^{f}: checksum mismatch: its contents differ"):
            checkpoints.load_file(f)
    capsys.readouterr()
    assert train_main(["--data", str(dataset), "--out", str(out), "--steps", "3", *TINY]) == 2
    assert f"{out / 'ckpt.pt'}: checksum mismatch" in _last_line(capsys)


def test_a_weights_file_without_its_own_checksum_is_checked_against_the_manifest(tmp_path):
    """A *.weights.f16.pt written before files carried a checksum of their own (the shipped ones did until GPU slice
    5) is checked against the sha256 that the manifest.json beside it lists."""
    import json

    from emdm import manifest as mf

    name = "emdm-a2m-web.weights.f16.pt"
    st = torch.load(paths.MODELS_DIR / name, weights_only=True)
    del st[checkpoints.CHECKSUM_KEY]
    torch.save(st, tmp_path / name)
    man = json.loads((paths.MODELS_DIR / "manifest.json").read_text())
    man["files"][name] = {"bytes": (tmp_path / name).stat().st_size, "sha256": mf.sha256_file(tmp_path / name)}
    (tmp_path / "manifest.json").write_text(json.dumps(man))
    st = checkpoints.load_weights_file(tmp_path / name)
    assert checkpoints.CHECKSUM_KEY not in st and st["G_ema"]
    _flip_tensor_byte(tmp_path / name)
    torch.load(tmp_path / name, weights_only=True)
    with pytest.raises(checkpoints.CheckpointError, match=rf"{name}: sha256 differs from .*manifest\.json"):
        checkpoints.load_weights_file(tmp_path / name)
