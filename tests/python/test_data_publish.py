"""Where prepare and pack --unpack write (issue 29): a run killed while publishing --out is finished or undone by
the next run, which says so in one line and clears what dead runs left beside --out (never a live run's
folders); an --out that cannot be written is one line and exit 2, before any work."""

import io
import json
import os
import stat
import subprocess
import sys
import tarfile

import pytest

from emdm import outdir
from emdm.data import pack, prepare
from test_data_prepare import _run, _user_folder


def _dead_pid() -> int:
    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def _copy(folder, tag: str):
    """A folder standing for a dataset, recognisable by its tag."""
    folder.mkdir()
    (folder / "tag.txt").write_text(tag)
    return folder


def _tag(folder) -> str:
    return (folder / "tag.txt").read_text()


def _siblings(out) -> list[str]:
    return sorted(p.name for p in out.parent.iterdir() if p.name.startswith(f".{out.name}."))


@pytest.mark.parametrize("state,expect,note", [
    # killed between moving the old copy aside and renaming the finished one in (the audit's case)
    ({"new": "new", "old": "old"}, "new", "put in place the finished copy"),
    # killed after the finished copy was renamed to .new, before the old one was moved aside
    ({"out": "old", "new": "new"}, "new", "put in place the finished copy"),
    # the first publish of --out, killed between the two renames
    ({"new": "new"}, "new", "put in place the finished copy"),
    # the layout of the code before this fix: the old copy aside, the new one still a temp folder
    ({"old": "old", "tmp": "half"}, "old", "put back the previous copy"),
    # published, killed while removing the old copy
    ({"out": "new", "old": "old"}, "new", "removed 1 leftover temp folder"),
    # killed while building: an unfinished temp folder
    ({"out": "old", "tmp": "half"}, "old", "removed 1 leftover temp folder"),
])
def test_recover_finishes_or_undoes_a_killed_publish(tmp_path, state, expect, note):
    out, pid = tmp_path / "ds", _dead_pid()
    names = {"out": out, "new": tmp_path / f".ds.new-{pid}", "old": tmp_path / f".ds.old-{pid}",
             "tmp": tmp_path / f".ds.tmp-{pid}-a1b2c3d4"}
    for kind, tag in state.items():
        _copy(names[kind], tag)
    line = outdir.recover(out)
    assert note in line and str(pid) in line and "\n" not in line, line
    assert _tag(out) == expect and _siblings(out) == []
    assert outdir.recover(out) == "", "nothing is left to do"


def test_a_live_runs_folders_are_never_touched(tmp_path):
    out, live = tmp_path / "ds", os.getppid()
    _copy(out, "mine")
    for kind in ("new", "old"):
        _copy(tmp_path / f".ds.{kind}-{live}", kind)
    _copy(tmp_path / f".ds.tmp-{live}-a1b2c3d4", "building")
    _copy(tmp_path / ".dsx.old-1", "another output's")
    assert outdir.recover(out) == ""
    assert _tag(out) == "mine" and len(_siblings(out)) == 3 and (tmp_path / ".dsx.old-1").is_dir()


def test_prepare_after_a_kill_restores_reports_and_cleans_up(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    out = _run(tmp_path, root, jm)
    before = (out / "all.txt").read_text()
    pid = _dead_pid()
    os.replace(out, tmp_path / f".ds.old-{pid}")                  # the kill state of the audit
    _copy(tmp_path / f".ds.tmp-{pid}-zz9xk2aa", "half")
    capsys.readouterr()
    (root / "walk" / "take0.bvh").write_text("HIERARCHY\n")        # this run skips every take but one...
    (root / "walk" / "take1.bvh").write_text("HIERARCHY\n")
    (root / "walk" / "take2.bvh").write_text("HIERARCHY\n")
    (root / "wave-left-hand" / "w.bvh").write_text("HIERARCHY\n")
    assert prepare.main(["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out", str(out),
                         "--workers", "1"]) == 2                  # ...so it publishes nothing
    err = capsys.readouterr().err.splitlines()
    notes = [l for l in err if l.startswith("note:")]
    assert len(notes) == 1 and "put back the previous copy" in notes[0] and "removed 1 leftover" in notes[0], err
    assert (out / "all.txt").read_text() == before, "the dataset the kill had moved aside is back"
    assert _siblings(out) == []


def test_unpack_after_a_kill_completes_the_publish(tmp_path, capsys):
    root, jm = _user_folder(tmp_path)
    ds = _run(tmp_path, root, jm)
    arc = tmp_path / "ds.tar.xz"
    assert pack.main([str(ds), str(arc)]) == 0
    out, pid = tmp_path / "un", _dead_pid()
    os.replace(ds, tmp_path / f".un.new-{pid}")                    # killed with its finished copy beside --out
    capsys.readouterr()
    with pytest.raises(pack.DatasetError):                         # this run fails, after the recovery
        pack.unpack(tmp_path / "missing.tar.xz", out)
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(out)]) == 0
    assert "put in place the finished copy" in capsys.readouterr().err
    assert (out / "train.txt").is_file() and _siblings(out) == []


def _readonly(folder):
    folder.mkdir()
    os.chmod(folder, stat.S_IRUSR | stat.S_IXUSR)
    try:
        (folder / "probe").write_text("")
    except OSError:
        return folder
    (folder / "probe").unlink()
    if subprocess.run(["chattr", "+i", str(folder)], capture_output=True).returncode:
        pytest.skip("cannot make a read-only folder here (root without chattr)")
    return folder


@pytest.fixture
def places(tmp_path):
    (tmp_path / "a-file").write_text("x")
    ro = _readonly(tmp_path / "ro")
    yield {"read-only parent": (ro / "ds", "cannot write in"), "parent is a file": (tmp_path / "a-file" / "ds", "is a file"),
           "out is a file": (tmp_path / "a-file", "exists and is a file")}
    subprocess.run(["chattr", "-i", str(ro)], capture_output=True)
    os.chmod(ro, 0o755)


@pytest.mark.parametrize("case", ["read-only parent", "parent is a file", "out is a file"])
def test_an_output_that_cannot_be_written_is_one_line_and_exit_2(tmp_path, places, case, capsys):
    root, jm = _user_folder(tmp_path)
    out, needle = places[case]
    rc = prepare.main(["--sources", "", "--input-dir", str(root), "--joint-map", str(jm), "--out", str(out),
                       "--workers", "1"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith(f"prepare: --out {out}: ") and needle in err[-1], err
    if case != "out is a file":
        arc = tmp_path / "x.tar.xz"
        arc.write_bytes(b"")
        assert pack.main(["--unpack", str(arc), str(out)]) == 2
        assert f"unpack folder {out}" in capsys.readouterr().err


@pytest.mark.parametrize("damage", ["random", "truncated", "bad header"])
def test_unpack_of_a_damaged_archive_is_one_line_and_exit_2(tmp_path, damage, capsys):
    root, jm = _user_folder(tmp_path)
    arc = tmp_path / "ds.tar.xz"
    assert pack.main([str(_run(tmp_path, root, jm)), str(arc)]) == 0
    data = arc.read_bytes()
    if damage == "random":
        arc.write_bytes(os.urandom(len(data)))
    elif damage == "truncated":
        arc.write_bytes(data[:len(data) // 2])
    else:
        with tarfile.open(arc, "r:xz") as tar:
            files = {m.name: tar.extractfile(m).read() for m in tar.getmembers()}
        files["pack.json"] = json.dumps({"format": 1, "lengths": "x"}).encode()
        with tarfile.open(arc, "w:xz") as tar:
            for name, b in files.items():
                info = tarfile.TarInfo(name)
                info.size = len(b)
                tar.addfile(info, io.BytesIO(b))
    capsys.readouterr()
    assert pack.main(["--unpack", "--workers", "1", str(arc), str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {arc}: ") and "Traceback" not in err[0], err
    assert not (tmp_path / "out").exists() and _siblings(tmp_path / "out") == []
