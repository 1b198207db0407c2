"""A broken dataset is one line and exit 2 in the CLIs that load one (issue 29): emdm.train and
emdm.eval.coverage used to let emdm.data.dataset.DatasetError escape as a traceback."""

from pathlib import Path

import pytest

from emdm import train
from emdm.eval import coverage
from test_bad_input import _prepare
from test_data_prepare import _user_folder


def _broken_dataset(tmp_path, how: str) -> Path:
    root, jm = _user_folder(tmp_path)
    ds = tmp_path / "ds"
    assert _prepare(tmp_path, root, jm) == 0
    if how == "no split file":
        for f in ("train.txt", "test.txt"):
            (ds / f).unlink()
    elif how == "Mean.npy not an array":
        (ds / "Mean.npy").write_text("junk")
    return ds


@pytest.mark.parametrize("how", ["no split file", "Mean.npy not an array"])
def test_train_on_a_broken_dataset_is_one_line_and_exit_2(tmp_path, how, capsys):
    ds = _broken_dataset(tmp_path, how)
    capsys.readouterr()
    rc = train.main(["--data", str(ds), "--task", "action", "--out", str(tmp_path / "run"), "--steps", "1",
                     "--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith("emdm.train: ") and str(ds) in err[-1], err


@pytest.mark.parametrize("how", ["no split file", "metadata.csv without action_id"])
def test_coverage_on_a_broken_dataset_is_one_line_and_exit_2(tmp_path, how, capsys):
    ds = _broken_dataset(tmp_path, how if how == "no split file" else "")
    if how != "no split file":
        (ds / "metadata.csv").write_text("id,source\nx,y\n")
    capsys.readouterr()
    rc = coverage.main(["--model", "emdm-t2m-web", "--dataset", str(ds), "--out", str(tmp_path / "cov.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith("error: ") and str(ds) in err[-1], err


def test_train_with_a_mistyped_text_encoder_is_one_line_naming_it(tmp_path, capsys):
    """`--encoder all-MiniLM-L6-v3` was a traceback from deep in the caption embedding; now one line, exit 2, the
    known encoders named, and no run folder left behind."""
    ds = _broken_dataset(tmp_path, "")
    capsys.readouterr()
    run = tmp_path / "run"
    rc = train.main(["--data", str(ds), "--task", "text", "--encoder", "all-MiniLM-L6-v3", "--out", str(run),
                     "--steps", "1", "--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1",
                     "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith("emdm.train: text encoder 'all-MiniLM-L6-v3'"), err
    assert "known: all-MiniLM-L6-v2" in err[-1] and not run.exists(), err
