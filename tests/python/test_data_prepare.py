"""The prepare CLI end to end: a user's folder of synthetic BVH files with a joint map, --strict,
and (with ../shared/data) a few real takes of every source and truthful mirrored walk-left clips."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.data import prepare
from emdm.data.captions import parse_caption_line
from test_mocap_bvh import reference_bvh_text


def _user_folder(tmp_path: Path, bad: bool = False) -> tuple[Path, Path]:
    root = tmp_path / "mocap"
    y = sk.REFERENCE_OFFSETS[0, 1]
    F = 91                                            # 3 s at 30 fps
    t = np.arange(F) / 30.0
    for i, yaw in enumerate((0.0, 90.0, -45.0)):      # walking forward at 1.2 m/s, any direction
        d = np.deg2rad(yaw)
        path = np.stack([1.2 * t * np.sin(d) + i, np.full(F, y), 1.2 * t * np.cos(d)], axis=1)
        (root / "walk").mkdir(parents=True, exist_ok=True)
        (root / "walk" / f"take{i}.bvh").write_text(reference_bvh_text(path, np.full(F, yaw), np.zeros(F)))
    (root / "wave-left-hand").mkdir()
    still = np.tile([0.0, y, 0.0], (F, 1))
    (root / "wave-left-hand" / "w.bvh").write_text(reference_bvh_text(still, np.zeros(F), 40 + 30 * np.sin(t * 6)))
    (root / "wave-left-hand" / "w.txt").write_text("A person waves the left hand.\nSomeone waves with the left hand.\n")
    if bad:
        (root / "walk" / "broken.bvh").write_text("HIERARCHY\nROOT pelvis\n{\n  OFFSET 0 0\n")
    jm = {"name": "reference", "format": "bvh", "scale": 0.01, "up": "y",
                      "joints": {n: n for n in sk.JOINT_NAMES}}
    jm_path = tmp_path / "reference_map.json"
    jm_path.write_text(json.dumps(jm))
    return root, jm_path


def _run(tmp_path, root, jm, *extra):
    out = tmp_path / "ds"
    rc = prepare.main(["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out", str(out),
                       "--workers", "1", *extra])
    assert rc == 0
    return out


def test_user_folder_becomes_a_humanml3d_dataset(tmp_path, capsys):
    root, jm = _user_folder(tmp_path, bad=True)
    out = _run(tmp_path, root, jm)
    printed = capsys.readouterr().out
    assert "run time:" in printed and "skipped files: 1" in printed and "walk" in printed
    skipped = (out / "skipped.txt").read_text()
    assert "broken.bvh" in skipped and "broken.bvh:" in skipped, "the reason names file and line"
    for name in ("Mean.npy", "Std.npy", "train.txt", "val.txt", "test.txt", "actions.json", "metadata.csv"):
        assert (out / name).is_file(), name
    mean, std = np.load(out / "Mean.npy"), np.load(out / "Std.npy")
    assert mean.shape == std.shape == (263,) and np.all(std > 0)
    rows = list(csv.DictReader(open(out / "metadata.csv")))
    assert len(rows) == 8, "4 takes x (original + mirror)"
    labels = json.loads((out / "actions.json").read_text())["labels"]
    assert labels == ["walk", "wave-left-hand", "wave-right-hand"]
    for r in rows:
        J = np.load(out / "new_joints" / f"{r['id']}.npy")
        feats = np.load(out / "new_joint_vecs" / f"{r['id']}.npy")
        assert J.shape == (int(r["frames"]), 22, 3) and feats.shape == (J.shape[0] - 1, 263)
        assert J.shape[0] == 61, "3 s at 20 fps"
        assert labels[int(r["action_id"])] == r["action"]
        np.testing.assert_allclose(J[0, 0, [0, 2]], 0, atol=1e-6)
        bones = np.linalg.norm(J[:, 1:] - J[:, sk.PARENTS[1:]], axis=-1)
        np.testing.assert_allclose(bones, np.broadcast_to(sk.bone_lengths()[1:], bones.shape), atol=1e-5)
        caps = [parse_caption_line(l) for l in (out / "texts" / f"{r['id']}.txt").read_text().splitlines()]
        assert caps
        if r["action"] == "walk":
            np.testing.assert_allclose(J[-1, 0, [0, 2]], [0, 3.6], atol=0.05)  # 1.2 m/s x 3 s, straight ahead
        else:
            side = "right" if r["mirrored"] == "1" else "left"
            assert r["action"] == f"wave-{side}-hand"
            assert all(side in c and ({"left", "right"} - {side}).pop() not in c for c, *_ in caps)
            wrist, other = (21, 20) if side == "right" else (20, 21)
            path = lambda j: np.linalg.norm(np.diff(J[:, j], axis=0), axis=-1).sum()
            assert path(wrist) > 1.0 > 0.01 > path(other), "the named hand is the one that waves"
    takes = {}
    for r in rows:
        takes.setdefault(r["take"], set()).add(r["split"])
    assert all(len(s) == 1 for s in takes.values()), "a take (and its mirror) is in one split"
    ids = {s: (out / f"{s}.txt").read_text().split() for s in ("train", "val", "test")}
    assert sum(map(len, ids.values())) == 8 and len(ids["test"]) >= 2


CLASHING = ["walk ä.bvh", "walk ö.bvh", "walk-ü.bvh", "walk.bvh", "walk.BVH"]     # all slug to 'walk'


def test_files_whose_names_slug_alike_are_each_their_own_clip_with_a_stable_id(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    take = (root / "walk" / "take0.bvh").read_text()
    for name in CLASHING:
        (root / "walk" / name).write_text(take)
    out = _run(tmp_path, root, jm)
    ids = (out / "all.txt").read_text().split()
    assert len(ids) == len(set(ids)) == 2 * 9, "9 files, each one clip and its mirror"
    rows = list(csv.DictReader(open(out / "metadata.csv")))
    assert len({r["take"] for r in rows}) == 9 and len({r["id"] for r in rows}) == 18
    info = json.loads((out / "info.json").read_text())
    assert (info["files"], info["clips"], info["skipped"], info["takes"], info["windows"]) == (9, 9, 0, 9, 18)
    assert "user            9                 18" in capsys.readouterr().out
    walk = sorted(i for i in ids if i.startswith("user_walk-walk"))
    assert len(walk) == 5 and all(len(i) == len("user_walk-walk-123456_00") for i in walk), walk
    assert "user_walk-take0_00" in ids, "a name that does not clash keeps its plain id"
    again = prepare.main(["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out",
                          str(tmp_path / "again"), "--workers", "2"])
    assert again == 0 and sorted((tmp_path / "again" / "all.txt").read_text().split()) == sorted(ids), "stable"


@pytest.mark.parametrize("workers", ["1", "2"])
def test_strict_fails_on_the_first_bad_file_and_writes_nothing(tmp_path, workers, capsys):
    root, jm = _user_folder(tmp_path, bad=True)
    rc = prepare.main(["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out", str(tmp_path / "ds"),
                       "--strict", "--workers", workers])
    assert rc == 2
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert "broken.bvh:4" in line and "--strict" in line
    assert not (tmp_path / "ds").exists()
    assert not list(tmp_path.glob(".ds.tmp-*")), "the temp folder is removed"


SHARED = paths.shared_data_dir()
HAVE_ALL = all((SHARED / a).is_file() for a in prepare.ARCHIVES.values())
needs_shared = pytest.mark.skipif(not HAVE_ALL, reason=f"real mocap archives not found in {SHARED} "
                                  "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")


@needs_shared
def test_real_sources_prepare_quickly(tmp_path):
    out = tmp_path / "real"
    assert prepare.main(["--limit", "2", "--out", str(out), "--workers", "1"]) == 0
    info = json.loads((out / "info.json").read_text())
    assert info["roundtrip_max_m"] < 1e-3 and info["skipped"] == 0
    rows = list(csv.DictReader(open(out / "metadata.csv")))
    assert {r["source"] for r in rows} == {"bandai", "hdm05", "cmu"}
    assert all(int(r["frames"]) <= sk.MAX_FRAMES for r in rows)


@needs_shared
def test_real_walk_left_goes_left_and_its_mirror_goes_right(tmp_path):
    from emdm.data import sources
    from emdm.data.process import process_job
    from emdm.data.unpack import unpack_archive

    root = unpack_archive(SHARED / prepare.ARCHIVES["bandai"])
    jobs = [j for j in sources.bandai_jobs(root) if j.extra["content"] in ("walk-left", "walk-turn-right")][:: 40][:4]
    for d in ("new_joints", "new_joint_vecs", "texts"):
        (tmp_path / d).mkdir()
    for job in jobs:
        res = process_job(job, str(tmp_path), 16, 196, 98)
        for w in res["windows"]:
            J = np.load(tmp_path / "new_joints" / f"{w['id']}.npy")
            goes = "left" if J[-1, 0, 0] > 0 else "right"    # +X is the first frame's left
            assert goes in w["action"], (w["id"], w["action"], J[-1, 0])
            text = " ".join(w["captions"])
            assert goes in text and ({"left", "right"} - {goes}).pop() not in text.split(), text


@needs_shared
def test_real_playground_jumps_are_jumps_and_the_playground_split_stays_as_trained():
    """CMU 01_01 ("playground - forward jumps, turn around") is labelled jump; the split still stratifies the
    playground session as one group, so its test takes are those the shipped models were evaluated on."""
    from emdm.data import sources
    from emdm.data.split import split_takes
    from emdm.data.unpack import unpack_archive

    root = unpack_archive(SHARED / prepare.ARCHIVES["cmu"])
    jobs = {j.take: j for j in sources.cmu_jobs(root) if j.take.startswith("cmu/01_")}
    assert jobs["cmu/01_01"].action == "jump" and jobs["cmu/01_07"].action == "climb"
    assert {j.stratum for j in jobs.values()} == {"climb"}
    held = {t: s for t, s in split_takes({t: j.stratum or j.action for t, j in jobs.items()}).items() if s != "train"}
    assert held == {"cmu/01_06": "test", "cmu/01_14": "test", "cmu/01_08": "val"}, "the split the models know"
