"""Read a mocap file's text with bounds: only a regular file (a FIFO would block the run forever, a device
never end), at most ``MAX_FILE_BYTES``; anything else is a ``MocapFormatError`` naming the file and why.

The readers bound what a file's contents can make them allocate as well (``bvh.MAX_JOINTS``,
``MAX_FRAMES``, ``MAX_VALUES``; ``asfamc.MAX_BONES``): together they keep one file's peak memory to a few
times its size, so one bad file is a skip, never a ``MemoryError`` that stops the whole run."""

from __future__ import annotations

import os
import stat
from pathlib import Path
from typing import Iterator

from emdm.mocap.errors import MocapFormatError

MAX_FILE_BYTES = 128 * 2 ** 20     # 128 MiB; the largest real take of the shared sources is ~4 MB
MAX_FRAMES = 100_000               # ~14 min at 120 fps; real takes have a few thousand
MAX_VALUES = 20_000_000            # frames x channels (160 MB as float64); real takes have < 1 M
_KINDS = {stat.S_ISDIR: "a folder", stat.S_ISFIFO: "a named pipe (FIFO)", stat.S_ISCHR: "a character device",
          stat.S_ISBLK: "a block device", stat.S_ISSOCK: "a socket"}


def read_text(path: str | Path, encoding: str = "utf-8", limit: int | None = None) -> str:
    """The file's text (undecodable bytes replaced), or MocapFormatError: unreadable, not a regular file,
    or larger than ``limit`` bytes (default MAX_FILE_BYTES). Opened without blocking, so a FIFO is refused
    instead of waited on."""
    p = str(path)
    limit = MAX_FILE_BYTES if limit is None else limit
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as e:
        raise MocapFormatError(p, None, f"cannot read: {e.strerror}") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            kind = next((k for test, k in _KINDS.items() if test(st.st_mode)), "not a plain file")
            raise MocapFormatError(p, None, f"is {kind}, not a regular file; only plain files are read")
        if st.st_size > limit:
            raise MocapFormatError(p, None, _too_big(st.st_size, limit))
        with os.fdopen(fd, "rb", closefd=False) as f:
            data = f.read(limit + 1)
    except OSError as e:
        raise MocapFormatError(p, None, f"cannot read: {e.strerror}") from None
    finally:
        os.close(fd)
    if len(data) > limit:
        raise MocapFormatError(p, None, _too_big(len(data), limit))
    return data.decode(encoding, errors="replace")


def _too_big(size: int, limit: int) -> str:
    return (f"{size / 2 ** 20:.0f} MiB is more than the {limit / 2 ** 20:.0f} MiB one mocap file may have "
            "(real takes are a few MB): split the take into shorter files")


def check_frames(path: str, line: int | None, frames: int) -> None:
    """MocapFormatError when a take has more than MAX_FRAMES frames."""
    if frames > MAX_FRAMES:
        raise MocapFormatError(path, line, f"{frames} frames is more than the {MAX_FRAMES} one take may have "
                                           "(~14 min at 120 fps): split the take into shorter files")


def iter_lines(text: str, start: int = 0, lineno: int = 1) -> Iterator[tuple[int, str, int]]:
    """(line number, line without its newline, offset of the next line) from ``text[start:]`` (whose first
    line is number ``lineno``), one at a time: no list of every line of a big file. Lines end at '\\n'."""
    size = len(text)
    while start < size:
        nl = text.find("\n", start)
        end = size if nl < 0 else nl
        yield lineno, text[start:end], end + 1
        start, lineno = end + 1, lineno + 1


def check_values(path: str, line: int | None, values: int) -> None:
    """MocapFormatError when a take holds more than MAX_VALUES numbers."""
    if values > MAX_VALUES:
        raise MocapFormatError(path, line, f"{values} motion values is more than the {MAX_VALUES} one take may "
                                           "have: split the take into shorter files")
