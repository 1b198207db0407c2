"""scripts/gpu/train-all.sh, the recipe of RESULTS.md's models, runs end to end (on the CPU, tiny flags through
EMDM_TRAIN_EXTRA) on a synthetic dataset: the probe, the horizons it sets, five runs and their weight files."""

import csv
import os
import subprocess
import sys

import torch

from emdm import paths
from model_synth_data import write_synthetic_dataset

SMOKE = "--device cpu --preset tiny --batch 2 --d-width 32 --threads 1 --stop-at 2 --log-every 1"


def test_train_all_runs_the_five_generators(tmp_path):
    data = write_synthetic_dataset(tmp_path / "ds", n_clips=8)
    runs = tmp_path / "runs"
    env = {**os.environ, "PYTHON": sys.executable, "EMDM_TRAIN_EXTRA": SMOKE}
    out = subprocess.run(["bash", str(paths.REPO_ROOT / "scripts/gpu/train-all.sh"), str(data), str(runs), "1"],
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    expect = {"t2m": ("text", "ddgan", 100.0), "a2m": ("action", "ddgan", 100.0), "t2m-ddim": ("text", "diffusion", 100.0),
              "t2m-naive": ("text", "ddgan", 0.0), "t2m-nodcond": ("text", "ddgan", 100.0)}
    for name, (task, objective, geo) in expect.items():
        with open(runs / name / "log.csv") as f:
            rows = list(csv.DictReader(f))
        assert rows and int(rows[-1]["step"]) == 2, name
        st = torch.load(runs / f"{name}.pt", weights_only=True)
        args = st["meta"]["args"]
        assert (st["meta"]["task"], args["objective"], args["geo_weight"]) == (task, objective, geo), name
        assert args["d_cond"] == (name != "t2m-naive" and name != "t2m-nodcond"), name
        assert args["w_bone"] == 0.0 and args["random_crop"] == 0.3 and args["ema"] == 0.999, name
    assert "train-all: done" in out.stdout


def test_train_balanced_runs_text_action_and_ddim_one_after_another(tmp_path):
    """scripts/gpu/train-balanced.sh (issue 12's retraining) on the CPU: three runs on the new loop, each probed
    and then given its horizon, with α, the batch, the LR scaling and the rigidity weight in their meta."""
    data = write_synthetic_dataset(tmp_path / "ds", n_clips=8)
    runs = tmp_path / "runs"
    env = {**os.environ, "PYTHON": sys.executable, "EMDM_TRAIN_EXTRA": SMOKE, "AMP": "off", "COMPILE": "0",
           "ALPHA": "0.25", "BATCH": "3"}
    out = subprocess.run(["bash", str(paths.REPO_ROOT / "scripts/gpu/train-balanced.sh"), str(data), str(runs), "1"],
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    expect = {"t2m-bal": ("text", "ddgan"), "a2m-bal": ("action", "ddgan"), "t2m-ddim-bal": ("text", "diffusion")}
    for name, (task, objective) in expect.items():
        with open(runs / name / "log.csv") as f:
            rows = list(csv.DictReader(f))
        assert rows and int(rows[-1]["step"]) == 2, name
        st = torch.load(runs / f"{name}.pt", weights_only=True)
        args = st["meta"]["args"]
        assert (st["meta"]["task"], args["objective"]) == (task, objective), name
        assert args["balance_alpha"] == 0.25 and st["meta"]["sampling"]["balance_alpha"] == 0.25, name
        assert args["lr_scale"] == "sqrt" and args["w_bone"] == 300.0 and args["random_crop"] == 0.3, name
        assert args["batch"] == 2 and args["amp"] == "off" and not args["compile"], name   # EMDM_TRAIN_EXTRA wins
        assert f"{name}: " in out.stdout and "-> --steps" in out.stdout
    assert "train-balanced: done" in out.stdout


def test_editing_time_times_the_weights_and_the_int8_file_in_one_call(tmp_path):
    """scripts/gpu/editing-time.sh (issue 14's time bar in one device call), on the CPU with tiny flags: the shipped
    model's PyTorch weights (cuda there, cpu here) and its int8 file on 1, 2, 4 and 8 ORT threads, each a JSON that
    emdm.eval.report reads."""
    from emdm.eval.report import load_results

    env = {**os.environ, "PYTHON": sys.executable, "EMDM_TIME_TIMELINES": "1", "EMDM_TIME_EXTRA": "--steps 1 --seconds 1"}
    out = subprocess.run(["bash", str(paths.REPO_ROOT / "scripts/gpu/editing-time.sh"), str(tmp_path)],
                         env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    device = "cuda" if torch.cuda.is_available() else "cpu"
    got = {r["runtime"]: r for r in load_results(tmp_path)}
    assert set(got) == {f"pytorch-{device}", "onnxruntime-cpu-int8"}
    assert list(got[f"pytorch-{device}"]["time"]["by_threads"]) == ["1"]
    assert list(got["onnxruntime-cpu-int8"]["time"]["by_threads"]) == ["1", "2", "4", "8"]
    assert all(r["steps"] == 1 and r["segment_seconds"] == 1 for r in got.values())
    assert "editing-time: done" in out.stdout
