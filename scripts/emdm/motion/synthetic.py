"""A small synthetic motion of the reference skeleton, and the cross-language fixture built from it.

    python -m emdm.motion.synthetic      # writes tests/fixtures/data/recover_joints.json

The fixture holds 263-d features (rounded to 6 decimals) of a turning "walk" and the joints that
``emdm.motion.features.recover_joints`` recovers from exactly those numbers; the TypeScript and
torch ports of ``recover_joints`` test against it.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from emdm import paths
from emdm import skeleton as sk
from emdm.mocap.rotations import axis_rotation
from emdm.motion.features import extract_features, recover_joints, rot_y
from emdm.motion.retarget import normalize_clip, put_on_floor


def _below(j: int, root: int) -> bool:
    while j >= 0:
        j = sk.PARENTS[j]
        if j == root:
            return True
    return False


def swing(pose: np.ndarray, joint: int, angle: float, axis: str = "x") -> np.ndarray:
    """Rotate the joints below ``joint`` about it by ``angle`` (radians) about a world axis."""
    R = axis_rotation(axis, angle)
    out = pose.copy()
    sub = [j for j in range(sk.NUM_JOINTS) if _below(j, joint)]
    out[sub] = (pose[sub] - pose[joint]) @ R.T + pose[joint]
    return out


def synthetic_walk(frames: int = 60, turn_per_frame: float = 0.03, speed: float = 0.06) -> np.ndarray:
    """(frames, 22, 3): legs and arms swing, the heading turns left ever faster, the pelvis advances
    along its facing direction; first frame at the origin facing +Z, floor at y = 0."""
    out = np.zeros((frames, sk.NUM_JOINTS, 3))
    pos = np.zeros(3)
    for t in range(frames):
        phase = 0.4 * np.sin(t * 0.35)
        p = sk.rest_pose()
        p = swing(p, 1, phase)
        p = swing(p, 2, -phase)
        p = swing(p, 4, max(0.0, -phase))
        p = swing(p, 16, 1.2, "z")
        p = swing(p, 17, -1.2, "z")
        theta = turn_per_frame * t ** 1.1
        p = rot_y(theta, p)
        if t:
            pos = pos + rot_y(theta, np.array([0.0, 0.0, speed]))
        out[t] = p + pos * [1, 0, 1]
    return put_on_floor(normalize_clip(out))


def write_recover_fixture(path: Path | None = None, frames: int = 24) -> Path:
    path = Path(path) if path else paths.FIXTURES_DIR / "data" / "recover_joints.json"
    feats = np.round(extract_features(synthetic_walk(frames + 1)).astype(np.float64), 6)
    joints = recover_joints(feats)
    data = {
        "about": "emdm.motion.synthetic: features (N,263) of a synthetic turning walk, rounded to 6 decimals, "
                 "and joints (N,22,3) = emdm.motion.features.recover_joints(features)",
        "features": feats.tolist(),
        "joints": np.round(joints, 9).tolist(),
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, separators=(",", ":")) + "\n")
    return path


if __name__ == "__main__":
    print(write_recover_fixture())
