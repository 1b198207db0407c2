"""Continuing a motion with a new segment, and pinning a kept later part in place (docs/ARCHITECTURE.md
"Sampling with constraints"); the TypeScript twin is ``src/motion/stitch.ts``.

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

from emdm.motion.features import check_joints, heading_angles, recover_root, rot_y


def align_segment(prev: np.ndarray, nxt: np.ndarray, overlap: int, ref: np.ndarray | None = None) -> np.ndarray:
    """``nxt`` (F, 22, 3) turned about +Y and shifted in x/z onto ``prev``'s last frame (see the module doc); the
    move is measured on ``ref`` (default ``nxt``; e.g. the recovered joints when ``nxt`` is their decoded version)."""
    p, n = check_joints(prev, "prev"), check_joints(nxt, "next")
    r = n if ref is None else check_joints(ref, "ref")
    if not isinstance(overlap, (int, np.integer)) or not 1 <= overlap <= min(len(p), len(n)):
        raise ValueError(f"align_segment: overlap must be an integer in 1..{min(len(p), len(n))} (frames of next "
                         f"that repeat prev's last frames), got {overlap!r}")
    d_theta = heading_angles(p[-1:])[0] - heading_angles(r[overlap - 1:overlap])[0]
    anchor = r[overlap - 1, 0] * [1.0, 0.0, 1.0]
    out = rot_y(d_theta, n - anchor)
    out[..., 0] += p[-1, 0, 0]
    out[..., 2] += p[-1, 0, 2]
    return out.astype(np.float32)


def append_segment(prev: np.ndarray, nxt: np.ndarray, overlap: int) -> np.ndarray:
    """``prev`` followed by ``nxt`` aligned by ``align_segment`` without its first ``overlap`` frames."""
    aligned = align_segment(prev, nxt, overlap)
    return np.concatenate([np.asarray(prev, np.float32), aligned[overlap:]])


def root_pose(features: np.ndarray, t: int) -> tuple[float, float, float]:
    """(x, z, heading θ) of frame t's recovered root (``recover_root``)."""
    theta, root = recover_root(np.asarray(features)[: t + 1])
    return float(root[t, 0]), float(root[t, 2]), float(theta[t])


def pin_root(features: np.ndarray, free: tuple[int, int], at: int, target: tuple[float, float, float]) -> np.ndarray:
    """Features whose root reaches ``target`` = (x, z, heading) at frame ``at`` (e.g. ``root_pose(known, at)``):
    the missing turn is spread evenly over the free frames' [0], then the missing x/z travel over their [1:3]
    (each in its frame's root frame). Only the free frames [start, end) change; end ≤ at (``src/motion/stitch.ts``
    ``pinRoot``)."""
    f = np.array(features, dtype=np.float32)
    s, e = free
    if not (0 <= s < e <= at < len(f)):
        raise ValueError(f"pin_root: free frames [{s}, {e}) must be a non-empty range ending at or before frame {at}, "
                         f"which must be < {len(f)}")
    n = e - s
    _, _, heading = root_pose(f, at)
    d_theta = np.arctan2(np.sin(target[2] - heading), np.cos(target[2] - heading))
    f[s:e, 0] += np.float32(-d_theta / 2 / n)                      # θ = −2·Σ f[·, 0]
    x, z, _ = root_pose(f, at)
    step = np.array([(target[0] - x) / n, 0.0, (target[1] - z) / n])
    theta, _ = recover_root(f[: e + 1])
    local = rot_y(-theta[s + 1:e + 1], np.broadcast_to(step, (n, 3)))   # f[k, 1:3] is turned by θ_{k+1}
    f[s:e, 1] += local[:, 0].astype(np.float32)
    f[s:e, 2] += local[:, 2].astype(np.float32)
    return f


def pin_kept_root(features: np.ndarray, keep: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``pin_root`` for every stretch of frames whose root velocities [0:3] are free, followed by a frame whose
    root is kept (pinned to ``root_pose(known, ·)``), so every kept frame decodes where ``recover_joints(known)``
    has it. ``keep``/``known`` (frames, 263), ``known`` de-normalised (``src/motion/stitch.ts`` ``pinKeptRoot``)."""
    f = np.array(features, np.float32)
    for name, a in (("keep", keep), ("known", known)):
        if np.shape(a) != f.shape:
            raise ValueError(f"pin_kept_root: {name} has shape {np.shape(a)}, features {f.shape}")
    root_kept = np.asarray(keep)[:, :3].astype(bool).any(1)
    t = 0
    while t < len(f):
        if root_kept[t]:
            t += 1
            continue
        e = t
        while e < len(f) and not root_kept[e]:
            e += 1
        if e < len(f):
            f = pin_root(f, (t, e), e, root_pose(known, e))
        t = e
    return f
