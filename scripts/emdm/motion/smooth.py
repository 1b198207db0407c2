"""Temporal smoothing (Python twin of src/motion/smooth.ts ``smoothJoints``): a Gaussian filter along frames."""

from __future__ import annotations

import math

import numpy as np


def smooth_frames(x: np.ndarray, sigma: float, lengths: np.ndarray | None = None) -> np.ndarray:
    """A Gaussian filter along the frame axis (axis −2) of ``x`` (..., frames, D): radius r = max(1, ⌈3σ⌉), weights
    exp(−d²/2σ²) renormalised over the frames inside the clip (no padding), accumulated in float64 and returned as
    float32 — ``smoothJoints`` of src/motion/smooth.ts, which the page's sampler uses for the same step. σ = 0 or
    fewer than 3 frames: a copy. ``lengths`` (rows,) for x (rows, frames, D) padded past each row's length: each row
    is smoothed over its own first lengths[i] frames (its clip), its padding left as it is."""
    x = np.asarray(x, np.float32)
    if lengths is not None:
        out = x.copy()
        for i, n in enumerate(np.asarray(lengths, np.int64)):
            out[i, :n] = smooth_frames(x[i, :n], sigma)
        return out
    frames = x.shape[-2]
    if sigma == 0 or frames < 3:
        return x.copy()
    r = max(1, math.ceil(3 * sigma))
    w = np.exp(-np.arange(-r, r + 1, dtype=np.float64) ** 2 / (2 * sigma * sigma))
    xd = x.astype(np.float64)
    out = np.empty(x.shape, np.float64)
    for f in range(frames):
        lo, hi = max(0, f - r), min(frames - 1, f + r)
        ww = w[lo - f + r:hi - f + r + 1]
        out[..., f, :] = np.einsum("k,...kd->...d", ww, xd[..., lo:hi + 1, :]) / ww.sum()
    return out.astype(np.float32)


# The pose channels of the HumanML3D layout: the 21 root-relative joint positions [4:67] and their 6D rotations
# [67:193]. x̂0 smoothing touches these only: smoothing the root channels [0:4], the local velocities [193:259] or the
# foot contacts [259:263] of x̂0 made the sampler choose faster motion (measured, docs/MODELS.md "Smoothing x̂0": a
# walk at 2.5 m/s instead of 1.3 with every channel smoothed; 2.45 m/s with the contacts alone; 1.2 with the pose).
POSE_CHANNELS = (4, 193)


def smooth_pose(x: np.ndarray, sigma: float, lengths: np.ndarray | None = None) -> np.ndarray:
    """``smooth_frames`` on the pose channels of ``x`` (..., frames, 263) only; the other channels as they are.
    src/motion/smooth.ts ``smoothPose``."""
    a, b = POSE_CHANNELS
    out = np.array(x, np.float32)
    if x.shape[-1] < b:
        raise ValueError(f"smooth_pose: {x.shape[-1]} channels; the pose channels are [{a}, {b})")
    out[..., a:b] = smooth_frames(out[..., a:b], sigma, lengths)
    return out
