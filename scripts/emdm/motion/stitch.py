"""Continuing a motion with a new segment (docs/ARCHITECTURE.md "Sampling with constraints"); the TypeScript
twin is ``src/motion/stitch.ts``.

    nxt = recover_joints(next_features)                 # first `overlap` frames kept from prev's last ones
    whole = append_segment(prev_joints, nxt, overlap)   # (F_prev + F_next − overlap, 22, 3)

The features' root is relative, so ``recover_joints`` integrates each segment from heading 0 at the origin.
Integrating the new segment from the previous one's pose instead is a rigid move about +Y plus an x/z shift;
``align_segment`` applies it so that the new segment's frame ``overlap − 1`` (the copy of the previous last
frame) has the previous last frame's root x/z and heading (``emdm.motion.features.heading_angles``). Heights
stay as recovered (they are absolute).
"""

from __future__ import annotations

import numpy as np

from emdm.motion.features import _check_joints, heading_angles, rot_y


def align_segment(prev: np.ndarray, nxt: np.ndarray, overlap: int) -> np.ndarray:
    """``nxt`` (F, 22, 3) turned about +Y and shifted in x/z onto ``prev``'s last frame (see the module doc)."""
    p, n = _check_joints(prev, "prev"), _check_joints(nxt, "next")
    if not isinstance(overlap, (int, np.integer)) or not 1 <= overlap <= min(len(p), len(n)):
        raise ValueError(f"align_segment: overlap must be an integer in 1..{min(len(p), len(n))} (frames of next "
                         f"that repeat prev's last frames), got {overlap!r}")
    d_theta = heading_angles(p[-1:])[0] - heading_angles(n[overlap - 1:overlap])[0]
    anchor = n[overlap - 1, 0] * [1.0, 0.0, 1.0]
    out = rot_y(d_theta, n - anchor)
    out[..., 0] += p[-1, 0, 0]
    out[..., 2] += p[-1, 0, 2]
    return out.astype(np.float32)


def append_segment(prev: np.ndarray, nxt: np.ndarray, overlap: int) -> np.ndarray:
    """``prev`` followed by ``nxt`` aligned by ``align_segment`` without its first ``overlap`` frames."""
    aligned = align_segment(prev, nxt, overlap)
    return np.concatenate([np.asarray(prev, np.float32), aligned[overlap:]])
