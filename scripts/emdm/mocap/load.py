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
    joints = jmap.apply(data.names, pos, str(path))
    return SourceClip(str(path), joints[jmap.drop_first_frames:], data.fps)


def load_amc_clip(path: str | Path, asf: asfamc.ASF, jmap: JointMap, fps: float = 120.0) -> SourceClip:
    motion = asfamc.read_amc(path, asf)
    names, pos = asfamc.forward_kinematics(asf, motion, length_scale=jmap.scale)
    joints = jmap.apply(names, pos, str(path))
    return SourceClip(str(path), joints[jmap.drop_first_frames:], fps)


def find_asf(amc_path: Path) -> Path:
    """The skeleton for an AMC file: 'HDM_bd_x.amc' -> 'HDM_bd.asf', '01_02.amc' -> '01.asf',
    or the only .asf in the folder."""
    folder = amc_path.parent
    stem = amc_path.stem
    candidates = []
    parts = stem.split("_")
    for k in range(len(parts) - 1, 0, -1):
        candidates.append(folder / ("_".join(parts[:k]) + ".asf"))
    for c in candidates:
        if c.is_file():
            return c
    asfs = sorted(folder.glob("*.asf")) + sorted(folder.glob("*.ASF"))
    if len(asfs) == 1:
        return asfs[0]
    raise MocapFormatError(str(amc_path), None,
                           f"no matching .asf skeleton in {folder} (tried {', '.join(c.name for c in candidates)})")
