"""Source joints -> the reference skeleton, HumanML3D style (numpy, pure functions).

``prepare_take`` = resample to 20 fps -> reference bone lengths -> floor at y = 0;
``normalize_clip`` = first frame's pelvis at x = z = 0 and facing +Z (per window).

Retargeting keeps every bone's DIRECTION per frame and replaces its length with the reference
skeleton's (``emdm.skeleton.REFERENCE_OFFSETS``), walking the kinematic tree from the pelvis, as
HumanML3D does with its IK/FK round trip. The pelvis trajectory is scaled by the ratio of the
reference leg length to the source's (median over frames), so foot steps keep their length
relative to the body.
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk
from emdm.motion.features import heading_angles, rot_y

LEG = [0, 1, 4, 7]   # pelvis -> l_hip -> l_knee -> l_ankle
LEG_R = [0, 2, 5, 8]


def resample(joints: np.ndarray, src_fps: float, dst_fps: float = sk.FPS) -> np.ndarray:
    """Linear interpolation of positions from src_fps to dst_fps (keeps the first frame)."""
    j = np.asarray(joints, dtype=np.float64)
    F = j.shape[0]
    if F == 0:
        return j.copy()
    duration = (F - 1) / src_fps
    n = int(np.floor(duration * dst_fps + 1e-6)) + 1
    t = np.arange(n) * (src_fps / dst_fps)
    i0 = np.minimum(np.floor(t).astype(int), F - 1)
    i1 = np.minimum(i0 + 1, F - 1)
    w = (t - i0)[:, None, None]
    return j[i0] * (1.0 - w) + j[i1] * w


def leg_length(joints: np.ndarray) -> float:
    """Median over frames of the mean left/right pelvis->hip->knee->ankle path length."""
    total = 0.0
    for chain in (LEG, LEG_R):
        seg = np.linalg.norm(joints[:, chain[1:]] - joints[:, chain[:-1]], axis=-1).sum(-1)
        total += float(np.median(seg))
    return total / 2.0


def reference_leg_length() -> float:
    return float(sum(np.linalg.norm(sk.REFERENCE_OFFSETS[j]) for j in LEG[1:]))


def retarget(joints: np.ndarray) -> np.ndarray:
    """Every bone gets the reference length, keeping its per-frame direction; root scaled."""
    j = np.asarray(joints, dtype=np.float64)
    src_leg = leg_length(j)
    if not src_leg > 1e-6:
        raise ValueError("retarget: the source legs have zero length (are the hips/knees/ankles mapped?)")
    scale = reference_leg_length() / src_leg
    out = np.zeros_like(j)
    out[:, 0] = j[:, 0] * scale
    lengths = np.linalg.norm(sk.REFERENCE_OFFSETS, axis=1)
    rest_dir = sk.REFERENCE_OFFSETS / np.maximum(lengths[:, None], 1e-12)
    for b in range(1, sk.NUM_JOINTS):
        p = sk.PARENTS[b]
        d = j[:, b] - j[:, p]
        n = np.linalg.norm(d, axis=-1, keepdims=True)
        d = np.where(n > 1e-9, d / np.maximum(n, 1e-12), rest_dir[b])
        out[:, b] = out[:, p] + lengths[b] * d
    return out


def put_on_floor(joints: np.ndarray) -> np.ndarray:
    """Shift so the lowest joint over the whole clip is at y = 0 (HumanML3D's floor)."""
    j = np.array(joints, dtype=np.float64)
    j[..., 1] -= j[..., 1].min()
    return j


def normalize_clip(joints: np.ndarray) -> np.ndarray:
    """First frame: pelvis at x = z = 0 and facing +Z (by emdm.motion.features' facing rule)."""
    j = np.array(joints, dtype=np.float64)
    j[..., 0] -= j[0, 0, 0]
    j[..., 2] -= j[0, 0, 2]
    theta0 = heading_angles(j[:1])[0]
    return rot_y(-theta0, j)


def prepare_take(joints: np.ndarray, src_fps: float) -> np.ndarray:
    """Source joints (F, 22, 3) metres Y up at src_fps -> reference skeleton, 20 fps, floor y = 0."""
    return put_on_floor(retarget(resample(joints, src_fps)))


def window_starts(frames: int, length: int = sk.MAX_FRAMES, stride: int = sk.MAX_FRAMES // 2,
                  min_frames: int = sk.MIN_FRAMES) -> list[tuple[int, int]]:
    """[start, end) windows covering a take: the whole take when it fits in ``length``, else
    windows of ``length`` frames every ``stride`` frames, the last one aligned to the end.
    Takes shorter than ``min_frames`` give no window."""
    if frames < min_frames:
        return []
    if frames <= length:
        return [(0, frames)]
    starts = list(range(0, frames - length + 1, stride))
    if starts[-1] != frames - length:
        starts.append(frames - length)
    return [(s, s + length) for s in starts]
