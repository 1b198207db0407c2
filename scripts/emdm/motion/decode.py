"""De-normalised features → the joints a motion is shown with (Python twin of src/motion/decode.ts): recovered
(``emdm.motion.features.recover_joints``), smoothed along time (σ = 1 frame, ``emdm.motion.smooth``) and the feet
held where they touch the floor (``emdm.motion.foot_contact``). What the page and the library show and export by
default (``smooth: true, footCleanup: true``), so the benchmarks can judge the motion a visitor sees.
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk
from emdm.motion.features import recover_joints
from emdm.motion.foot_contact import cleanup_foot_contacts, contacts_from_features
from emdm.motion.smooth import smooth_frames


def decode_joints(features: np.ndarray, smooth: bool = True, foot_cleanup: bool = True,
                  parents=None, foot_joints=None) -> np.ndarray:
    """(frames, 263) de-normalised features → (frames, 22, 3) float32 joints, smoothed and cleaned up as asked."""
    features = np.asarray(features, np.float32)
    joints = recover_joints(features).astype(np.float32)
    frames = joints.shape[0]
    if smooth:
        joints = smooth_frames(joints.reshape(frames, -1), 1.0).reshape(joints.shape)
    if foot_cleanup:
        joints = cleanup_foot_contacts(joints, contacts_from_features(features),
                                       list(sk.PARENTS if parents is None else parents),
                                       list(sk.FOOT_JOINTS if foot_joints is None else foot_joints))
    return joints
