"""Where a CLI may write (or replace) a folder or file, and the atomic replace itself.

Every CLI that replaces a whole ``--out`` (``emdm.data.prepare``, ``emdm.data.pack --unpack``, the
archive cache of ``emdm.data.unpack``) asks ``check_out`` first:

* an ``--out`` that is, or holds, the repository, a filesystem root or the home folder is refused always;
* an ``--out`` equal to or inside an input folder, or holding an input (file or folder), is refused always
  (replacing it would delete what the run reads);
* an existing ``--out`` that this tool did not write (``recognise`` says no; an empty folder is fine) is
  refused unless ``force``.

``replace_dir`` then renames a finished temp folder (made beside ``out``) into place; an older ``out`` is
renamed aside first and removed only once the new one is in place (put back if that rename fails).
A refusal is an ``OutputRefused`` whose message is one line: the path and why.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from typing import Callable, Iterable

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


def replace_dir(tmp: Path, out: Path) -> None:
    """Rename the finished folder ``tmp`` (beside ``out``) onto ``out``; an older ``out`` is removed only
    after the new one is in place."""
    tmp, out = Path(tmp), Path(out)
    os.chmod(tmp, 0o755)  # mkdtemp makes it private
    if not out.exists() and not out.is_symlink():
        os.replace(tmp, out)
        return
    old = out.with_name(f".{out.name}.old-{os.getpid()}")
    os.replace(out, old)
    try:
        os.replace(tmp, out)
    except BaseException:
        os.replace(old, out)
        raise
    if old.is_dir() and not old.is_symlink():
        shutil.rmtree(old, ignore_errors=True)
    else:
        old.unlink()
