"""The one error type the mocap readers raise: it names the file, the line and what was expected."""

from __future__ import annotations


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
