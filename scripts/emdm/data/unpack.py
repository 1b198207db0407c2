"""Unpack a shared ``.tar.xz`` mocap archive once into ``data/raw/<name>/`` (atomic: a temp folder
renamed into place, marked complete), and reuse it on later runs.

Archives are checked member by member before anything is written (``unsafe_member``): links, devices,
FIFOs and paths that resolve outside the target folder are refused, naming the member; extraction then
runs through tarfile's ``"data"`` filter as a second line of defence. A ``<name>/`` folder that this
function did not write (no ``.unpacked`` marker) is left alone unless ``force``."""

from __future__ import annotations

import shutil
import tarfile
from pathlib import Path

from emdm import paths
from emdm.outdir import announce_recovery, check_out, replace_dir, temp_dir

MARKER = ".unpacked"


class UnsafeArchiveError(ValueError):
    """An archive member that must not be extracted (the message names the archive and the member)."""


def unsafe_member(member: tarfile.TarInfo, root: Path) -> str:
    """Why ``member`` must not be extracted under the folder ``root`` ('' when it is a plain file or folder
    that stays inside it). Containment is checked on resolved paths, not by string prefix."""
    if member.issym() or member.islnk():
        return f"is a {'symbolic' if member.issym() else 'hard'} link (to {member.linkname!r}); links are not extracted"
    if member.ischr() or member.isblk() or member.isfifo():
        return "is a device or FIFO; only plain files and folders are extracted"
    if not (member.isfile() or member.isdir()):
        return "is not a plain file or folder"
    base = root.resolve()
    target = (base / member.name).resolve()
    if Path(member.name).is_absolute() or not target.is_relative_to(base) or target == base and member.isfile():
        return f"would be written outside the target folder (to {target})"
    return ""


def check_members(tar: tarfile.TarFile, root: Path, archive: Path) -> list[tarfile.TarInfo]:
    """Every member of ``tar``, or UnsafeArchiveError naming the first one that is not safe under ``root``."""
    members = tar.getmembers()
    for m in members:
        why = unsafe_member(m, root)
        if why:
            raise UnsafeArchiveError(f"{archive}: refusing member {m.name!r}: it {why}")
    return members


def unpack_archive(archive: Path, dest_root: Path | None = None, force: bool = False) -> Path:
    archive = Path(archive)
    if not archive.is_file():
        raise FileNotFoundError(f"{archive}: archive not found (see the shared data README)")
    dest_root = Path(dest_root) if dest_root is not None else paths.DATA_DIR / "raw"
    name = archive.name.split(".tar")[0]
    dest = dest_root / name
    announce_recovery(dest, f"unpack folder {dest}")   # a run killed while publishing it: finish or undo that
    if (dest / MARKER).is_file():
        return dest
    check_out(dest, inputs=[("archive", archive)], force=force, recognise=lambda d: (d / MARKER).is_file(),
              what="an archive unpacked by emdm.data.unpack", option="unpack folder")
    dest_root.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(dest)
    try:
        with tarfile.open(archive, "r:*") as tar:
            members = check_members(tar, tmp, archive)
            tar.extractall(tmp, members=members, filter="data")
        (tmp / MARKER).write_text(f"{archive.name}\n")
        replace_dir(tmp, dest)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return dest
