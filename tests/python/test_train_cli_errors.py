"""emdm.train refuses a user's mistake before it writes anything: an unknown --preset or bad --supported-steps is an
argparse error (exit 2, usage line), a missing dataset, an --out that is a file or a --weights-out that is a folder
one line (exit 2); a run refused while it sets up leaves no --out folder it made (nor the caption cache it wrote
there), and never touches a folder that was there before. A finished run names its checkpoint (and weights file)."""

import pytest

from emdm.outdir import missing_folders, remove_made_folders
from emdm.train import main as train_main
from model_synth_data import fake_text_encoder, write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--log-every", "1", "--no-progress"]
FAST = ["--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress", "--steps", "1"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in err[0], err
    return err[0]


@pytest.mark.parametrize("flags, says", [(["--preset", "tinny"], "--preset: invalid choice: 'tinny'"),
                                         (["--preset", "tiny", "--supported-steps", "0,2"],
                                          "--supported-steps: expected positive integers, got '0,2'"),
                                         (["--preset", "tiny", "--supported-steps", "a"],
                                          "--supported-steps: expected positive integers, got 'a'")])
def test_a_bad_option_is_an_argparse_error_before_anything_is_read_or_written(dataset, tmp_path, capsys, flags, says):
    out = tmp_path / "runs" / "t-y"
    with pytest.raises(SystemExit) as e:
        train_main(["--data", str(dataset), "--task", "action", "--out", str(out), *FAST, *flags])
    err = capsys.readouterr().err
    assert e.value.code == 2 and err.startswith("usage: ") and says in err and "Traceback" not in err, err
    assert not (tmp_path / "runs").exists()


def test_a_missing_dataset_leaves_no_out_folder(tmp_path, capsys):
    out = tmp_path / "runs" / "t-x"
    rc = train_main(["--data", str(tmp_path / "nope"), "--task", "action", "--out", str(out), *TINY, "--steps", "1"])
    line = _one_line(capsys)
    assert rc == 2 and line.startswith("emdm.train: ") and "nope/train.txt: split file not found" in line, line
    assert not (tmp_path / "runs").exists()


def test_an_out_that_is_a_file_or_a_weights_out_that_is_a_folder_is_one_line(dataset, tmp_path, capsys):
    afile = tmp_path / "afile"
    afile.write_text("mine")
    rc = train_main(["--data", str(dataset), "--task", "action", "--out", str(afile), *TINY, "--steps", "1"])
    says = f"emdm.train: --out {afile}: is a file, not a folder; give a folder to write in"
    assert rc == 2 and _one_line(capsys) == says
    assert afile.read_text() == "mine"
    rc = train_main(["--data", str(dataset), "--task", "action", "--out", str(tmp_path / "r"), *TINY, "--steps", "1",
                     "--weights-out", str(tmp_path)])
    assert rc == 2 and _one_line(capsys) == f"emdm.train: --weights-out {tmp_path}: is a folder; give a file path"
    rc = train_main(["--data", str(dataset), "--task", "action", "--out", str(afile / "sub"), *TINY, "--steps", "1"])
    line = _one_line(capsys)
    assert rc == 2 and line.startswith(f"emdm.train: --out {afile / 'sub'}: {afile} is a file, not a folder"), line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["afile"]


def test_a_run_refused_after_caching_captions_leaves_no_folder_it_made(dataset, tmp_path, monkeypatch, capsys):
    """A text run whose --init-weights is an action model is refused after the captions are embedded (into --out):
    the folders it made go with the cache; a folder that was there stays, with what was in it."""
    fake_text_encoder(monkeypatch, dim=16)
    weights = tmp_path / "action.pt"
    assert train_main(["--data", str(dataset), "--task", "action", "--out", str(tmp_path / "a"), *TINY, "--steps", "1",
                       "--weights-out", str(weights)]) == 0
    capsys.readouterr()
    text = ["--data", str(dataset), "--task", "text", *TINY, "--steps", "1", "--init-weights", str(weights)]
    rc = train_main([*text, "--out", str(tmp_path / "new" / "t")])
    line = _one_line(capsys)
    assert rc == 2 and line.startswith(f"emdm.train: {weights}: ") and "another model/task/objective" in line, line
    assert not (tmp_path / "new").exists()
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    assert train_main([*text, "--out", str(mine)]) == 2
    assert (mine / "notes.txt").read_text() == "keep"


def test_a_finished_run_names_its_checkpoint_and_weights(dataset, tmp_path, capsys):
    out, weights = tmp_path / "run", tmp_path / "w" / "slim.pt"
    assert train_main(["--data", str(dataset), "--task", "action", "--out", str(out), *TINY, "--steps", "2",
                       "--weights-out", str(weights)]) == 0
    last = capsys.readouterr().out.strip().splitlines()[-1]
    assert last == f"checkpoint {out / 'ckpt.pt'} (step 2); weights {weights}"
    assert train_main(["--data", str(dataset), "--task", "action", "--out", str(out), *TINY, "--steps", "2"]) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1] == f"checkpoint {out / 'ckpt.pt'} (step 2)"   # resumed


def test_remove_made_folders_removes_only_what_the_run_made(tmp_path):
    made = missing_folders(tmp_path / "a" / "b" / "c")
    assert made == [tmp_path / "a" / "b" / "c", tmp_path / "a" / "b", tmp_path / "a"]
    (tmp_path / "a" / "b" / "c").mkdir(parents=True)
    (tmp_path / "a" / "b" / "c" / "text-x-1.npy").write_bytes(b"cache")
    remove_made_folders(made, ours=("text-*.npy",))
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "a" / "b" / "c").mkdir(parents=True)
    (tmp_path / "a" / "b" / "user.txt").write_text("not the run's")
    (tmp_path / "a" / "b" / "c" / "text-x-1.npy").write_bytes(b"cache")
    remove_made_folders(made, ours=("text-*.npy",))
    assert sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*")) == ["a", "a/b", "a/b/user.txt"]
    assert missing_folders(tmp_path) == []


@pytest.mark.parametrize("flags, width", [(["--preset", "tiny"], 64), (["--preset", "web"], 1024), ([], 1024),
                                          (["--preset", "tiny", "--d-width", "1024"], 1024)])
def test_the_discriminator_width_follows_the_preset_unless_given(flags, width):
    """--preset tiny with the released D (1024 wide) wrote a 1.3 GB checkpoint for a smoke-test model."""
    from emdm.train_options import build_parser, check_args

    parser = build_parser()
    args = parser.parse_args(["--task", "action", "--out", "x", *flags])
    check_args(parser, args)
    assert args.d_width == width


def test_a_discriminator_width_below_one_is_refused(capsys):
    with pytest.raises(SystemExit) as e:
        train_main(["--task", "action", "--out", "x", "--d-width", "0"])
    assert e.value.code == 2 and "--d-width 0: needs a width ≥ 1" in capsys.readouterr().err
