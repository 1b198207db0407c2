"""De-normalised features → the joints a motion is shown with (Python twin of src/motion/decode.ts): recovered
(``emdm.motion.features.recover_joints``), smoothed along time (σ = 1 frame, ``emdm.motion.smooth``) and the feet
held where they touch the floor (``emdm.motion.foot_contact``). What the page and the library show and export by
default (``smooth: true, footCleanup: true``), so the benchmarks can judge the motion a visitor sees.

A looping clip (``loop=True``, a loop's clip: its frame 0 follows its last) is decoded as the loop plays: with
``LOOP_PAD`` frames from its other end on each side, so the smoothing and the foot clean-up see across the wrap
(decoded alone, the two ends were smoothed and cleaned up apart: the in-place walk's wrap stepped up to 0.38 m
against in-loop steps of 0.28 m, ``python -m emdm.eval.seams``); then set back to start at the origin facing +Z.
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk
from emdm.motion.features import recover_joints, recover_root, rot_y
from emdm.motion.foot_contact import cleanup_foot_contacts, contacts_from_features
from emdm.motion.smooth import smooth_frames


LOOP_PAD = 10     # frames of a looping clip's other end decoded on each side (σ = 1 smoothing, 3-frame fades, gaps of 2)


def decode_joints(features: np.ndarray, smooth: bool = True, foot_cleanup: bool = True,
                  parents=None, foot_joints=None, loop: bool = False) -> np.ndarray:
    """(frames, 263) de-normalised features → (frames, 22, 3) float32 joints, smoothed and cleaned up as asked;
    ``loop``: the features are a looping clip (module doc)."""
    features = np.asarray(features, np.float32)
    if loop:
        return _decode_loop(features, smooth, foot_cleanup, parents, foot_joints)
    joints = recover_joints(features).astype(np.float32)
    frames = joints.shape[0]
    if smooth:
        joints = smooth_frames(joints.reshape(frames, -1), 1.0).reshape(joints.shape)
    if foot_cleanup:
        joints = cleanup_foot_contacts(joints, contacts_from_features(features),
                                       list(sk.PARENTS if parents is None else parents),
                                       list(sk.FOOT_JOINTS if foot_joints is None else foot_joints))
    return joints


def _decode_loop(features: np.ndarray, smooth: bool, foot_cleanup: bool, parents, foot_joints) -> np.ndarray:
    """``decode_joints`` of [last P frames, clip, first P frames] (P = min(LOOP_PAD, frames)), the clip's frames
    taken back and turned/shifted so that its frame 0's root is at the origin with heading 0 (as ``recover_joints``
    of the clip alone has it)."""
    n = len(features)
    p = min(LOOP_PAD, n)
    ext = np.concatenate([features[n - p:], features, features[:p]])
    joints = decode_joints(ext, smooth, foot_cleanup, parents, foot_joints)[p:p + n].astype(np.float64)
    theta, root = recover_root(ext)
    joints[..., 0] -= root[p, 0]
    joints[..., 2] -= root[p, 2]
    return rot_y(-theta[p], joints).astype(np.float32)
