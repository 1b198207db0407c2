"""Bad input on purpose (issue 16): prepare and pack never destroy a folder they did not write, refuse an
--out that is (or holds) an input or the repository, fail early on a bad joint map, and turn broken mocap
(non-finite values, degenerate frame times, a missing ASF) into per-file skips with an honest reason."""

import io
import json
import os
import signal
import tarfile
from pathlib import Path

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.data import pack, prepare
from emdm.data.unpack import unpack_archive
from test_data_prepare import _user_folder
from test_mocap_bvh import reference_bvh_text


def _prepare(tmp_path, root, jm, out=None, *extra):
    """prepare.main -> (exit status, stderr's last line); a SystemExit counts as its status."""
    out = tmp_path / "ds" if out is None else out
    argv = ["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out", str(out), "--workers", "1",
            *extra]
    try:
        return prepare.main(argv)
    except SystemExit as e:
        return e.code if isinstance(e.code, int) else 1


def _last_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    return err[-1] if err else ""


def _bystander(folder: Path) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    f = folder / "thesis.txt"
    f.write_text("years of work\n")
    return f


# --- outputs are never destroyed ---------------------------------------------------------------------------

def test_existing_folder_that_is_not_a_dataset_is_refused_without_force(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    keep = _bystander(tmp_path / "ds")
    assert _prepare(tmp_path, root, jm) == 2
    line = _last_line(capsys)
    assert str(tmp_path / "ds") in line and "--force" in line and "not a dataset" in line
    assert keep.read_text() == "years of work\n", "the folder is left as it was"
    assert not list(tmp_path.glob(".ds.*")), "no temp folder left behind"


def test_force_replaces_a_foreign_folder_and_a_dataset_is_replaced_without_it(tmp_path):
    root, jm = _user_folder(tmp_path)
    keep = _bystander(tmp_path / "ds")
    assert _prepare(tmp_path, root, jm, None, "--force") == 0
    assert not keep.exists() and (tmp_path / "ds" / "train.txt").is_file()
    info = json.loads((tmp_path / "ds" / "info.json").read_text())
    assert info["tool"] == "emdm.data.prepare"
    assert _prepare(tmp_path, root, jm) == 0, "a dataset prepare wrote is replaced without --force"
    assert not list(tmp_path.glob(".ds.*"))


def test_an_older_dataset_without_the_marker_is_still_recognised(tmp_path):
    from emdm import outdir

    old = tmp_path / "old"
    old.mkdir()
    for f in ("train.txt", "Mean.npy"):
        (old / f).write_text("")
    (old / "info.json").write_text(json.dumps({"sources": "bandai"}))
    assert outdir.is_prepared_dataset(old)
    (old / "info.json").write_text("not json")
    assert not outdir.is_prepared_dataset(old)


@pytest.mark.parametrize("where", ["equal", "inside", "parent"])
def test_out_equal_to_inside_or_holding_the_input_is_refused_even_with_force(tmp_path, capsys, where):
    root, jm = _user_folder(tmp_path)
    before = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*"))
    out = {"equal": root, "inside": root / "walk" / "ds", "parent": tmp_path}[where]
    assert _prepare(tmp_path, root, jm, out, "--force") == 2
    line = _last_line(capsys)
    assert "--input-dir" in line and str(out) in line
    assert sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*")) == before, "nothing added or removed"


def test_out_that_is_or_holds_the_repository_is_refused(tmp_path, monkeypatch, capsys):
    from emdm import outdir

    repo = tmp_path / "repo"
    keep = _bystander(repo)
    monkeypatch.setattr(paths, "REPO_ROOT", repo)
    root, jm = _user_folder(tmp_path / "in")
    for out in (repo, tmp_path):
        assert _prepare(tmp_path, root, jm, out, "--force") == 2
        assert "repository" in _last_line(capsys)
    assert keep.is_file()
    with pytest.raises(outdir.OutputRefused, match="repository"):
        outdir.check_out(paths.REPO_ROOT.parent, force=True)


def test_the_real_repository_root_is_refused():
    from emdm import outdir

    with pytest.raises(outdir.OutputRefused, match="repository"):
        outdir.check_out(paths.REPO_ROOT, force=True)
    with pytest.raises(outdir.OutputRefused, match="repository"):
        outdir.check_out(Path("/"), force=True)


def test_out_beside_the_joint_map_is_fine_but_holding_it_is_not(tmp_path, capsys):
    root, jm = _user_folder(tmp_path / "in")
    out = jm.parent / "maps"
    jm2 = out / "map.json"
    out.mkdir()
    jm2.write_text(jm.read_text())
    assert _prepare(tmp_path, root, jm2, out, "--force") == 2
    assert "--joint-map" in _last_line(capsys) and jm2.is_file()


def test_unpack_refuses_a_foreign_folder_and_a_folder_holding_the_archive(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    ds = tmp_path / "ds"
    assert _prepare(tmp_path, root, jm) == 0
    box = tmp_path / "box"
    box.mkdir()
    arc = box / "ds.tar.xz"
    assert pack.main([str(ds), str(arc)]) == 0
    keep = _bystander(tmp_path / "mine")
    capsys.readouterr()
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(tmp_path / "mine")]) == 2
    assert "--force" in _last_line(capsys) and keep.is_file()
    assert pack.main(["--unpack", "--workers", "1", "--force", str(arc), str(box)]) == 2
    assert "archive" in _last_line(capsys) and arc.is_file()
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(ds)]) == 0, "a dataset is replaced"
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(box / "ds")]) == 0, "beside the archive is fine"
    assert not list(tmp_path.rglob(".*.old-*")) and not list(box.glob(".ds.*"))


def test_pack_does_not_overwrite_a_file_it_did_not_write(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    assert _prepare(tmp_path, root, jm) == 0
    keep = _bystander(tmp_path / "notes")
    capsys.readouterr()
    assert pack.main([str(tmp_path / "ds"), str(keep)]) == 2
    assert "--force" in _last_line(capsys) and keep.read_text() == "years of work\n"
    assert pack.main([str(tmp_path / "ds"), str(tmp_path / "a.tar.xz")]) == 0
    assert pack.main([str(tmp_path / "ds"), str(tmp_path / "a.tar.xz")]) == 0, "its own archive is replaced"


# --- prepare fails early and says why --------------------------------------------------------------------

def test_unknown_joint_map_name_lists_the_builtin_maps(tmp_path, capsys):
    root, _ = _user_folder(tmp_path)
    assert _prepare(tmp_path, root, "no_such_rig") == 2
    line = _last_line(capsys)
    assert "no_such_rig" in line and "bandai, cmu_asfamc, cmu_cc_bvh" in line
    assert not (tmp_path / "ds").exists()


def test_broken_joint_map_json_names_file_line_and_column(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    jm.write_text('{"name": "x",\n "format": "bvh",\n "scale" 0.01}\n')
    assert _prepare(tmp_path, root, jm) == 2
    line = _last_line(capsys)
    assert f"{jm}:3" in line and "column 10" in line


def test_joint_map_for_another_rig_names_the_missing_joints_and_the_file(tmp_path, capsys):
    root, _ = _user_folder(tmp_path)
    assert _prepare(tmp_path, root, "bandai") == 2
    line = _last_line(capsys)
    assert "needs 'Chest', 'Foot_L'" in line and "take0.bvh" in line and "bandai" in line and "pelvis" in line
    assert not (tmp_path / "ds").exists() and not (tmp_path / "ds.skipped.txt").exists()


def _bad_bvh(root: Path, name: str, edit) -> Path:
    F = 61
    t = np.arange(F) / 30.0
    path = np.stack([np.zeros(F), np.full(F, sk.REFERENCE_OFFSETS[0, 1]), 1.2 * t], axis=1)
    lines = reference_bvh_text(path, np.zeros(F), np.zeros(F)).splitlines()
    p = root / "walk" / name
    p.write_text("\n".join(edit(lines)) + "\n")
    return p


def _motion_value(value: str, row: int = 10, col: int = 1):
    def edit(lines):
        first = next(i for i, l in enumerate(lines) if l.startswith("Frame Time")) + 1
        toks = lines[first + row].split()
        toks[col] = value
        lines[first + row] = " ".join(toks)
        return lines
    return edit


def _frame_time(value: str):
    return lambda lines: [f"Frame Time: {value}" if l.startswith("Frame Time") else l for l in lines]


@pytest.mark.parametrize("edit,reason", [
    (_motion_value("nan"), "not a finite number"),
    (_motion_value("inf", col=0), "not a finite number"),
    (_motion_value("1e308"), "out of range"),
    (_motion_value("1e308", col=7), "out of range"),             # a rotation: cos/sin of 1e306 rad is noise
    (_frame_time("inf"), "Frame Time"),
    (_frame_time("0"), "Frame Time"),
    (_frame_time("-0.033"), "Frame Time"),
    (_frame_time("nan"), "Frame Time"),
    (_frame_time("1e-300"), "Frame Time"),
], ids=["nan", "inf", "1e308-position", "1e308-rotation", "ft-inf", "ft-0", "ft-negative", "ft-nan", "ft-tiny"])
def test_broken_values_skip_that_file_with_the_reason(tmp_path, edit, reason):
    root, jm = _user_folder(tmp_path)
    bad = _bad_bvh(root, "bad.bvh", edit)
    out = tmp_path / "ds"
    assert _prepare(tmp_path, root, jm) == 0
    skipped = dict(l.split("\t", 1) for l in (out / "skipped.txt").read_text().splitlines())
    assert list(skipped) == [str(bad)]
    assert reason in skipped[str(bad)] and "legs" not in skipped[str(bad)], skipped
    mean, std = np.load(out / "Mean.npy"), np.load(out / "Std.npy")
    assert np.isfinite(mean).all() and np.isfinite(std).all()
    assert "bad" not in (out / "all.txt").read_text()
    assert not list((out / "new_joints").glob("*bad*")), "no file of a skipped take is left in the dataset"


def test_amc_without_its_asf_is_a_skip_naming_the_missing_file(tmp_path):
    root, jm = _user_folder(tmp_path)
    (root / "walk" / "lonely.amc").write_text(":DEGREES\n1\nroot 0 0 0 0 0 0\n")
    assert _prepare(tmp_path, root, jm) == 0
    skipped = (tmp_path / "ds" / "skipped.txt").read_text()
    assert "lonely.amc" in skipped and "lonely.asf" in skipped


def test_when_every_file_is_skipped_the_reasons_are_printed_and_kept(tmp_path, capsys):
    root = tmp_path / "mocap"
    (root / "walk").mkdir(parents=True)
    _, jm = _user_folder(tmp_path / "other")
    a = _bad_bvh(root, "a.bvh", _frame_time("inf"))
    b = _bad_bvh(root, "b.bvh", _motion_value("nan"))
    keep = _bystander(tmp_path / "ds")
    (keep.parent / "train.txt").write_text("")                    # an older dataset: it must survive
    (keep.parent / "Mean.npy").write_text("")
    (keep.parent / "info.json").write_text("{}")
    assert _prepare(tmp_path, root, jm) == 2
    cap = capsys.readouterr()
    last = cap.err.strip().splitlines()[-1]
    assert "every one of the 2 files was skipped" in last and "ds.skipped.txt" in last
    assert "Frame Time" in cap.err + cap.out and "not a finite number" in cap.err + cap.out
    kept = (tmp_path / "ds.skipped.txt").read_text()
    assert str(a) in kept and str(b) in kept
    assert keep.is_file(), "the previous dataset is untouched"
    assert not list(tmp_path.glob(".ds.*"))
    root2, _ = _user_folder(tmp_path / "good")
    assert _prepare(tmp_path, root2, jm) == 0
    assert not (tmp_path / "ds.skipped.txt").exists(), "a later good run removes the stale list"


def test_non_finite_mean_std_is_never_published(tmp_path):
    job = {"source": "user", "take": "t", "style": "", "extra": {}}
    w = {"id": "user_x_00", "action": "walk", "frames": 3, "mirrored": False, "start": 0, "captions": [],
         "roundtrip": 0.0, "sum": np.full(sk.FEATURE_DIM, np.inf), "sumsq": np.ones(sk.FEATURE_DIM), "n": 3}
    with pytest.raises(prepare.PrepareError, match="not finite"):
        prepare.write_dataset([{"job": job, "fps": 30.0, "windows": [w]}], tmp_path, {"t": "train"}, {})
    assert not (tmp_path / "Mean.npy").exists()


# --- archives: safe extraction ---------------------------------------------------------------------------

def _tar(path: Path, members: list[tuple[tarfile.TarInfo, bytes]]) -> Path:
    with tarfile.open(path, "w:xz") as tar:
        for info, data in members:
            info.size = len(data) if info.isfile() else 0
            tar.addfile(info, io.BytesIO(data) if info.isfile() else None)
    return path


def _member(name: str, kind=tarfile.REGTYPE, link: str = "") -> tarfile.TarInfo:
    m = tarfile.TarInfo(name)
    m.type = kind
    m.linkname = link
    return m


UNSAFE = {
    "symlink": (_member("data/link", tarfile.SYMTYPE, "/etc/passwd"), "link"),
    "hardlink": (_member("data/hard", tarfile.LNKTYPE, "data/ok.txt"), "link"),
    "device": (_member("data/dev", tarfile.CHRTYPE), "device"),
    "fifo": (_member("data/fifo", tarfile.FIFOTYPE), "device"),
    "dotdot": (_member("../escaped.txt"), "outside"),
    "absolute": (_member("/tmp/emdm-absolute.txt"), "outside"),
}


@pytest.mark.parametrize("kind", list(UNSAFE))
def test_unpack_archive_rejects_links_devices_and_escapes_naming_the_member(tmp_path, kind):
    bad, why = UNSAFE[kind]
    arc = _tar(tmp_path / "src.tar.xz", [(_member("data/ok.txt"), b"ok"), (bad, b"x")])
    with pytest.raises(ValueError, match=why) as e:
        unpack_archive(arc, tmp_path / "raw")
    assert repr(bad.name) in str(e.value)
    assert not (tmp_path / "escaped.txt").exists() and not (tmp_path / "raw" / "src").exists()
    assert not [p for p in (tmp_path / "raw").iterdir()], "no temp folder left"


def test_unpack_archive_is_not_fooled_by_a_sibling_with_the_same_prefix(tmp_path, monkeypatch):
    """The old check compared strings: '<raw>/.src.tmp' is a prefix of '<raw>/.src.tmpx/f'."""
    from emdm.data import unpack as unpack_mod

    raw = tmp_path / "raw"
    fixed = raw / ".src.tmp"

    def temp_dir(out):
        fixed.mkdir(parents=True)
        return fixed

    monkeypatch.setattr(unpack_mod, "temp_dir", temp_dir)
    arc = _tar(tmp_path / "src.tar.xz", [(_member("../.src.tmpx/f.txt"), b"x")])
    with pytest.raises(ValueError, match="outside"):
        unpack_archive(arc, raw)
    assert not (raw / ".src.tmpx").exists()


def test_unpack_archive_extracts_a_good_archive_and_refuses_a_foreign_cache_folder(tmp_path):
    from emdm import outdir

    arc = _tar(tmp_path / "src.tar.xz", [(_member("data/ok.txt"), b"ok")])
    keep = _bystander(tmp_path / "raw" / "src")
    with pytest.raises(outdir.OutputRefused, match="--force"):
        unpack_archive(arc, tmp_path / "raw")
    assert keep.is_file()
    dest = unpack_archive(arc, tmp_path / "raw", force=True)
    assert (dest / "data" / "ok.txt").read_bytes() == b"ok" and not keep.exists()


@pytest.mark.parametrize("kind", ["symlink", "device", "dotdot", "absolute"])
def test_pack_unpack_rejects_unsafe_members_naming_them(tmp_path, kind, capsys):
    bad, _ = UNSAFE[kind]
    header = json.dumps({"format": pack.FORMAT, "ids": [], "lengths": [], "mirrored": [], "clips": 0}).encode()
    buf = io.BytesIO()
    np.save(buf, np.zeros((0, 22, 3), np.int32))
    members = [(_member("pack.json"), header), (_member("joints_delta.npy"), buf.getvalue())]
    members += [(_member(n), b"1\n") for n in ("all.txt", "Mean.npy", "Std.npy")] + [(bad, b"x")]
    arc = _tar(tmp_path / "ds.tar.xz", members)
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(tmp_path / "out")]) == 2
    line = _last_line(capsys)
    assert repr(bad.name) in line and str(arc) in line
    assert not (tmp_path / "out").exists() and not (tmp_path / "escaped.txt").exists()


# --- one file's failure is that file's skip (issue 29) --------------------------------------------------------

def test_a_fifo_named_bvh_is_skipped_not_waited_on(tmp_path):
    root, jm = _user_folder(tmp_path)
    os.mkfifo(root / "walk" / "pipe.bvh")
    class Blocked(BaseException):     # not an OSError: nothing on the way may take it for a read error
        pass

    def blocked(*_):
        raise Blocked("prepare blocked on the FIFO for 20 s")

    old = signal.signal(signal.SIGALRM, blocked)
    signal.alarm(20)
    try:
        assert _prepare(tmp_path, root, jm) == 0
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    skipped = (tmp_path / "ds" / "skipped.txt").read_text()
    assert "pipe.bvh" in skipped and "named pipe (FIFO), not a regular file" in skipped


def test_memory_error_on_one_file_is_its_skip_and_the_run_goes_on(tmp_path, monkeypatch):
    root, jm = _user_folder(tmp_path)
    real = prepare.process_job

    def hungry(job, *a, **k):
        if job.path.endswith("take1.bvh"):
            raise MemoryError("Unable to allocate 4.8 GiB for an array")
        return real(job, *a, **k)

    monkeypatch.setattr(prepare, "process_job", hungry)
    assert _prepare(tmp_path, root, jm) == 0
    skipped = dict(l.split("\t", 1) for l in (tmp_path / "ds" / "skipped.txt").read_text().splitlines())
    assert list(skipped) == [str(root / "walk" / "take1.bvh")]
    assert skipped[str(root / "walk" / "take1.bvh")].startswith("MemoryError: the file needs more memory")
    info = json.loads((tmp_path / "ds" / "info.json").read_text())
    assert (info["files"], info["skipped"], info["clips"]) == (4, 1, 3)

