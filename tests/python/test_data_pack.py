"""emdm.data.pack: a prepared dataset survives pack -> unpack (what moves it to a GPU machine)."""

import tarfile

import numpy as np
import pytest

from emdm.data import pack
from emdm.data.dataset import DatasetError, load_split
from test_data_prepare import _run, _user_folder


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pack")
    root, jm = _user_folder(tmp)
    return _run(tmp, root, jm)


def test_round_trip_rebuilds_every_file(dataset, tmp_path):
    arc = tmp_path / "ds.tar.xz"
    assert pack.main([str(dataset), str(arc)]) == 0
    out = tmp_path / "again"
    assert pack.main(["--unpack", "--workers", "2", str(arc), str(out)]) == 0
    names = sorted(p.relative_to(dataset).as_posix() for p in dataset.rglob("*") if p.is_file())
    assert names == sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    ids = (dataset / "all.txt").read_text().split()
    assert any(i.startswith("M") for i in ids), "the fixture has mirrored clips"
    for cid in ids:
        a, b = np.load(dataset / "new_joints" / f"{cid}.npy"), np.load(out / "new_joints" / f"{cid}.npy")
        assert np.abs(a - b).max() < 5e-4, cid                 # 0.01 mm quantum; mirrors re-normalised
        fa, fb = np.load(dataset / "new_joint_vecs" / f"{cid}.npy"), np.load(out / "new_joint_vecs" / f"{cid}.npy")
        assert fa.shape == fb.shape and np.abs(fa[:, :259] - fb[:, :259]).max() < 0.05, cid
        assert (dataset / "texts" / f"{cid}.txt").read_bytes() == (out / "texts" / f"{cid}.txt").read_bytes()
    for f in ("Mean.npy", "Std.npy", "train.txt", "metadata.csv", "actions.json"):
        assert (dataset / f).read_bytes() == (out / f).read_bytes(), f
    assert len(load_split(out, "train", min_frames=16)) == len(load_split(dataset, "train", min_frames=16))


def test_bad_archives_are_refused_and_leave_nothing(dataset, tmp_path):
    with pytest.raises(DatasetError, match="archive not found"):
        pack.unpack(tmp_path / "missing.tar.xz", tmp_path / "x")
    bogus = tmp_path / "bogus.tar.xz"
    with tarfile.open(bogus, "w:xz") as tar:
        tar.add(dataset / "all.txt", arcname="all.txt")
    with pytest.raises(DatasetError, match="pack.json missing"):
        pack.unpack(bogus, tmp_path / "x")
    assert not (tmp_path / "x").exists() and not list(tmp_path.glob(".x.*")), "no half-written folder"
    with pytest.raises(DatasetError, match="all.txt not found"):
        pack.pack(tmp_path, tmp_path / "out.tar.xz")
    assert not (tmp_path / "out.tar.xz").exists()
