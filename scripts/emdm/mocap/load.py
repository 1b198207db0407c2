"""Read one mocap file (BVH or AMC) through a joint map: -> 22 joints in metres, Y up, source fps."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from emdm.mocap import asfamc, bvh
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.jointmap import JointMap


@dataclass
class SourceClip:
    path: str
    joints: np.ndarray   # (F, 22, 3) metres, Y up, source skeleton proportions
    fps: float


MAX_METRES = 1e5   # no joint of a real take is 100 km from the origin: beyond, a value or the map's scale is wrong


def checked_joints(joints: np.ndarray, path: str, jmap: JointMap) -> np.ndarray:
    """The mapped joints, or MocapFormatError when a value in the file is out of range: a joint position
    not finite or farther than MAX_METRES after the map's scale (squared in Mean/Std it would overflow)."""
    finite = np.isfinite(joints)
    if not finite.all():
        f = int(np.flatnonzero(~finite.all(axis=(1, 2)))[0])
        raise MocapFormatError(path, None, f"frame {f + 1}: joint positions are not finite after the joint map "
                                           f"{jmap.name!r}: a value in the file is out of range")
    far = float(np.abs(joints).max()) if joints.size else 0.0
    if far > MAX_METRES:
        f = int(np.flatnonzero(np.abs(joints).max(axis=(1, 2)) > MAX_METRES)[0])
        raise MocapFormatError(path, None, f"frame {f + 1}: a joint is {far:.3g} m from the origin after the joint "
                                           f"map {jmap.name!r} (limit {MAX_METRES:g} m): a value in the file is out "
                                           "of range, or the map's scale is wrong")
    return joints


def source_point_names(kind: str, path: str | Path, asf_path: str | Path = "") -> list[str]:
    """The point names a joint map can use for this file: a BVH's joints (End Sites as ``<parent>_End``)
    or, for an AMC, ``root`` and its ASF's bones. Reads the BVH hierarchy / the ASF only."""
    if kind == "bvh":
        return bvh.read_bvh_names(path)
    if not asf_path or not Path(asf_path).is_file():
        raise MocapFormatError(str(path), None, f"its skeleton {asf_path or '(.asf)'} is missing")
    return ["root", *asfamc.read_asf(asf_path).order()]


def load_bvh_clip(path: str | Path, jmap: JointMap) -> SourceClip:
    data = bvh.read_bvh(path)
    wanted = []
    for n in jmap.point_names():
        try:
            wanted.append(data.index(n))
        except KeyError:
            raise MocapFormatError(str(path), None,
                                   f"joint map {jmap.name!r} needs joint {n!r}, which this BVH does not have") from None
    pos = bvh.forward_kinematics(data, wanted)
    joints = checked_joints(jmap.apply(data.names, pos, str(path)), str(path), jmap)
    return SourceClip(str(path), joints[jmap.drop_first_frames:], data.fps)


def load_amc_clip(path: str | Path, asf: asfamc.ASF, jmap: JointMap, fps: float = 120.0) -> SourceClip:
    motion = asfamc.read_amc(path, asf)
    names, pos = asfamc.forward_kinematics(asf, motion, length_scale=jmap.scale)
    joints = checked_joints(jmap.apply(names, pos, str(path)), str(path), jmap)
    return SourceClip(str(path), joints[jmap.drop_first_frames:], fps)


def find_asf(amc_path: Path) -> Path:
    """The skeleton for an AMC file: 'take.amc' -> 'take.asf', 'HDM_bd_x.amc' -> 'HDM_bd.asf',
    '01_02.amc' -> '01.asf', or the only .asf in the folder; else MocapFormatError naming what it looked for."""
    folder = amc_path.parent
    parts = amc_path.stem.split("_")
    candidates = [folder / ("_".join(parts[:k]) + ".asf") for k in range(len(parts), 0, -1)]
    for c in candidates:
        if c.is_file():
            return c
    asfs = sorted(folder.glob("*.asf")) + sorted(folder.glob("*.ASF"))
    if len(asfs) == 1:
        return asfs[0]
    tried = ", ".join(c.name for c in candidates)
    found = f"the folder has {len(asfs)} .asf files, not exactly one" if asfs else "the folder has no .asf file"
    raise MocapFormatError(str(amc_path), None, f"its skeleton is missing: looked for {tried} in {folder} ({found}); "
                                                "put the .asf beside the .amc")
