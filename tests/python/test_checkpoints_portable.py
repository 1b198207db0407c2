"""A weights file that leaves its machine carries no machine's folders (emdm.checkpoints.portable_meta): exports'
--ship-weights and ``python -m emdm.checkpoints portable``; the shipped files are checked in test_shipped_models."""

from pathlib import Path

import torch

from emdm.checkpoints import (PATH_ARGS, load_weights_file, main as checkpoints_main, portable_meta,
                              save_weights_file)
from emdm.train_options import build_parser


def test_path_args_are_every_path_valued_option_of_train():
    dests = {a.dest for a in build_parser()._actions if a.type is Path}
    assert dests == set(PATH_ARGS)


META = {"task": "text", "args": {"data": "/tmp/tmp.Abc/dataset", "out": "/tmp/tmp.Abc/runs/t2m-base",
                                 "init_weights": "/home/someone/repo/.lease/init-t2m.pt", "weights_out": None,
                                 "encoder": "all-MiniLM-L6-v2", "betas": [0.5, 0.9], "geo_weight": 100.0},
        "data": {"path": "/tmp/tmp.Abc/dataset", "split": "train", "sha256": "ab" * 32}, "dataset": "dataset"}


def test_portable_meta_keeps_names_only_and_leaves_the_rest():
    out = portable_meta(META)
    assert out["args"] == {**META["args"], "data": "dataset", "out": "t2m-base", "init_weights": "init-t2m.pt"}
    assert out["data"] == {**META["data"], "path": "dataset"}
    assert META["args"]["data"] == "/tmp/tmp.Abc/dataset"                   # the given meta is not changed
    assert portable_meta({"task": "action"}) == {"task": "action"}          # a meta without either: as it was


def test_portable_command_rewrites_in_place_keeping_weights_and_dtype(tmp_path, capsys):
    f = tmp_path / "w.pt"
    state = {"a": torch.randn(3, 4), "b": torch.arange(5.0)}
    save_weights_file(f, state, step=7, wall=1.5, meta=META, last_losses={"recon": 0.5}, dtype="float16")
    assert checkpoints_main(["portable", str(f), str(f)]) == 0
    assert "float16" in capsys.readouterr().out
    st = load_weights_file(f)
    assert st["meta"]["args"]["init_weights"] == "init-t2m.pt" and st["meta"]["data"]["path"] == "dataset"
    assert st["step"] == 7 and st["wall"] == 1.5 and st["last_losses"] == {"recon": 0.5}
    raw = torch.load(f, weights_only=True)["G_ema"]
    assert all(raw[k].dtype == torch.float16 and torch.equal(raw[k], state[k].half()) for k in state)


def test_portable_command_names_a_file_it_cannot_read(tmp_path, capsys):
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"nope")
    assert checkpoints_main(["portable", str(bad), str(tmp_path / "out.pt")]) == 2
    err = capsys.readouterr().err
    assert "bad.pt" in err and not (tmp_path / "out.pt").exists()
