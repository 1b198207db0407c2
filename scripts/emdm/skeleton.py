"""The 22-joint SMPL-order skeleton every clip is retargeted onto, and the motion format constants.

Conventions (shared with the TypeScript side through ``public/models/manifest.json``):

* Y is up, metres, the character faces +Z in the rest pose and its LEFT side is at +X.
* ``REFERENCE_OFFSETS[j]`` is joint j's offset from its parent in the rest T-pose (arms straight
  out along +-X, legs straight down). The pelvis row is its height above the floor
  (0.94 m: with the feet on the floor the ball-of-foot joints 10/11 are at y = 0).
* Proportions follow SMPL's neutral body (about 1.72 m tall), made exactly left/right symmetric.
"""

from __future__ import annotations

import numpy as np

JOINT_NAMES: list[str] = [
    "pelvis", "l_hip", "r_hip", "spine1", "l_knee", "r_knee", "spine2", "l_ankle", "r_ankle",
    "spine3", "l_foot", "r_foot", "neck", "l_collar", "r_collar", "head", "l_shoulder",
    "r_shoulder", "l_elbow", "r_elbow", "l_wrist", "r_wrist",
]
NUM_JOINTS = 22

PARENTS: list[int] = [-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19]

KINEMATIC_CHAINS: list[list[int]] = [
    [0, 2, 5, 8, 11],
    [0, 1, 4, 7, 10],
    [0, 3, 6, 9, 12, 15],
    [9, 14, 17, 19, 21],
    [9, 13, 16, 18, 20],
]

# l_ankle, l_foot, r_ankle, r_foot: the order of the four contact channels [259:263].
FOOT_JOINTS: list[int] = [7, 10, 8, 11]
# The hips and shoulders, used for the facing direction (right minus left, see motion.features).
L_HIP, R_HIP, L_SHOULDER, R_SHOULDER = 1, 2, 16, 17

FPS = 20
MAX_FRAMES = 196
MIN_FRAMES = 16   # shortest take kept by emdm.data.prepare (0.8 s; HDM05 has many 1-repetition clips)
FEATURE_DIM = 263

# Offsets from the parent joint in the rest T-pose (metres). Left joints have x > 0.
_HALF: dict[str, tuple[float, float, float]] = {
    # name: offset of the LEFT joint (the right one mirrors x)
    "hip": (0.070, -0.090, -0.005),
    "knee": (0.035, -0.370, 0.005),
    "ankle": (-0.005, -0.420, -0.040),
    "foot": (0.025, -0.060, 0.120),
    "collar": (0.075, 0.120, -0.020),
    "shoulder": (0.100, 0.030, -0.010),
    "elbow": (0.260, 0.000, 0.000),
    "wrist": (0.250, 0.000, 0.000),
}


def _build_offsets() -> np.ndarray:
    off = np.zeros((NUM_JOINTS, 3), dtype=np.float64)
    off[0] = (0.0, 0.940, 0.0)          # pelvis above the floor
    off[3] = (0.0, 0.110, -0.025)       # spine1
    off[6] = (0.0, 0.130, 0.030)        # spine2
    off[9] = (0.0, 0.055, 0.000)        # spine3
    off[12] = (0.0, 0.210, -0.020)      # neck
    off[15] = (0.0, 0.070, 0.045)       # head (centre of the skull)
    for name, (x, y, z) in _HALF.items():
        off[JOINT_NAMES.index("l_" + name)] = (x, y, z)
        off[JOINT_NAMES.index("r_" + name)] = (-x, y, z)
    return off


REFERENCE_OFFSETS: np.ndarray = _build_offsets()

# MIRROR_PERMUTATION[j] is the joint that j becomes in a left<->right mirrored copy.
MIRROR_PERMUTATION: list[int] = [
    JOINT_NAMES.index(n.replace("l_", "#").replace("r_", "l_").replace("#", "r_")) if n[:2] in ("l_", "r_")
    else JOINT_NAMES.index(n)
    for n in JOINT_NAMES
]


def rest_pose() -> np.ndarray:
    """World joint positions (22, 3) of the reference skeleton in its rest T-pose, feet on the floor."""
    pos = np.zeros((NUM_JOINTS, 3))
    for j, p in enumerate(PARENTS):
        pos[j] = REFERENCE_OFFSETS[j] if p < 0 else pos[p] + REFERENCE_OFFSETS[j]
    return pos


def bone_lengths() -> np.ndarray:
    """(22,) length of each joint's bone to its parent (0 for the pelvis)."""
    lengths = np.linalg.norm(REFERENCE_OFFSETS, axis=1)
    lengths[0] = 0.0
    return lengths


def mirror_joints(joints: np.ndarray) -> np.ndarray:
    """Left/right mirror of joint positions (..., 22, 3): swap sides and negate x."""
    out = np.asarray(joints)[..., MIRROR_PERMUTATION, :].copy()
    out[..., 0] *= -1.0
    return out
