"""Unpack a shared ``.tar.xz`` mocap archive once into ``data/raw/<name>/`` (atomic: a temp folder
renamed into place, marked complete), and reuse it on later runs."""

from __future__ import annotations

import os
import shutil
import tarfile
import tempfile
from pathlib import Path

from emdm import paths

MARKER = ".unpacked"


def unpack_archive(archive: Path, dest_root: Path | None = None) -> Path:
    archive = Path(archive)
    if not archive.is_file():
        raise FileNotFoundError(f"{archive}: archive not found (see the shared data README)")
    dest_root = Path(dest_root) if dest_root is not None else paths.DATA_DIR / "raw"
    name = archive.name.split(".tar")[0]
    dest = dest_root / name
    if (dest / MARKER).is_file():
        return dest
    dest_root.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.", dir=dest_root))
    try:
        with tarfile.open(archive, "r:*") as tar:
            for member in tar.getmembers():
                target = (tmp / member.name).resolve()
                if not str(target).startswith(str(tmp.resolve())) or member.issym() or member.islnk():
                    raise ValueError(f"{archive}: refusing unsafe member {member.name!r}")
            tar.extractall(tmp)
        (tmp / MARKER).write_text(f"{archive.name}\n")
        os.chmod(tmp, 0o755)  # mkdtemp makes it private
        if dest.exists():
            shutil.rmtree(dest)
        os.replace(tmp, dest)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return dest
