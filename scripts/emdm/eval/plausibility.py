"""Physical plausibility of a motion given as joint positions (pure numpy).

Input: ``joints`` (F, 22, 3) in metres, Y up, floor at y = 0, ``fps`` frames per second (the
project's motions are 20 fps). The measures follow PhysDiff (Yuan et al., ICCV 2023), which the
EMDM paper's Tab. D5 reports, adapted from mesh vertices to the 22 skeleton joints:

* penetration: per frame, the depth of the lowest joint below the floor, max(0, −min_j y);
  reported as the mean over frames, in millimetres.
* floating: per frame, the height of the lowest joint above the floor beyond a tolerance,
  max(0, min_j y − float_tol); mean over frames, in millimetres. The tolerance absorbs the
  height of the toe joint above the sole (joints are inside the body, not on the skin).
* foot skate: for each foot joint (by default the two toe joints, SMPL ``l_foot``/``r_foot``)
  a frame pair (t, t+1) is *in contact* when the joint is below ``contact_height`` in both
  frames; skate is the mean horizontal (xz) speed of the joint over its contact pairs, in cm/s.
  ``skate_ratio`` is the fraction of frame pairs in which some foot in contact slides faster than
  ``skate_speed`` (GMD's foot-skating ratio: 2.5 cm per frame at 20 fps = 0.5 m/s).
* phys_err: PhysDiff's overall error, penetration + floating + skate, each in mm per frame
  (skate as horizontal displacement per frame in mm, i.e. speed / fps).

A motion whose feet never touch the floor has no contact pairs: its skate is 0 and it counts in
``contact_pairs`` as 0, so a floating motion cannot hide skating (floating reports it).
"""

from __future__ import annotations

from dataclasses import dataclass, asdict

import numpy as np

FOOT_JOINTS = (10, 11)        # SMPL l_foot, r_foot (toe joints)
CONTACT_HEIGHT = 0.05         # m: a foot joint below this is touching the floor
FLOAT_TOL = 0.05              # m: lowest joint allowed above the floor without counting as floating
SKATE_SPEED = 0.5             # m/s: sliding faster than this while in contact counts as skating
FLIP_M = 0.10                 # m: a joint leaving its neighbours' mean by more and coming back (a one-frame flip)


@dataclass(frozen=True)
class Plausibility:
    penetration_mm: float
    floating_mm: float
    skate_cm_s: float
    skate_ratio: float
    phys_err_mm: float
    contact_pairs: int
    frames: int

    def as_dict(self) -> dict:
        return asdict(self)


def _check_joints(joints) -> np.ndarray:
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[2] != 3 or j.shape[1] < 1:
        raise ValueError(f"joints: expected shape (frames, joints, 3), got {j.shape}")
    if j.shape[0] < 2:
        raise ValueError(f"joints: need at least 2 frames to measure skating, got {j.shape[0]}")
    if not np.all(np.isfinite(j)):
        f = int(np.argwhere(~np.isfinite(j))[0][0])
        raise ValueError(f"joints: non-finite position at frame {f}")
    return j


def motion_plausibility(joints, fps: float = 20.0, *, foot_joints=FOOT_JOINTS,
                        contact_height: float = CONTACT_HEIGHT, float_tol: float = FLOAT_TOL,
                        skate_speed: float = SKATE_SPEED) -> Plausibility:
    """Plausibility of one motion; see the module docstring for the definitions."""
    j = _check_joints(joints)
    if fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    if max(foot_joints) >= j.shape[1]:
        raise ValueError(f"foot_joints {foot_joints} out of range for {j.shape[1]} joints")
    lowest = j[:, :, 1].min(axis=1)                                     # (F,)
    penetration = np.maximum(0.0, -lowest).mean()
    floating = np.maximum(0.0, lowest - float_tol).mean()

    feet = j[:, list(foot_joints), :]                                   # (F, K, 3)
    low = feet[:, :, 1] < contact_height                                # (F, K)
    contact = low[:-1] & low[1:]                                        # (F-1, K)
    step = np.linalg.norm(feet[1:, :, [0, 2]] - feet[:-1, :, [0, 2]], axis=2)  # m per frame
    speed = step * fps                                                  # m/s
    n_contact = int(contact.sum())
    skate_speed_mean = float(speed[contact].mean()) if n_contact else 0.0
    skating = (contact & (speed > skate_speed)).any(axis=1)
    skate_mm_per_frame = skate_speed_mean / fps * 1000.0
    return Plausibility(
        penetration_mm=float(penetration * 1000.0),
        floating_mm=float(floating * 1000.0),
        skate_cm_s=skate_speed_mean * 100.0,
        skate_ratio=float(skating.mean()),
        phys_err_mm=float((penetration + floating) * 1000.0 + skate_mm_per_frame),
        contact_pairs=n_contact,
        frames=int(j.shape[0]),
    )


def batch_plausibility(motions, fps: float = 20.0, **kw) -> dict[str, np.ndarray]:
    """Per-motion measures for a list of (F_i, J, 3) motions: {name: array over motions}."""
    rows = []
    for i, m in enumerate(motions):
        try:
            rows.append(motion_plausibility(m, fps, **kw))
        except ValueError as e:
            raise ValueError(f"motion {i}: {e}") from None
    if not rows:
        raise ValueError("batch_plausibility: no motions")
    keys = rows[0].as_dict().keys()
    return {k: np.array([r.as_dict()[k] for r in rows]) for k in keys}


def flips(features: np.ndarray) -> np.ndarray:
    """(F,) per frame t = 1..F−2 (0 at the ends): the largest one-frame flip of a joint, metres — the distance of its
    position from the mean of its neighbours' (x_t − (x_{t−1} + x_{t+1})/2), counted when the neighbours are closer
    to each other than that (out and back within a frame, not a step). Joints as the features hold them: the root
    height and the 21 root-relative positions [4:67]."""
    f = np.asarray(features, np.float64)
    x = np.zeros((len(f), 22, 3))
    x[:, 0, 1] = f[:, 3]
    x[:, 1:] = f[:, 4:67].reshape(-1, 21, 3)
    out = np.zeros(len(f))
    if len(f) >= 3:
        d = np.linalg.norm(x[1:-1] - (x[:-2] + x[2:]) / 2, axis=2)
        across = np.linalg.norm(x[2:] - x[:-2], axis=2)
        out[1:-1] = np.where(across < d, d, 0.0).max(axis=1)
    return out


def flip_share(features_list) -> float:
    """Share of frames (t = 1..F−2 of every motion of ≥ 3 frames, pooled) with a one-frame flip (``flips``) of more
    than FLIP_M: how often a motion's joints jump out and back within one frame (real clips: 0.04 %)."""
    per = [flips(f)[1:-1] for f in features_list if len(f) >= 3]
    return float(np.mean(np.concatenate(per) > FLIP_M)) if per else 0.0
