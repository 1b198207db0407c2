"""Joint maps: a source skeleton's points -> the 22 SMPL-order joints, kept as JSON data.

A joint map file (see ``emdm/mocap/jointmaps/*.json`` and docs/DATA.md)::

    {"name": "bandai", "format": "bvh" | "asfamc",
     "scale": 0.01,              # file length unit -> metres (null for ASF: use its :units)
     "up": "y" | "z",            # the file's up axis (z-up is turned to y-up, keeping handedness)
     "drop_first_frames": 0,     # e.g. 1 when the first frame is a T-pose
     "joints": {"pelvis": "Hips", "spine2": {"lerp": ["Spine", "Chest", 0.5]}, ...}}

Every one of the 22 joints must be mapped, to a point name (a BVH joint, or for ASF/AMC a bone
name meaning the bone's END, or ``root``), to ``{"lerp": [a, b, t]}`` (a + t (b - a)) or to
``{"mean": [a, b, ...]}``.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from emdm import skeleton as sk
from emdm.mocap.errors import MocapFormatError

BUILTIN_DIR = Path(__file__).resolve().parent / "jointmaps"


@dataclass
class JointMap:
    name: str
    path: str
    format: str
    scale: float | None
    up: str
    drop_first_frames: int
    joints: dict[str, Any]

    def point_names(self) -> list[str]:
        out: list[str] = []
        for spec in self.joints.values():
            if isinstance(spec, str):
                out.append(spec)
            elif "lerp" in spec:
                out.extend(spec["lerp"][:2])
            else:
                out.extend(spec["mean"])
        return sorted(set(out))

    def apply(self, names: list[str], positions: np.ndarray, source: str = "") -> np.ndarray:
        """(F, P, 3) source points named ``names`` -> (F, 22, 3) metres, Y up."""
        index = {n: i for i, n in enumerate(names)}

        def get(n: str) -> np.ndarray:
            if n not in index:
                raise MocapFormatError(source or self.path, None,
                                       f"joint map {self.name!r} ({self.path}) needs point {n!r}, which the file does not have")
            return positions[:, index[n]]

        out = np.zeros((positions.shape[0], sk.NUM_JOINTS, 3))
        for j, jn in enumerate(sk.JOINT_NAMES):
            spec = self.joints[jn]
            if isinstance(spec, str):
                out[:, j] = get(spec)
            elif "lerp" in spec:
                a, b, t = spec["lerp"]
                pa = get(a)
                out[:, j] = pa + float(t) * (get(b) - pa)
            else:
                out[:, j] = np.mean([get(n) for n in spec["mean"]], axis=0)
        if self.scale is not None:
            out *= self.scale
        if self.up == "z":
            out = np.stack([out[..., 0], out[..., 2], -out[..., 1]], axis=-1)
        return out


def _fail(path: str, field: str, msg: str) -> MocapFormatError:
    return MocapFormatError(path, None, f"field '{field}': {msg}")


def parse_joint_map(data: Any, path: str) -> JointMap:
    if not isinstance(data, dict):
        raise MocapFormatError(path, None, "a joint map must be a JSON object")
    fmt = data.get("format")
    if fmt not in ("bvh", "asfamc"):
        raise _fail(path, "format", f"must be 'bvh' or 'asfamc', got {fmt!r}")
    scale = data.get("scale", None)
    if scale is not None and (not isinstance(scale, (int, float)) or scale <= 0):
        raise _fail(path, "scale", f"must be a positive number (file unit -> metres) or null, got {scale!r}")
    if fmt == "bvh" and scale is None:
        raise _fail(path, "scale", "BVH files need a scale (e.g. 0.01 for centimetres)")
    up = data.get("up", "y")
    if up not in ("y", "z"):
        raise _fail(path, "up", f"must be 'y' or 'z', got {up!r}")
    drop = data.get("drop_first_frames", 0)
    if not isinstance(drop, int) or drop < 0:
        raise _fail(path, "drop_first_frames", f"must be a non-negative integer, got {drop!r}")
    joints = data.get("joints")
    if not isinstance(joints, dict):
        raise _fail(path, "joints", "must be an object mapping the 22 joint names to points")
    missing = [n for n in sk.JOINT_NAMES if n not in joints]
    if missing:
        raise _fail(path, "joints", f"missing {', '.join(missing)} (all 22 SMPL-order joints are required)")
    extra = [n for n in joints if n not in sk.JOINT_NAMES]
    if extra:
        raise _fail(path, "joints", f"unknown joint {extra[0]!r} (expected one of {', '.join(sk.JOINT_NAMES)})")
    for jn, spec in joints.items():
        f = f"joints.{jn}"
        if isinstance(spec, str):
            continue
        if isinstance(spec, dict) and "lerp" in spec:
            v = spec["lerp"]
            if not (isinstance(v, list) and len(v) == 3 and isinstance(v[0], str) and isinstance(v[1], str)
                    and isinstance(v[2], (int, float))):
                raise _fail(path, f, "'lerp' must be [point_a, point_b, t]")
        elif isinstance(spec, dict) and "mean" in spec:
            v = spec["mean"]
            if not (isinstance(v, list) and v and all(isinstance(x, str) for x in v)):
                raise _fail(path, f, "'mean' must be a non-empty list of point names")
        else:
            raise _fail(path, f, "must be a point name, {\"lerp\": [a, b, t]} or {\"mean\": [a, ...]}")
    return JointMap(str(data.get("name", Path(path).stem)), path, fmt, None if scale is None else float(scale),
                    up, drop, joints)


def load_joint_map(name_or_path: str | Path) -> JointMap:
    """A built-in map by name ('bandai', 'cmu_asfamc', 'cmu_cc_bvh') or a JSON file path."""
    p = Path(name_or_path)
    builtin = ", ".join(sorted(q.stem for q in BUILTIN_DIR.glob("*.json")))
    if not p.suffix and not p.exists():
        p = BUILTIN_DIR / f"{name_or_path}.json"
        if not p.is_file():
            raise FileNotFoundError(f"joint map {str(name_or_path)!r} is neither a built-in map ({builtin}) nor a "
                                    "JSON file; give one of those names or the path of your map (see docs/DATA.md)")
    if not p.is_file():
        raise FileNotFoundError(f"{p}: joint map file not found (built-in maps: {builtin})")
    try:
        data = json.loads(p.read_text())
    except json.JSONDecodeError as e:
        raise MocapFormatError(str(p), e.lineno, f"invalid JSON at column {e.colno}: {e.msg}") from e
    return parse_joint_map(data, str(p))
