"""Vectorised Euler-angle rotation matrices shared by the BVH and ASF/AMC readers."""

from __future__ import annotations

import numpy as np


def axis_rotation(axis: str, angle: np.ndarray) -> np.ndarray:
    """(..., 3, 3) right-handed rotation matrices about 'x', 'y' or 'z' by angle (radians)."""
    a = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros(a.shape + (3, 3))
    axis = axis.lower()
    if axis == "x":
        R[..., 0, 0] = 1.0
        R[..., 1, 1], R[..., 1, 2], R[..., 2, 1], R[..., 2, 2] = c, -s, s, c
    elif axis == "y":
        R[..., 1, 1] = 1.0
        R[..., 0, 0], R[..., 0, 2], R[..., 2, 0], R[..., 2, 2] = c, s, -s, c
    elif axis == "z":
        R[..., 2, 2] = 1.0
        R[..., 0, 0], R[..., 0, 1], R[..., 1, 0], R[..., 1, 1] = c, -s, s, c
    else:
        raise ValueError(f"unknown rotation axis {axis!r} (expected x, y or z)")
    return R


def euler_matrix(axes: str, angles: np.ndarray) -> np.ndarray:
    """Compose rotations about the axes listed (e.g. "zxy") as R = R_axes[0] @ R_axes[1] @ ...

    ``angles`` is (..., len(axes)) in radians. This is the BVH convention (channels listed in the
    order they multiply, the last listed is applied to the vector first)."""
    angles = np.asarray(angles, dtype=np.float64)
    R = None
    for i, ax in enumerate(axes):
        r = axis_rotation(ax, angles[..., i])
        R = r if R is None else R @ r
    if R is None:
        return np.broadcast_to(np.eye(3), angles.shape[:-1] + (3, 3)).copy()
    return R
