"""ASF/AMC (Acclaim) reader and forward kinematics (numpy, vectorised over frames).

ASF: ``:units`` (``length`` = file units per inch inverse, see below; ``angle deg|rad``),
``:root`` (``order`` of the root's AMC values, ``axis`` order of its orientation, ``position``,
``orientation``), ``:bonedata`` (``direction``, ``length``, ``axis ax ay az ORDER``, ``dof``) and
``:hierarchy``. AMC: optional ``:FULLY-SPECIFIED`` / ``:DEGREES`` / ``:RADIANS`` header lines,
then per frame a frame number and one line per bone with its values in ``dof`` order.

Forward kinematics (the Acclaim convention): with ``C`` the bone's axis rotation and ``M`` the
rotation built from its dof values (applied in dof order: the first listed is applied first, so
``rx ry rz`` gives ``M = Rz Ry Rx``), the bone's world rotation is ``W = W_parent C M C^-1`` and
its END point is ``start + length * W direction``. A bone's start is its parent's end (the root's
position for bones attached to the root). Points are named by bone (its end point) and ``root``.

Units: ASF ``length L`` means a value v is ``v / L`` inches (CMU and HDM05 use 0.45); positions
come back in metres (``v / L * 0.0254``) unless ``length_scale`` overrides that factor.

What a file can make the reader allocate is bounded (``emdm.mocap.textfile``): its size, ``MAX_BONES``
bones, ``MAX_FRAMES`` frames and ``MAX_VALUES`` values (kept as float64 arrays, not lists of floats).
"""

from __future__ import annotations

import math
from array import array
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from emdm.mocap.errors import MocapFormatError, parse_float
from emdm.mocap.rotations import axis_rotation
from emdm.mocap.textfile import check_frames, check_values, iter_lines, read_text

INCH = 0.0254
MAX_BONES = 1000           # real skeletons have ~30
MAX_DEGREES = 1e7          # a rotation beyond this (~28,000 turns) is a broken value: cos/sin of it are noise


@dataclass
class Bone:
    name: str
    direction: np.ndarray
    length: float
    axis: np.ndarray          # degrees or radians as in the file (converted when used)
    axis_order: str           # e.g. "xyz"
    dof: list[str]            # e.g. ["rx", "ry", "rz"]
    line: int


@dataclass
class ASF:
    path: str
    length_unit: float        # the ':units length' value
    angle_unit: str           # 'deg' or 'rad'
    root_order: list[str]     # e.g. ["tx", "ty", "tz", "rx", "ry", "rz"]
    root_axis: str            # e.g. "xyz"
    root_position: np.ndarray
    root_orientation: np.ndarray
    bones: dict[str, Bone]
    children: dict[str, list[str]] = field(default_factory=dict)
    parent: dict[str, str] = field(default_factory=dict)

    def order(self) -> list[str]:
        """Bone names, parents before children (breadth-first from root)."""
        out, queue = [], list(self.children.get("root", []))
        while queue:
            b = queue.pop(0)
            out.append(b)
            queue.extend(self.children.get(b, []))
        return out


@dataclass
class AMC:
    path: str
    angle_unit: str | None            # from ':DEGREES' / ':RADIANS' if present
    values: dict[str, np.ndarray]     # bone -> (F, n_dof)


def _floats(toks: list[str], path: str, line: int, what: str) -> list[float]:
    return [parse_float(t, path, line, what) for t in toks]


def parse_asf_text(text: str, path: str = "<asf>") -> ASF:
    text = text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text
    section = None
    length_unit, angle_unit = 1.0, "deg"
    root_order = ["tx", "ty", "tz", "rx", "ry", "rz"]
    root_axis = "xyz"
    root_pos = np.zeros(3)
    root_ori = np.zeros(3)
    bones: dict[str, Bone] = {}
    children: dict[str, list[str]] = {}
    parent: dict[str, str] = {}
    cur: dict | None = None
    saw_bonedata = False
    for ln, raw, _ in iter_lines(text):
        s = raw.split("#", 1)[0].strip()
        if not s:
            continue
        toks = s.split()
        if toks[0].startswith(":"):
            section = toks[0][1:].lower()
            if section == "bonedata":
                saw_bonedata = True
            continue
        key = toks[0].lower()
        if section == "units":
            if key == "length":
                length_unit = _floats(toks[1:2], path, ln, ":units length")[0] if len(toks) > 1 else 1.0
                if length_unit <= 0:
                    raise MocapFormatError(path, ln, f":units length must be positive, got {length_unit}")
            elif key == "angle":
                if len(toks) < 2 or toks[1].lower() not in ("deg", "rad", "degree", "degrees", "radian", "radians"):
                    raise MocapFormatError(path, ln, "expected ':units angle deg' or 'angle rad'")
                angle_unit = "rad" if toks[1].lower().startswith("rad") else "deg"
        elif section == "root":
            if key == "order":
                root_order = [t.lower() for t in toks[1:]]
                bad = [t for t in root_order if t not in ("tx", "ty", "tz", "rx", "ry", "rz")]
                if bad:
                    raise MocapFormatError(path, ln, f"unknown root order channel {bad[0]!r} (expected TX TY TZ RX RY RZ)")
            elif key == "axis":
                if len(toks) != 2 or sorted(toks[1].lower()) != ["x", "y", "z"]:
                    raise MocapFormatError(path, ln, "expected ':root axis' followed by an order such as XYZ")
                root_axis = toks[1].lower()
            elif key in ("position", "orientation"):
                if len(toks) != 4:
                    raise MocapFormatError(path, ln, f"expected ':root {key} x y z'")
                v = np.array(_floats(toks[1:4], path, ln, f"root {key}"))
                root_pos, root_ori = (v, root_ori) if key == "position" else (root_pos, v)
        elif section == "bonedata":
            if key == "begin":
                cur = {"line": ln, "dof": []}
            elif key == "end":
                if cur is None:
                    raise MocapFormatError(path, ln, "'end' without 'begin'")
                for need in ("name", "direction", "length"):
                    if need not in cur:
                        raise MocapFormatError(path, cur["line"], f"bone block has no '{need}'")
                if len(bones) >= MAX_BONES:
                    raise MocapFormatError(path, ln, f"more than {MAX_BONES} bones (real skeletons have ~30)")
                bones[cur["name"]] = Bone(cur["name"], cur["direction"], cur["length"], cur.get("axis", np.zeros(3)),
                                          cur.get("axis_order", "xyz"), cur["dof"], cur["line"])
                cur = None
            elif cur is None:
                raise MocapFormatError(path, ln, f"{toks[0]!r} outside a begin/end bone block")
            elif key == "name":
                if len(toks) != 2:
                    raise MocapFormatError(path, ln, "expected 'name <bone>'")
                cur["name"] = toks[1]
            elif key == "direction":
                d = np.array(_floats(toks[1:], path, ln, "direction"))
                if d.size != 3:
                    raise MocapFormatError(path, ln, "expected 'direction x y z'")
                cur["direction"] = d
            elif key == "length":
                if len(toks) != 2:
                    raise MocapFormatError(path, ln, "expected 'length <value>'")
                cur["length"] = _floats(toks[1:2], path, ln, "length")[0]
            elif key == "axis":
                if len(toks) != 5 or sorted(toks[4].lower()) != ["x", "y", "z"]:
                    raise MocapFormatError(path, ln, "expected 'axis ax ay az ORDER' (ORDER such as XYZ)")
                cur["axis"] = np.array(_floats(toks[1:4], path, ln, "axis"))
                cur["axis_order"] = toks[4].lower()
            elif key == "dof":
                dof = [t.lower() for t in toks[1:]]
                bad = [t for t in dof if t not in ("rx", "ry", "rz", "tx", "ty", "tz", "l")]
                if bad:
                    raise MocapFormatError(path, ln, f"unknown dof {bad[0]!r} (expected rx ry rz)")
                cur["dof"] = dof
        elif section == "hierarchy":
            if key in ("begin", "end"):
                continue
            par = toks[0]
            for c in toks[1:]:
                if c not in bones:
                    raise MocapFormatError(path, ln, f"hierarchy names bone {c!r}, which is not in :bonedata")
                if c in parent:
                    raise MocapFormatError(path, ln, f"bone {c!r} has two parents in :hierarchy")
                parent[c] = par
                children.setdefault(par, []).append(c)
            if par != "root" and par not in bones:
                raise MocapFormatError(path, ln, f"hierarchy names bone {par!r}, which is not in :bonedata")
    if not saw_bonedata or not bones:
        raise MocapFormatError(path, None, "no :bonedata section with bones")
    if "root" not in children:
        raise MocapFormatError(path, None, "no ':hierarchy' line starting with 'root'")
    return ASF(path, length_unit, angle_unit, root_order, root_axis, root_pos, root_ori, bones, children, parent)


def parse_amc_text(text: str, asf: ASF, path: str = "<amc>") -> AMC:
    text = text.replace("\r\n", "\n").replace("\r", "\n") if "\r" in text else text
    angle_unit = None
    counts = {b: len(asf.bones[b].dof) for b in asf.bones}
    counts["root"] = len(asf.root_order)
    rot_cols = {b: [i for i, d in enumerate(asf.bones[b].dof) if d[0] == "r"] for b in asf.bones}
    rot_cols["root"] = [i for i, d in enumerate(asf.root_order) if d[0] == "r"]
    rows: dict[str, array] = {b: array("d") for b in counts}
    per_frame = sum(counts.values())
    frame = 0
    frame_line = 0
    seen: set[str] = set()
    for ln, raw, _ in iter_lines(text):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith(":"):
            tag = s[1:].upper()
            if tag.startswith("DEG"):
                angle_unit = "deg"
            elif tag.startswith("RAD"):
                angle_unit = "rad"
            continue
        toks = s.split()
        if len(toks) == 1 and toks[0].isdigit():
            if frame:
                _check_frame_complete(rows, counts, frame, path, frame_line)
            frame += 1
            check_frames(path, ln, frame)
            check_values(path, ln, frame * per_frame)
            frame_line = ln
            seen = set()
            continue
        if frame == 0:
            raise MocapFormatError(path, ln, f"expected a frame number before {toks[0]!r}")
        bone = toks[0]
        if bone not in counts:
            raise MocapFormatError(path, ln, f"bone {bone!r} is not in the skeleton {asf.path}")
        if bone in seen:
            raise MocapFormatError(path, ln, f"bone {bone!r} appears twice in frame {frame}")
        seen.add(bone)
        vals = _floats(toks[1:], path, ln, f"bone {bone!r}")
        if len(vals) != counts[bone]:
            raise MocapFormatError(path, ln, f"bone {bone!r} has {len(vals)} values, expected {counts[bone]} (its dof)")
        limit = MAX_DEGREES if (angle_unit or asf.angle_unit) == "deg" else math.radians(MAX_DEGREES)
        for i in rot_cols[bone]:
            if abs(vals[i]) > limit:
                raise MocapFormatError(path, ln, f"bone {bone!r}: rotation {toks[1 + i]} is out of range (more than "
                                                 f"{MAX_DEGREES:g} degrees; the value is broken)")
        rows[bone].extend(vals)
    if frame == 0:
        raise MocapFormatError(path, None, "no frames found")
    _check_frame_complete(rows, counts, frame, path, frame_line)
    values = {b: np.frombuffer(v, dtype=np.float64).reshape(frame, counts[b]) for b, v in rows.items() if counts[b] > 0}
    return AMC(path, angle_unit, values)


def _check_frame_complete(rows: dict[str, array], counts: dict[str, int], frame: int,
                          path: str, ln: int) -> None:
    for b, r in rows.items():
        if counts[b] > 0 and len(r) < frame * counts[b]:
            raise MocapFormatError(path, ln, f"frame {frame} (starting at line {ln}) has no line for bone {b!r}")


def read_asf(path: str | Path) -> ASF:
    return parse_asf_text(read_text(path, "latin-1"), str(path))


def read_amc(path: str | Path, asf: ASF) -> AMC:
    return parse_amc_text(read_text(path, "latin-1"), asf, str(path))


def _euler(order: str, angles_by_axis: dict[str, np.ndarray], n: int) -> np.ndarray:
    """Rotation applying the axes in ``order`` (first applied first): R = R_last ... R_first."""
    R = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    for ax in order:
        if ax in angles_by_axis:
            R = axis_rotation(ax, angles_by_axis[ax]) @ R
    return R


def forward_kinematics(asf: ASF, amc: AMC, length_scale: float | None = None) -> tuple[list[str], np.ndarray]:
    """(point names ['root', bone...], positions (F, P, 3)) in metres (see module docstring). Finite values
    too big to compute with (a length of 1e308) give non-finite positions, quietly: the caller checks
    (``emdm.mocap.load.checked_joints`` names the frame)."""
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return _forward_kinematics(asf, amc, length_scale)


def _forward_kinematics(asf: ASF, amc: AMC, length_scale: float | None) -> tuple[list[str], np.ndarray]:
    scale = (INCH / asf.length_unit) if length_scale is None else length_scale
    ang = amc.angle_unit or asf.angle_unit
    to_rad = np.deg2rad if ang == "deg" else (lambda a: np.asarray(a, dtype=np.float64))
    axis_to_rad = np.deg2rad if asf.angle_unit == "deg" else (lambda a: np.asarray(a, dtype=np.float64))
    if "root" not in amc.values:
        raise MocapFormatError(amc.path, None, "no 'root' values")
    F = amc.values["root"].shape[0]
    rv = amc.values["root"]
    trans = np.zeros((F, 3))
    rots: dict[str, np.ndarray] = {}
    rot_order = ""
    for k, ch in enumerate(asf.root_order):
        if ch[0] == "t":
            trans[:, "xyz".index(ch[1])] = rv[:, k]
        else:
            rots[ch[1]] = to_rad(rv[:, k])
            rot_order += ch[1]
    Croot = _euler(asf.root_axis, {a: axis_to_rad(asf.root_orientation[i]) for i, a in enumerate("xyz")}, 1)[0]
    Mroot = _euler(rot_order, rots, F)
    W = {"root": Croot @ Mroot @ Croot.T}
    names = ["root"]
    ends = {"root": (trans + asf.root_position) * scale}
    for b in asf.order():
        bone = asf.bones[b]
        C = _euler(bone.axis_order, {a: axis_to_rad(bone.axis[i]) for i, a in enumerate("xyz")}, 1)[0]
        if b in amc.values and bone.dof:
            v = amc.values[b]
            angles = {d[1]: to_rad(v[:, i]) for i, d in enumerate(bone.dof) if d[0] == "r"}
            order = "".join(d[1] for d in bone.dof if d[0] == "r")
            M = _euler(order, angles, F)
        else:
            M = np.broadcast_to(np.eye(3), (F, 3, 3))
        par = asf.parent[b]
        Wb = W[par] @ (C @ M @ C.T)
        W[b] = Wb
        big = np.abs(bone.direction).max()
        d = bone.direction / big if big > 0 else bone.direction        # norm of 1e308 overflows
        d = d / max(np.linalg.norm(d), 1e-12)
        ends[b] = ends[par] + bone.length * scale * (Wb @ d)
        names.append(b)
    return names, np.stack([ends[n] for n in names], axis=1)
