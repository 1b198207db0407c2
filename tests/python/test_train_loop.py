"""Training runs end to end on a tiny synthetic dataset in the HumanML3D layout (written by the test)."""

import csv
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from emdm.train import main as train_main
from model_synth_data import fake_text_encoder, write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--log-every", "1", "--no-progress"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def read_log(run: Path) -> list[dict]:
    with open(run / "log.csv") as f:
        return list(csv.DictReader(f))


def test_action_ddgan_run_logs_finite_losses_and_checkpoints(dataset, tmp_path):
    out = tmp_path / "run"
    train_main(["--data", str(dataset), "--task", "action", "--out", str(out), "--steps", "4", *TINY])
    rows = read_log(out)
    assert [int(r["step"]) for r in rows] == [1, 2, 3, 4]
    for r in rows:
        for k in ("loss_d", "g_adv", "recon", "pos", "vel", "foot"):
            assert float(r[k]) == float(r[k]) and abs(float(r[k])) < 1e6, (k, r)
    assert rows[0]["r1"] != ""                         # lazy R1 on step 0
    st = torch.load(out / "ckpt.pt", weights_only=True)
    assert st["step"] == 4 and st["meta"]["condition"]["labels"] == ["walk", "wave", "turn"]
    assert any((st["G"][k] != st["G_ema"][k]).any() for k in st["G"])   # EMA is a separate average


def test_text_run_uses_cached_caption_embeddings(dataset, tmp_path, monkeypatch):
    fake_text_encoder(monkeypatch, dim=16)
    out = tmp_path / "run"
    train_main(["--data", str(dataset), "--task", "text", "--out", str(out), "--steps", "2", *TINY])
    assert list(out.glob("text-*.npy"))
    st = torch.load(out / "ckpt.pt", weights_only=True)
    assert st["meta"]["condition"] == {"type": "text", "encoder": "all-MiniLM-L6-v2", "dim": 16}


@pytest.mark.parametrize("flags", [["--objective", "diffusion"], ["--geo-weight", "0", "--no-d-cond"]])
def test_baseline_flags_train(dataset, tmp_path, flags):
    out = tmp_path / "run"
    train_main(["--data", str(dataset), "--task", "action", "--out", str(out), "--steps", "2", *TINY, *flags])
    rows = read_log(out)
    assert len(rows) == 2
    if "diffusion" in flags:
        assert rows[0]["loss_d"] == "" and float(rows[0]["recon"]) > 0
    else:
        assert rows[0]["recon"] == "" and float(rows[0]["g_adv"]) > 0


def test_resume_is_exact(dataset, tmp_path):
    straight, split = tmp_path / "a", tmp_path / "b"
    common = ["--data", str(dataset), "--task", "action", "--steps", "6", "--random-crop", "0.5", *TINY]
    train_main([*common, "--out", str(straight)])
    train_main([*common, "--out", str(split), "--stop-at", "3"])
    assert torch.load(split / "ckpt.pt", weights_only=True)["step"] == 3
    train_main([*common, "--out", str(split)])                       # resumes from step 3
    a = torch.load(straight / "ckpt.pt", weights_only=True)
    b = torch.load(split / "ckpt.pt", weights_only=True)
    assert b["step"] == 6
    for key in ("G", "G_ema", "D"):
        for name in a[key]:
            assert torch.equal(a[key][name], b[key][name]), f"{key}.{name} differs after resume"
    assert [r["loss_g"] for r in read_log(straight)][3:] == [r["loss_g"] for r in read_log(split)][3:]


def test_ddp_two_gloo_processes(dataset, tmp_path):
    out = tmp_path / "ddp"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    cmd = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", "-m", "emdm.train",
           "--data", str(dataset), "--task", "action", "--out", str(out), "--steps", "3", "--device", "cpu", *TINY]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=240, env=env)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "2 replicas in sync" in res.stderr
    st = torch.load(out / "ckpt.pt", weights_only=True)
    assert st["step"] == 3 and st["meta"]["world"] == 2 and len(st["rng"]) == 2


def test_missing_dataset_names_the_file(tmp_path, capsys):
    rc = train_main(["--data", str(tmp_path), "--task", "action", "--out", str(tmp_path / "r"), "--steps", "1", *TINY])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and "\n" not in err and "train.txt: split file not found" in err, err


def test_weights_out_and_init_weights_continue_a_run(dataset, tmp_path, capsys):
    from emdm.export import load_generator

    first, second = tmp_path / "a", tmp_path / "b"
    common = ["--data", str(dataset), "--task", "action", *TINY]
    train_main([*common, "--out", str(first), "--steps", "3", "--weights-out", str(tmp_path / "a.pt"),
                "--weights-dtype", "float16"])
    slim = torch.load(tmp_path / "a.pt", weights_only=True)
    assert set(slim) == {"step", "wall", "meta", "last_losses", "G_ema", "content_sha256"} and slim["step"] == 3
    assert all(v.dtype == torch.float16 for v in slim["G_ema"].values())
    G, meta, summary = load_generator(tmp_path / "a.pt")               # what export/sample/eval read
    ema = torch.load(first / "ckpt.pt", weights_only=True)["G_ema"]
    for k, v in G.state_dict().items():
        assert v.dtype == torch.float32 and torch.allclose(v, ema[k], atol=1e-2, rtol=1e-3), k
    train_main([*common, "--out", str(second), "--steps", "2", "--init-weights", str(tmp_path / "a.pt"),
                "--weights-out", str(tmp_path / "b.pt")])
    b = torch.load(tmp_path / "b.pt", weights_only=True)
    assert b["step"] == 2 and b["meta"]["init"]["steps"] == 3 and b["meta"]["init"]["runs"][0]["file"] == "a.pt"
    rc = train_main(["--data", str(dataset), "--task", "action", *TINY, "--objective", "diffusion",
                     "--out", str(tmp_path / "c"), "--steps", "1", "--init-weights", str(tmp_path / "a.pt")])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 2 and "a.pt: trained with another model/task/objective (objective 'ddgan', this run 'diffusion')" in err


def test_an_action_model_continued_keeps_its_labels_and_renumbers_the_dataset(dataset, tmp_path, capsys):
    """--init-weights of an action model: the run's one-hot inputs are the model's labels in the model's order (the
    dataset's actions renumbered to them); a dataset action the model does not know is refused, naming it."""
    from emdm.checkpoints import save_weights_file
    from emdm.train import Trainer
    from emdm.train_options import build_parser

    common = ["--data", str(dataset), "--task", "action", *TINY]
    assert train_main([*common, "--out", str(tmp_path / "a"), "--steps", "1",
                       "--weights-out", str(tmp_path / "a.pt")]) == 0
    st = torch.load(tmp_path / "a.pt", weights_only=True)
    assert st["meta"]["condition"]["labels"] == ["walk", "wave", "turn"]
    for name, labels in (("perm.pt", ["turn", "walk", "wave"]), ("other.pt", ["walk", "wave", "jump"])):
        meta = {**st["meta"], "condition": {**st["meta"]["condition"], "labels": labels}}
        save_weights_file(tmp_path / name, st["G_ema"], step=1, wall=0.0, meta=meta, last_losses={})
    args = build_parser().parse_args([*common, "--out", str(tmp_path / "b"), "--steps", "1",
                                      "--init-weights", str(tmp_path / "perm.pt")])
    plain = Trainer(build_parser().parse_args([*common, "--out", str(tmp_path / "c"), "--steps", "1"]))
    t = Trainer(args)
    assert t.ms.action_labels == ["turn", "walk", "wave"]
    # every clip keeps its action by name: walk 0 -> 1, wave 1 -> 2, turn 2 -> 0
    names = lambda tr: [tr.ms.action_labels[i] for i in tr.ms.actions]      # noqa: E731
    assert names(t) == names(plain) and list(t.ms.actions) != list(plain.ms.actions)
    assert "renumbered to the 3 labels of perm.pt" in capsys.readouterr().err
    t.dist.close(); plain.dist.close()
    rc = train_main([*common, "--out", str(tmp_path / "d"), "--steps", "1",
                     "--init-weights", str(tmp_path / "other.pt")])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 2 and "other.pt: its action model does not know this dataset's action(s) turn" in err, err


def test_a_text_model_continued_needs_its_own_encoder(dataset, tmp_path, monkeypatch, capsys):
    from emdm.checkpoints import save_weights_file

    fake_text_encoder(monkeypatch, dim=16)
    common = ["--data", str(dataset), "--task", "text", *TINY, "--steps", "1"]
    assert train_main([*common, "--out", str(tmp_path / "a"), "--weights-out", str(tmp_path / "a.pt")]) == 0
    st = torch.load(tmp_path / "a.pt", weights_only=True)
    meta = {**st["meta"], "condition": {**st["meta"]["condition"], "encoder": "another-encoder"}}
    save_weights_file(tmp_path / "b.pt", st["G_ema"], step=1, wall=0.0, meta=meta, last_losses={})
    assert train_main([*common, "--out", str(tmp_path / "c"), "--init-weights", str(tmp_path / "a.pt")]) == 0
    rc = train_main([*common, "--out", str(tmp_path / "d"), "--init-weights", str(tmp_path / "b.pt")])
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert rc == 2 and "b.pt: its text model reads 'another-encoder' embeddings" in err, err


def test_bf16_autocast_and_lr_scaling(dataset, tmp_path):
    out = tmp_path / "run"
    assert train_main(["--data", str(dataset), "--task", "action", "--out", str(out), "--steps", "2", *TINY,
                       "--amp", "bf16", "--lr-scale", "sqrt", "--lr-g", "4e-5", "--lr-d", "1e-4"]) == 0
    rows = read_log(out)
    assert all(abs(float(r["loss_g"])) < 1e6 for r in rows)
    st = torch.load(out / "ckpt.pt", weights_only=True)
    assert st["meta"]["lr"] == {"g": 1e-5, "d": 2.5e-5, "scale": 0.25}        # (4 / 64)^½ = 0.25
    assert all(v.dtype == torch.float32 for v in st["G"].values())           # weights stay float32 under autocast
