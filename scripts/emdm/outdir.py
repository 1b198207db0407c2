"""Where a CLI may write (or replace) a folder or file, and the atomic replace itself.

Every CLI that replaces a whole ``--out`` (``emdm.data.prepare``, ``emdm.data.pack --unpack``, the
archive cache of ``emdm.data.unpack``) asks ``check_out`` first:

* an ``--out`` that is, or holds, the repository, a filesystem root or the home folder is refused always;
* an ``--out`` equal to or inside an input folder, or holding an input (file or folder), is refused always
  (replacing it would delete what the run reads);
* an existing ``--out`` that this tool did not write (``recognise`` says no; an empty folder is fine) is
  refused unless ``force``.

The output is built in ``temp_dir(out)`` (``.NAME.tmp-PID-*`` beside it) and published by ``replace_dir``:
the finished folder is renamed ``.NAME.new-PID``, an older ``out`` aside to ``.NAME.old-PID``, the new one
onto ``out``, and only then is the old one removed. A run killed at any point leaves names that say what
to do, and ``check_out`` starts with ``recover``: for each such name whose process is gone it completes the
publish (a ``new`` copy is finished), else puts the old ``out`` back, removes stale copies and unfinished
temp folders, and says so in one line. Folders of a live process are never touched.
A refusal is an ``OutputRefused`` whose message is one line: the path and why.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from emdm import paths

PREPARE_TOOL = "emdm.data.prepare"      # info.json "tool" of a dataset written by emdm.data.prepare


class OutputRefused(Exception):
    """An output path this run must not write (one-line message: the path and why)."""


def is_prepared_dataset(folder: Path) -> bool:
    """A dataset folder written by emdm.data.prepare (or unpacked by emdm.data.pack from one): its
    info.json says ``"tool": "emdm.data.prepare"``; older ones, written before that field, are recognised
    by a readable info.json object beside train.txt and Mean.npy."""
    folder = Path(folder)
    try:
        info = json.loads((folder / "info.json").read_text())
    except (OSError, ValueError):
        return False
    if not isinstance(info, dict):
        return False
    return info.get("tool") == PREPARE_TOOL or ((folder / "train.txt").is_file() and (folder / "Mean.npy").is_file())


def _inside(a: Path, b: Path) -> bool:
    """a is b or below it (resolved paths)."""
    return a == b or a.is_relative_to(b)


def check_out(out: Path | str, *, inputs: Iterable[tuple[str, Path | str]] = (), force: bool = False,
              recognise: Callable[[Path], bool] = is_prepared_dataset, what: str = "a dataset folder",
              option: str = "--out") -> Path:
    """The resolved ``out`` if this run may replace it, else OutputRefused (see the module docstring).
    ``inputs``: (option name, path) of what the run reads, e.g. ("--input-dir", "my_mocap")."""
    given = f"{option} {out}"
    out = Path(out).expanduser().resolve()
    announce_recovery(out, given)
    repo = Path(paths.REPO_ROOT).resolve()
    if _inside(repo, out):
        raise OutputRefused(f"{given}: {'is' if out == repo else 'holds'} the repository ({repo}); "
                            "replacing it would delete the checkout. Choose a folder such as data/mine")
    if out.parent == out or out == Path.home().resolve():
        raise OutputRefused(f"{given}: is {'a filesystem root' if out.parent == out else 'your home folder'}; "
                            "choose a new folder for the output")
    for name, p in inputs:
        if p is None or str(p) == "":
            continue
        inp = Path(p).expanduser().resolve()
        if not inp.is_file() and _inside(out, inp):
            raise OutputRefused(f"{given}: is {'the' if out == inp else 'inside the'} {name} folder "
                                f"{p}; write the output somewhere else (e.g. data/mine)")
        if _inside(inp, out):
            raise OutputRefused(f"{given}: {'is' if out == inp else 'holds'} the {name} {p}; replacing it "
                                "would delete the input. Write the output somewhere else")
    if out.exists() and not force:
        if out.is_dir():
            if any(out.iterdir()) and not recognise(out):
                raise OutputRefused(f"{given}: exists and is not {what} this tool wrote; nothing was "
                                    "changed (give --force to replace it, or choose a new folder)")
        elif not recognise(out):
            raise OutputRefused(f"{given}: exists and is a file, not {what} this tool wrote; nothing was "
                                "changed (give --force to replace it, or choose a new path)")
    return out


def check_writable(path: Path | str, *, folder: bool = False, option: str = "--out") -> Path:
    """``path`` if this run can write it (a file; ``folder=True``: a folder to write files in), else
    OutputRefused: a file path must not be a folder and a folder path not a file, and the nearest existing
    folder must take a new file. Asked before any work, so a run never fails at its end for want of a place
    to write."""
    path = Path(path)
    given = f"{option} {path}"
    if folder and path.exists() and not path.is_dir():
        raise OutputRefused(f"{given}: is a file, not a folder; give a folder to write in")
    if not folder and path.is_dir():
        raise OutputRefused(f"{given}: is a folder; give a file path")
    try:
        writable_folder(path if folder and path.is_dir() else path.parent)
    except OutputRefused as e:
        raise OutputRefused(f"{given}: {e}") from None
    return path


def missing_folders(path: Path | str) -> list[Path]:
    """The folders at and above ``path`` that do not exist yet, deepest first: those a run that makes ``path``
    creates (``remove_made_folders`` takes them away again when it fails)."""
    out, d = [], Path(path)
    while not d.exists() and not d.is_symlink() and d.parent != d:
        out.append(d)
        d = d.parent
    return out


def remove_made_folders(made: list[Path], ours: Iterable[str] = ()) -> None:
    """Undo ``made`` (``missing_folders`` before a run that then failed): in the deepest, the files matching the
    glob patterns ``ours`` (what the run writes there) are removed, then each folder while it is empty. Anything
    else found in them stays, and with it its folders: nothing that is not this run's is ever deleted."""
    if not made or not made[0].is_dir():
        return
    for pattern in ours:
        for f in made[0].glob(pattern):
            if f.is_file() and not f.is_symlink():
                f.unlink(missing_ok=True)
    for d in made:
        if not d.is_dir() or d.is_symlink():
            continue
        try:
            d.rmdir()
        except OSError:          # not empty (or not ours to remove): it and the folders above it stay
            return


def check_place(out: Path, given: Path | str, option: str = "--out") -> Path:
    """OutputRefused unless the folder that will hold ``out`` (and its temp folder, beside it) can be made
    and written: its nearest existing ancestor is a folder that takes a new file."""
    try:
        return writable_folder(Path(out).parent)
    except OutputRefused as e:
        raise OutputRefused(f"{option} {given}: {e}") from None


def writable_folder(d: Path) -> Path:
    """The nearest existing folder at or above ``d`` if a new file can be made in it, else OutputRefused
    with the reason alone (the caller puts its option in front)."""
    while not d.exists():
        if d.is_symlink():
            raise OutputRefused(f"{d} is a broken symbolic link; give a path in a writable folder")
        d = d.parent
    if not d.is_dir():
        raise OutputRefused(f"{d} is a file, not a folder; give a path in a writable folder")
    try:
        with tempfile.TemporaryFile(dir=d):
            pass
    except OSError as e:
        raise OutputRefused(f"cannot write in {d} ({e.strerror}); give a path in a writable folder") from None
    return d


def temp_dir(out: Path) -> Path:
    """A new private folder beside ``out`` to build it in (``.NAME.tmp-PID-*``; ``recover`` removes it if
    this process dies before publishing it)."""
    out = Path(out)
    return Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-{os.getpid()}-", dir=out.parent))


def replace_dir(tmp: Path, out: Path) -> None:
    """Publish the finished folder ``tmp`` (from ``temp_dir(out)``) as ``out``; an older ``out`` is removed
    only after the new one is in place. Killed at any point, the next ``recover(out)`` finishes the job."""
    tmp, out = Path(tmp), Path(out)
    os.chmod(tmp, 0o755)  # mkdtemp makes it private
    new, old = _beside(out, "new", os.getpid()), _beside(out, "old", os.getpid())
    _remove(new)           # only a dead process that had our pid can have left one
    os.replace(tmp, new)   # finished: from here on, a killed run is completed, not undone
    if not out.exists() and not out.is_symlink():
        os.replace(new, out)
        return
    _remove(old)
    os.replace(out, old)
    try:
        os.replace(new, out)
    except BaseException:
        os.replace(old, out)
        _remove(new)
        raise
    _remove(old)


def _beside(out: Path, kind: str, pid: int) -> Path:
    return out.with_name(f".{out.name}.{kind}-{pid}")


def _remove(p: Path) -> None:
    if p.is_dir() and not p.is_symlink():
        shutil.rmtree(p, ignore_errors=True)
    elif p.exists() or p.is_symlink():
        p.unlink()


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (on this machine); when unsure, yes."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True
    return True


def _leftovers(out: Path) -> dict[int, dict[str, list[Path]]]:
    """pid -> {'tmp'|'new'|'old': [paths]} of the names ``temp_dir``/``replace_dir`` use beside ``out``, for
    processes that are gone."""
    prefix, found = f".{out.name}.", {}
    try:
        siblings = list(out.parent.iterdir())
    except OSError:
        return {}
    for p in siblings:
        m = re.fullmatch(r"(tmp|new|old)-(\d+)(-[A-Za-z0-9_]+)?", p.name[len(prefix):]) \
            if p.name.startswith(prefix) else None
        if m and (m[1] == "tmp") == (m[3] is not None) and not _alive(int(m[2])):
            found.setdefault(int(m[2]), {}).setdefault(m[1], []).append(p)
    return found


def announce_recovery(out: Path, given: str) -> None:
    """``recover(out)``, and its line on stderr when it did something."""
    note = recover(out)
    if note:
        print(f"note: {given}: {note}", file=sys.stderr)


def recover(out: Path) -> str:
    """Complete or undo the publish of ``out`` that a killed run left half done, remove what dead runs left
    beside it; one line saying what was done ('' when nothing was there)."""
    out, done, removed = Path(out), [], []
    for pid, left in sorted(_leftovers(out).items()):
        new, old = (left.get(k, [None])[0] for k in ("new", "old"))
        if new is not None:
            if out.exists() or out.is_symlink():
                if old is not None:
                    _remove(old)
                old = _beside(out, "old", pid)
                os.replace(out, old)
            os.replace(new, out)
            done.append(f"put in place the finished copy that run {pid} was killed while publishing")
        elif old is not None and not out.exists() and not out.is_symlink():
            os.replace(old, out)
            old = None
            done.append(f"put back the previous copy that run {pid} had moved aside when it was killed")
        for p in ([old] if old is not None else []) + left.get("tmp", []):
            _remove(p)
            removed.append(pid)
    if removed:
        pids = ", ".join(str(p) for p in sorted(set(removed)))
        done.append(f"removed {len(removed)} leftover temp folder{'s' if len(removed) > 1 else ''} of killed "
                    f"run{'s' if len(set(removed)) > 1 else ''} {pids}")
    return "; ".join(done)


def write_text_atomic(path: Path | str, text: str) -> Path:
    """Write ``text`` to ``path`` through a temporary file beside it and a rename: a killed run leaves the old file
    whole (the generated docs: RESULTS.md, MODELS.md's tables)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text)
    os.replace(tmp, path)
    return path


def write_bytes_atomic(path: Path | str, data: bytes) -> Path:
    """``write_text_atomic`` for bytes: a killed run leaves no half-written file (the old one, or none)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp-{os.getpid()}")
    try:
        tmp.write_bytes(data)
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path


def write_npy_atomic(path: Path | str, array) -> Path:
    """``numpy.save`` of ``array`` to exactly ``path`` (no .npy appended), whole or not at all."""
    buf = io.BytesIO()
    np.save(buf, array)
    return write_bytes_atomic(path, buf.getvalue())
