"""The one error type the mocap readers raise (it names the file, the line and what was expected), and their number
parsing."""

from __future__ import annotations

import math


class MocapFormatError(ValueError):
    """A motion-capture file (or joint map) is malformed."""

    def __init__(self, path: str, line: int | None, message: str):
        self.path = str(path)
        self.line = line
        self.message = message
        where = f"{self.path}:{line}" if line is not None else self.path
        super().__init__(f"{where}: {message}")

    def __reduce__(self):  # picklable, so worker processes can report it
        return (type(self), (self.path, self.line, self.message))


def parse_float(tok: str, path: str, line: int, what: str) -> float:
    """``tok`` as a finite float, else MocapFormatError naming the file, line and field (both readers' numbers)."""
    try:
        v = float(tok)
    except ValueError:
        raise MocapFormatError(path, line, f"expected a number for {what}, got {tok!r}") from None
    if not math.isfinite(v):
        raise MocapFormatError(path, line, f"{what}: {tok!r} is not a finite number")
    return v
