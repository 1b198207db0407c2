"""BVH reader and forward kinematics (numpy, vectorised over frames).

Supports any channel count per joint (0-6: position and rotation channels in any order), End
Sites (kept as joints named ``<parent>_End`` with no channels), any rotation order (channels
multiply in the order listed: ``Zrotation Xrotation Yrotation`` -> R = Rz Rx Ry) and any length
unit (positions are returned in file units; the joint map says how to convert).

Position channels replace the joint's OFFSET (the usual convention); joints without position
channels use their OFFSET. Rotation channels are in degrees.

Every number must be finite, a rotation within ``MAX_DEGREES`` (beyond it cos/sin are noise) and the
Frame Time within ``FRAME_TIME_RANGE`` seconds; otherwise ``MocapFormatError`` names the line. What a file
can make the reader allocate is bounded (``emdm.mocap.textfile``): its size, ``MAX_JOINTS`` joints in a
HIERARCHY of at most ``MAX_HIERARCHY_CHARS``, ``MAX_FRAMES`` frames and ``MAX_VALUES`` motion values.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emdm.mocap.errors import MocapFormatError, parse_float
from emdm.mocap.rotations import axis_rotation
from emdm.mocap.textfile import check_frames, check_values, iter_lines, read_text

MAX_DEGREES = 1e7                      # ~28,000 turns: more is a broken value, not an unwrapped spin
FRAME_TIME_RANGE = (1e-5, 10.0)        # seconds: 100,000 fps .. 0.1 fps
MAX_JOINTS = 1000                      # real rigs have 20-150 (fingers included)
MAX_HIERARCHY_CHARS = 4 * 2 ** 20      # ~4,000 characters a joint at MAX_JOINTS
_CHUNK = 4 * 2 ** 20                   # motion text parsed this many characters at a time
_MOTION = re.compile(r"^[ \t]*MOTION(?=\s|$)", re.M | re.I)
_CHANNELS = {"xposition", "yposition", "zposition", "xrotation", "yrotation", "zrotation"}


@dataclass
class BVH:
    path: str
    names: list[str]
    parents: list[int]
    offsets: np.ndarray                  # (J, 3) file units
    channels: list[list[str]]            # per joint, lower-case channel names, in file order
    channel_start: list[int]             # index of each joint's first channel in a motion row
    frame_time: float
    motion: np.ndarray                   # (F, C) raw channel values
    end_site: list[bool] = field(default_factory=list)

    @property
    def fps(self) -> float:
        """1 / Frame Time, snapped to the nearest integer when within 0.01 % (files write 1/30 s
        as 0.0333333, which would otherwise lose the last frame when resampling)."""
        f = 1.0 / self.frame_time
        r = round(f)
        return float(r) if r > 0 and abs(f - r) < 1e-4 * f else f

    @property
    def num_frames(self) -> int:
        return int(self.motion.shape[0])

    def index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise KeyError(f"{self.path}: no joint named {name!r} (joints: {', '.join(self.names)})") from None


def _parse_hierarchy(lines: list[str], path: str):
    """HIERARCHY ... MOTION -> (names, parents, offsets, channels, end_site, index of the line after MOTION)."""
    names: list[str] = []
    parents: list[int] = []
    offsets: list[list[float]] = []
    channels: list[list[str]] = []
    end_site: list[bool] = []
    stack: list[int] = []
    pending: int | None = None   # joint declared, waiting for '{'
    i = 0
    n = len(lines)

    def next_nonempty(i: int) -> int:
        while i < n and not lines[i].strip():
            i += 1
        return i

    i = next_nonempty(0)
    if i >= n or lines[i].split()[0].upper() != "HIERARCHY":
        raise MocapFormatError(path, i + 1 if i < n else None, "expected 'HIERARCHY' at the start of a BVH file")
    i += 1
    while True:
        i = next_nonempty(i)
        if i >= n:
            raise MocapFormatError(path, n, "unexpected end of file inside HIERARCHY (expected 'MOTION')")
        toks = lines[i].split()
        key = toks[0].upper()
        lineno = i + 1
        if key in ("ROOT", "JOINT"):
            if key == "ROOT" and (stack or names):
                if stack:
                    raise MocapFormatError(path, lineno, "'ROOT' inside another joint")
                raise MocapFormatError(path, lineno, "only one ROOT hierarchy is supported")
            if key == "JOINT" and not stack:
                raise MocapFormatError(path, lineno, "'JOINT' outside of a ROOT block")
            if len(toks) < 2:
                raise MocapFormatError(path, lineno, f"expected a joint name after {toks[0]}")
            name = " ".join(toks[1:])
            _count_joint(names, path, lineno)
            names.append(name)
            parents.append(stack[-1] if stack else -1)
            offsets.append([np.nan, np.nan, np.nan])
            channels.append([])
            end_site.append(False)
            pending = len(names) - 1
        elif key == "END":
            if not stack:
                raise MocapFormatError(path, lineno, "'End Site' outside of a joint")
            parent = stack[-1]
            _count_joint(names, path, lineno)
            names.append(f"{names[parent]}_End")
            parents.append(parent)
            offsets.append([np.nan, np.nan, np.nan])
            channels.append([])
            end_site.append(True)
            pending = len(names) - 1
        elif key == "{":
            if pending is None:
                raise MocapFormatError(path, lineno, "'{' without a ROOT, JOINT or End Site before it")
            stack.append(pending)
            pending = None
        elif key == "}":
            if not stack:
                raise MocapFormatError(path, lineno, "unbalanced '}'")
            j = stack.pop()
            if np.isnan(offsets[j][0]):
                raise MocapFormatError(path, lineno, f"joint {names[j]!r} has no OFFSET")
        elif key == "OFFSET":
            if not stack:
                raise MocapFormatError(path, lineno, "OFFSET outside of a joint block")
            if len(toks) != 4:
                raise MocapFormatError(path, lineno, f"expected 'OFFSET x y z', got {len(toks) - 1} values")
            offsets[stack[-1]] = [parse_float(t, path, lineno, "OFFSET") for t in toks[1:]]
        elif key == "CHANNELS":
            if not stack:
                raise MocapFormatError(path, lineno, "CHANNELS outside of a joint block")
            j = stack[-1]
            if end_site[j]:
                raise MocapFormatError(path, lineno, "an End Site cannot have CHANNELS")
            try:
                count = int(toks[1])
            except (IndexError, ValueError):
                raise MocapFormatError(path, lineno, "expected 'CHANNELS <count> <names...>'") from None
            chans = [t.lower() for t in toks[2:]]
            if len(chans) != count:
                raise MocapFormatError(path, lineno, f"CHANNELS says {count} channels but lists {len(chans)}")
            for c in chans:
                if c not in _CHANNELS:
                    raise MocapFormatError(path, lineno, f"unknown channel {c!r} (expected X/Y/Z position or rotation)")
            if len(set(chans)) != len(chans):
                raise MocapFormatError(path, lineno, f"repeated channel in {' '.join(toks[2:])}")
            channels[j] = chans
        elif key == "MOTION":
            if stack:
                raise MocapFormatError(path, lineno, f"'MOTION' reached with {len(stack)} unclosed '{{'")
            if not names:
                raise MocapFormatError(path, lineno, "no ROOT joint before MOTION")
            i += 1
            break
        else:
            raise MocapFormatError(path, lineno, f"unexpected {toks[0]!r} in HIERARCHY")
        i += 1

    return names, parents, offsets, channels, end_site, i


def _count_joint(names: list[str], path: str, lineno: int) -> None:
    if len(names) >= MAX_JOINTS:
        raise MocapFormatError(path, lineno, f"more than {MAX_JOINTS} joints in HIERARCHY (real rigs have "
                                             "20-150): not a skeleton this reader takes")


def _hierarchy_lines(text: str, path: str) -> tuple[list[str], int]:
    """(the lines up to and including the MOTION line, offset of the MOTION line in ``text``; len(text) when
    there is none). A HIERARCHY longer than MAX_HIERARCHY_CHARS is refused before it is split into lines."""
    m = _MOTION.search(text)
    end = m.start() if m else len(text)
    if end > MAX_HIERARCHY_CHARS:
        raise MocapFormatError(path, None, f"the HIERARCHY is {end / 2 ** 20:.1f} MiB, more than the "
                                           f"{MAX_HIERARCHY_CHARS / 2 ** 20:.0f} MiB a rig of {MAX_JOINTS} joints "
                                           f"needs{'' if m else ' (and no MOTION line follows)'}")
    if not m:
        return text.split("\n"), end
    nl = text.find("\n", end)
    return text[:end].split("\n")[:-1] + [text[end:nl if nl >= 0 else len(text)]], end


def _normalise_newlines(text: str) -> str:
    return text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text


def read_bvh_names(path: str | Path) -> list[str]:
    """The joint names of a BVH file (End Sites as ``<parent>_End``), from its HIERARCHY only."""
    p = str(path)
    return _parse_hierarchy(_hierarchy_lines(_normalise_newlines(read_text(p)), p)[0], p)[0]


def _motion_header(text: str, start: int, lineno: int, path: str) -> tuple[int, float, int, int]:
    """(frames, frame time, line number of the first motion row, its offset) from the two lines after MOTION
    (``start``: the MOTION line's offset, ``lineno`` its number)."""
    header = []
    for ln, line, nxt in iter_lines(text, start, lineno):
        if ln > lineno and line.strip():
            header.append((ln, line.strip(), nxt))
            if len(header) == 2:
                break
    if not header or not header[0][1].lower().startswith("frames:"):
        raise MocapFormatError(path, header[0][0] if header else lineno, "expected 'Frames: <count>'")
    ln, line, _ = header[0]
    try:
        frames = int(line.split(":", 1)[1])
    except ValueError:
        raise MocapFormatError(path, ln, "expected an integer after 'Frames:'") from None
    if frames < 0:
        raise MocapFormatError(path, ln, f"'Frames: {frames}' is negative")
    check_frames(path, ln, frames)
    if len(header) < 2 or not header[1][1].lower().startswith("frame time:"):
        raise MocapFormatError(path, header[1][0] if len(header) > 1 else ln, "expected 'Frame Time: <seconds>'")
    ln, line, nxt = header[1]
    frame_time = parse_float(line.split(":", 1)[1].strip(), path, ln, "Frame Time")
    lo, hi = FRAME_TIME_RANGE
    if not lo <= frame_time <= hi:
        raise MocapFormatError(path, ln, f"Frame Time must be between {lo:g} and {hi:g} seconds "
                                         f"({1 / lo:g} to {1 / hi:g} fps), got {frame_time:g}")
    return frames, frame_time, ln + 1, nxt


def _parse_values(text: str, start: int, expected: int) -> np.ndarray | None:
    """The ``expected`` whitespace-separated numbers from ``text[start:]``, parsed a chunk at a time into one
    array (no list of tokens); None when they are not exactly that many numbers."""
    out = np.empty(expected)
    n, pos, size = 0, start, len(text)
    while pos < size:
        end = text.find("\n", min(pos + _CHUNK, size))
        end = size if end < 0 else end
        try:
            v = np.fromstring(text[pos:end], dtype=np.float64, sep=" ")
        except ValueError:
            return None
        if n + v.size > expected:
            return None
        out[n:n + v.size] = v
        n, pos = n + v.size, end + 1
    return out if n == expected else None


def parse_bvh_text(text: str, path: str = "<string>") -> BVH:
    text = _normalise_newlines(text)
    lines, motion_at = _hierarchy_lines(text, path)
    names, parents, offsets, channels, end_site, i = _parse_hierarchy(lines, path)
    frames, frame_time, first_line, first_at = _motion_header(text, motion_at, len(lines), path)
    starts, total = [], 0
    for c in channels:
        starts.append(total)
        total += len(c)
    check_values(path, first_line - 2, frames * total)
    values = _parse_values(text, first_at, frames * total)
    if values is None:
        _locate_motion_error(text.rstrip("\n").split("\n"), first_line - 1, frames, total, path)
    motion = values.reshape(frames, total) if total else np.zeros((frames, 0))
    _check_motion_values(motion, channels, names, text, first_line - 1, path)
    return BVH(path, names, parents, np.array(offsets, dtype=np.float64), channels, starts, frame_time, motion, end_site)


def _check_motion_values(motion: np.ndarray, channels: list[list[str]], names: list[str], text: str,
                         first: int, path: str) -> None:
    """Every value finite, every rotation within MAX_DEGREES; else the line, joint and channel."""
    owner = [(names[j], c) for j, chans in enumerate(channels) for c in chans]
    rot = np.array([c.endswith("rotation") for _, c in owner], dtype=bool)
    bad = ~np.isfinite(motion)
    bad_rot = np.zeros_like(bad)
    if rot.any():
        with np.errstate(invalid="ignore"):
            bad_rot[:, rot] = np.abs(motion[:, rot]) > MAX_DEGREES
    if not (bad.any() or bad_rot.any()):
        return
    flat = int(np.flatnonzero((bad | bad_rot).ravel())[0])
    row, col = divmod(flat, motion.shape[1])
    lines = text.split("\n")
    seen = 0
    for k in range(first, len(lines)):          # the line holding value number ``flat`` of the motion block
        toks = lines[k].split()
        if seen + len(toks) > flat:
            tok = toks[flat - seen]
            joint, chan = owner[col]
            where = f"motion row {row + 1}, joint {joint!r} {chan}"
            if bad.ravel()[flat]:
                raise MocapFormatError(path, k + 1, f"{where}: {tok!r} is not a finite number")
            raise MocapFormatError(path, k + 1, f"{where}: {tok} degrees is out of range (more than "
                                                f"{MAX_DEGREES:g} degrees; the value is broken)")
        seen += len(toks)


def _locate_motion_error(lines: list[str], first: int, frames: int, total: int, path: str) -> None:
    row = 0
    for k in range(first, len(lines)):
        toks = lines[k].split()
        if not toks:
            continue
        if row >= frames:
            raise MocapFormatError(path, k + 1, f"more motion rows than 'Frames: {frames}'")
        if len(toks) != total:
            raise MocapFormatError(path, k + 1, f"motion row {row + 1} has {len(toks)} values, expected {total} (one per channel)")
        for t in toks:
            parse_float(t, path, k + 1, f"motion row {row + 1}")
        row += 1
    raise MocapFormatError(path, len(lines), f"file has {row} motion rows, but the header says 'Frames: {frames}'"
                                             if row != frames else "a motion value is not a number this reader takes")


def read_bvh(path: str | Path) -> BVH:
    return parse_bvh_text(read_text(path), str(path))


def _needed(bvh: BVH, joints: list[int] | None) -> list[int]:
    if joints is None:
        return list(range(len(bvh.names)))
    keep: set[int] = set()
    for j in joints:
        while j >= 0 and j not in keep:
            keep.add(j)
            j = bvh.parents[j]
    return sorted(keep)  # parents are declared before children


def forward_kinematics(bvh: BVH, joints: list[int] | None = None) -> np.ndarray:
    """World positions (F, J, 3) in file units. With ``joints``, only those joints (and their
    ancestors) are computed; the others are NaN."""
    pos = np.full((bvh.num_frames, len(bvh.names), 3), np.nan)
    done = _needed(bvh, joints)
    pos[:, done] = joint_positions(bvh, done)
    return pos


def joint_positions(bvh: BVH, joints: list[int]) -> np.ndarray:
    """World positions (F, len(joints), 3) in file units of ``joints`` alone: their ancestors are computed
    and each one's rotation dropped once its last needed child is done, so memory follows the joints asked
    for, not the rig's size. Finite values too big to compute with give non-finite positions, quietly: the
    caller checks (``emdm.mocap.load.checked_joints``)."""
    with np.errstate(over="ignore", invalid="ignore"):
        return _joint_positions(bvh, joints)


def _joint_positions(bvh: BVH, joints: list[int]) -> np.ndarray:
    F = bvh.num_frames
    order = _needed(bvh, joints)
    pending = {j: 0 for j in order}           # needed children not yet computed
    for j in order:
        if bvh.parents[j] >= 0:
            pending[bvh.parents[j]] += 1
    want = set(joints)
    rot: dict[int, np.ndarray] = {}
    pos: dict[int, np.ndarray] = {}
    for j in order:
        R, t = _local(bvh, j)
        p = bvh.parents[j]
        if p < 0:
            rot[j], pos[j] = R, t
        else:
            rot[j] = rot[p] @ R
            pos[j] = pos[p] + np.einsum("fij,fj->fi", rot[p], t)
            pending[p] -= 1
            if not pending[p]:
                del rot[p]
                if p not in want:
                    del pos[p]
        if not pending[j]:
            rot.pop(j, None)
    return np.stack([pos[j] for j in joints], axis=1) if joints else np.zeros((F, 0, 3))


def _local(bvh: BVH, j: int) -> tuple[np.ndarray, np.ndarray]:
    """Joint j's rotation (F, 3, 3) and translation (F, 3) relative to its parent."""
    F = bvh.num_frames
    s = bvh.channel_start[j]
    t = np.broadcast_to(bvh.offsets[j], (F, 3)).copy()
    R = None
    for k, c in enumerate(bvh.channels[j]):
        v = bvh.motion[:, s + k]
        if c.endswith("position"):
            t[:, "xyz".index(c[0])] = v
        else:
            r = axis_rotation(c[0], np.deg2rad(v))
            R = r if R is None else R @ r
    if R is None:
        R = np.broadcast_to(np.eye(3), (F, 3, 3))
    return R, t
