"""Which parts of a motion the sampler keeps: frame ranges × feature groups → a (frames, 263) 0/1 mask
(docs/ARCHITECTURE.md "Sampling with constraints"; the TypeScript twin is ``src/sampler/mask.ts``, checked
against the ``tiny-mask`` parity fixture that ``python -m emdm.motion.mask_fixture`` writes).

    rects = [parse_keep("frames:0-19"), parse_keep("group:legs")]    # the union of two rectangles
    keep = keep_mask(120, rects)                                    # (120, 263) float32, 1 = kept

Feature groups (channels of the 263-d layout, ``emdm.motion.features``; joint j's channels are its
root-relative position [4+3(j−1) : 7+3(j−1)] and 6D rotation [67+6(j−1) : 73+6(j−1)] for j = 1..21, and its
velocity [193+3j : 196+3j] for j = 0..21):

* ``root``: [0:4] (angular velocity, xz velocity, height) and the pelvis velocity [193:196];
* ``legs``: hips, knees, ankles, feet, and the four foot contacts [259:263];
* ``upper``: spine1..3, neck, head, collars, shoulders, elbows, wrists.

The three are disjoint and cover all 263 channels.

Keep spec (``python -m emdm.sample --keep``, repeatable; the mask is the union): one rectangle is
``frames:RANGES``, ``group:NAMES`` or both joined by ``/`` (``frames:0-19/group:legs`` = the legs during
frames 0..19). RANGES: comma-separated ``A-B`` (inclusive), ``A`` or ``A-`` (to the last frame); NAMES:
comma-separated group names. A missing part means every frame / every group.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from emdm import skeleton as sk

FEATURE_DIM = sk.FEATURE_DIM
GROUP_JOINTS: dict[str, tuple[str, ...]] = {
    "root": ("pelvis",),
    "legs": ("l_hip", "r_hip", "l_knee", "r_knee", "l_ankle", "r_ankle", "l_foot", "r_foot"),
    "upper": ("spine1", "spine2", "spine3", "neck", "head", "l_collar", "r_collar", "l_shoulder", "r_shoulder",
              "l_elbow", "r_elbow", "l_wrist", "r_wrist"),
}
GROUPS = tuple(GROUP_JOINTS)


class KeepSpecError(ValueError):
    """A keep spec or mask argument that cannot be used, said in one line."""


def joint_channels(joint: int) -> list[int]:
    """The channels of one joint (0 = pelvis: root [0:4] and its velocity; 1..21: position, rotation, velocity)."""
    if not 0 <= joint < sk.NUM_JOINTS:
        raise KeepSpecError(f"joint index {joint} outside 0..{sk.NUM_JOINTS - 1}")
    vel = list(range(193 + 3 * joint, 196 + 3 * joint))
    if joint == 0:
        return [0, 1, 2, 3, *vel]
    pos = list(range(4 + 3 * (joint - 1), 7 + 3 * (joint - 1)))
    rot = list(range(67 + 6 * (joint - 1), 73 + 6 * (joint - 1)))
    return pos + rot + vel


def group_channels(group: str) -> list[int]:
    """Sorted channel indices of a feature group (``legs`` includes the foot contacts [259:263])."""
    if group not in GROUP_JOINTS:
        raise KeepSpecError(f"unknown feature group {group!r}; groups: {', '.join(GROUPS)}")
    ch = [c for name in GROUP_JOINTS[group] for c in joint_channels(sk.JOINT_NAMES.index(name))]
    if group == "legs":
        ch += list(range(259, 263))
    return sorted(ch)


@dataclass(frozen=True)
class KeepRect:
    """Frames × groups to keep. ``frames``: inclusive (start, end) ranges, end None = the last frame; None = all
    frames. ``groups``: group names; None = all groups."""
    frames: tuple[tuple[int, int | None], ...] | None = None
    groups: tuple[str, ...] | None = None


_RANGE = re.compile(r"^(\d+)(?:(-)(\d*))?$")


def parse_keep(spec: str) -> KeepRect:
    """``"frames:0-19/group:legs"`` → KeepRect; a bad spec raises KeepSpecError naming the part and the fix."""
    if not isinstance(spec, str) or not spec.strip():
        raise KeepSpecError("keep spec is empty; use e.g. frames:0-19, group:legs or frames:0-19/group:legs")
    frames = groups = None
    for part in spec.strip().split("/"):
        kind, sep, body = part.partition(":")
        kind = kind.strip()
        if not sep or kind not in ("frames", "group"):
            raise KeepSpecError(f"keep spec {spec!r}: part {part!r} must be frames:RANGES or group:NAMES "
                                f"(e.g. frames:0-19/group:legs)")
        items = [s.strip() for s in body.split(",")]
        if not all(items):
            raise KeepSpecError(f"keep spec {spec!r}: {kind}: has an empty entry")
        if kind == "frames":
            if frames is not None:
                raise KeepSpecError(f"keep spec {spec!r}: frames: given twice (list ranges with commas: frames:0-9,50-59)")
            rs = []
            for item in items:
                m = _RANGE.match(item)
                if not m:
                    raise KeepSpecError(f"keep spec {spec!r}: frame range {item!r} must be A-B (inclusive), A or A-")
                a = int(m.group(1))
                b = a if not m.group(2) else (int(m.group(3)) if m.group(3) else None)
                if b is not None and b < a:
                    raise KeepSpecError(f"keep spec {spec!r}: frame range {item!r} ends before it starts")
                rs.append((a, b))
            frames = tuple(rs)
        else:
            if groups is not None:
                raise KeepSpecError(f"keep spec {spec!r}: group: given twice (list groups with commas: group:root,legs)")
            for g in items:
                if g not in GROUP_JOINTS:
                    raise KeepSpecError(f"keep spec {spec!r}: unknown group {g!r}; groups: {', '.join(GROUPS)}")
            groups = tuple(items)
    return KeepRect(frames, groups)


def keep_mask(frames: int, rects: list[KeepRect] | tuple[KeepRect, ...], dim: int = FEATURE_DIM) -> np.ndarray:
    """(frames, dim) float32, 1 where some rectangle keeps the channel; a range past the motion is an error."""
    if dim != FEATURE_DIM:
        raise KeepSpecError(f"feature groups are defined for the {FEATURE_DIM}-d layout, got dim {dim}")
    if not isinstance(frames, (int, np.integer)) or frames < 1:
        raise KeepSpecError(f"frames must be a positive integer, got {frames!r}")
    mask = np.zeros((frames, dim), np.float32)
    for r in rects:
        rows = np.zeros(frames, bool)
        for a, b in (r.frames if r.frames is not None else ((0, None),)):
            end = frames - 1 if b is None else b
            if a >= frames or end >= frames:
                shown = f"{a}-{'' if b is None else b}" if b != a else str(a)
                raise KeepSpecError(f"keep: frame range {shown} goes past the motion's last frame {frames - 1}")
            rows[a:end + 1] = True
        cols = np.zeros(dim, bool)
        for g in (r.groups if r.groups is not None else GROUPS):
            cols[group_channels(g)] = True
        mask[np.ix_(rows, cols)] = 1.0
    return mask
