"""Inverse kinematics: 22 joint positions per frame → local joint rotations of the reference skeleton.

The 263-d format loses bone twist, so a rig is driven from positions. Per frame:
* the pelvis gets a full frame from (l_hip − r_hip) and (spine1 − pelvis); spine3 one from
  (l_collar − r_collar) and (neck − spine3) (the rest pose gives the reference frames);
* every other joint with a child gets the shortest-arc swing that turns its bone to the child, as
  carried by the parent's rotation, into the observed direction (no added twist);
* leaf joints (head, wrists, feet) keep the parent's orientation (identity local rotation).
Rotations are 3×3 matrices; local = parent_globalᵀ · global. ``forward_kinematics`` of the result with
the reference offsets reproduces the joint directions (positions exactly when bone lengths match).
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk

# the child whose bone a joint's swing aims at (joints with a frame or no child are absent)
PRIMARY_CHILD = {1: 4, 2: 5, 3: 6, 4: 7, 5: 8, 6: 9, 7: 10, 8: 11, 12: 15, 13: 16, 14: 17, 16: 18, 17: 19, 18: 20, 19: 21}
L_HIP, R_HIP, SPINE1, SPINE3, NECK, L_COLLAR, R_COLLAR = 1, 2, 3, 9, 12, 13, 14


def rest_positions() -> np.ndarray:
    pos = np.zeros((sk.NUM_JOINTS, 3))
    for j, p in enumerate(sk.PARENTS):
        pos[j] = sk.REFERENCE_OFFSETS[j] + (pos[p] if p >= 0 else 0.0)
    return pos


def _frame(across: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Orthonormal frame (..., 3, 3) with columns (x = across, y = up ⟂ across, z = x × y)."""
    x = across / np.maximum(np.linalg.norm(across, axis=-1, keepdims=True), 1e-9)
    y = up - np.sum(up * x, axis=-1, keepdims=True) * x
    y = y / np.maximum(np.linalg.norm(y, axis=-1, keepdims=True), 1e-9)
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=-1)


def _swing(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Shortest-arc rotation (..., 3, 3) turning u into v (both (..., 3), any length)."""
    u = u / np.maximum(np.linalg.norm(u, axis=-1, keepdims=True), 1e-9)
    v = v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)
    k = np.cross(u, v)
    c = np.sum(u * v, axis=-1)
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 0] = -k[..., 2], k[..., 1], k[..., 2]
    K[..., 1, 2], K[..., 2, 0], K[..., 2, 1] = -k[..., 0], -k[..., 1], k[..., 0]
    R = np.eye(3) + K + K @ K / np.maximum(1.0 + c, 1e-9)[..., None, None]
    opposite = c < -1.0 + 1e-7
    if np.any(opposite):       # half turn about an axis perpendicular to u
        axis = np.cross(u, [1.0, 0.0, 0.0])
        axis = np.where(np.linalg.norm(axis, axis=-1, keepdims=True) < 1e-6, np.cross(u, [0.0, 0.0, 1.0]), axis)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        half = 2.0 * axis[..., :, None] * axis[..., None, :] - np.eye(3)
        R = np.where(opposite[..., None, None], half, R)
    return R


def solve_ik(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(F, 22, 3) joints → (root positions (F, 3), local rotations (F, 22, 3, 3))."""
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (sk.NUM_JOINTS, 3):
        raise ValueError(f"solve_ik: expected joints of shape (frames, 22, 3), got {j.shape}")
    rest = rest_positions()
    n = j.shape[0]
    glob = np.zeros((n, sk.NUM_JOINTS, 3, 3))
    rest_pelvis = _frame(rest[L_HIP] - rest[R_HIP], rest[SPINE1] - rest[0])
    glob[:, 0] = _frame(j[:, L_HIP] - j[:, R_HIP], j[:, SPINE1] - j[:, 0]) @ rest_pelvis.T
    rest_chest = _frame(rest[L_COLLAR] - rest[R_COLLAR], rest[NECK] - rest[SPINE3])
    for b in range(1, sk.NUM_JOINTS):          # parents come before children in SMPL order
        parent = glob[:, sk.PARENTS[b]]
        if b == SPINE3:
            glob[:, b] = _frame(j[:, L_COLLAR] - j[:, R_COLLAR], j[:, NECK] - j[:, SPINE3]) @ rest_chest.T
        elif b in PRIMARY_CHILD:
            c = PRIMARY_CHILD[b]
            carried = parent @ (rest[c] - rest[b])
            glob[:, b] = _swing(carried, j[:, c] - j[:, b]) @ parent
        else:
            glob[:, b] = parent
    local = glob.copy()
    for b in range(1, sk.NUM_JOINTS):
        local[:, b] = np.swapaxes(glob[:, sk.PARENTS[b]], -1, -2) @ glob[:, b]
    return j[:, 0].copy(), local


def forward_kinematics(root: np.ndarray, local: np.ndarray, offsets: np.ndarray | None = None) -> np.ndarray:
    """(F, 3) root positions + (F, 22, 3, 3) local rotations → (F, 22, 3) joints (reference offsets)."""
    off = sk.REFERENCE_OFFSETS if offsets is None else offsets
    n = local.shape[0]
    glob = np.zeros_like(local)
    pos = np.zeros((n, sk.NUM_JOINTS, 3))
    glob[:, 0], pos[:, 0] = local[:, 0], root
    for b in range(1, sk.NUM_JOINTS):
        p = sk.PARENTS[b]
        glob[:, b] = glob[:, p] @ local[:, b]
        pos[:, b] = pos[:, p] + glob[:, p] @ off[b]
    return pos
