"""Foot-contact clean-up (Python twin of src/motion/footContact.ts, parity-tested on tests/fixtures/parity/decode.*).

The model predicts per-frame contacts for l_ankle, l_foot, r_ankle, r_foot (features [259:263]); where a joint is
in contact it should neither skate nor sink:

1. Floor: each frame whose lowest foot joint is below y = 0 is lifted as a whole by that depth.
2. Pinning: every contact run (≥ 2 frames with contact > threshold) of a foot joint is held at the run's mean
   position (y clamped to ≥ 0); the correction fades in and out linearly over ``blend`` frames on both sides.
3. Legs follow: a moved ankle re-solves its knee with two-bone IK (hip fixed, that frame's thigh and shin lengths,
   bending in the original knee's plane); the ball of the foot is placed at its original distance from the ankle,
   towards its pinned target; step 1 is repeated at the end (vertical lifts only).
"""

from __future__ import annotations

import numpy as np


def contacts_from_features(features: np.ndarray) -> np.ndarray:
    """The 4 contact channels of de-normalised features (frames, dim) → (frames, 4)."""
    return np.asarray(features, np.float64)[:, -4:]


def _runs(on: np.ndarray) -> list[tuple[int, int]]:
    """[first, last] of every run of True of at least 2 frames."""
    out, s = [], -1
    for f in range(len(on) + 1):
        cur = f < len(on) and bool(on[f])
        if cur and s < 0:
            s = f
        if not cur and s >= 0:
            if f - s >= 2:
                out.append((s, f - 1))
            s = -1
    return out


def _normalize(a: np.ndarray, fallback) -> np.ndarray:
    n = float(np.sqrt(a @ a))
    return a / n if n > 1e-12 else np.array(fallback, np.float64)


def two_bone_ik(a: np.ndarray, target: np.ndarray, pole: np.ndarray, l1: float, l2: float) -> tuple[np.ndarray, np.ndarray]:
    """Hip ``a``, ankle target, knee pole, thigh and shin lengths → (knee, reached ankle): math3.ts ``twoBoneIK``."""
    v = target - a
    d0 = float(np.sqrt(v @ v))
    direction = _normalize(v, [0.0, -1.0, 0.0])
    d = min(max(d0, abs(l1 - l2), 1e-9), l1 + l2)          # out of reach: straight
    x = (l1 * l1 - l2 * l2 + d * d) / (2 * d)
    h = np.sqrt(max(0.0, l1 * l1 - x * x))
    kp = pole - a
    side = kp - direction * (kp @ direction)
    if np.sqrt(side @ side) < 1e-9:
        side = np.array([0.0, 0.0, 1.0]) if abs(direction[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    side = side - direction * (side @ direction)
    knee = a + direction * x + _normalize(side, [0.0, 1.0, 0.0]) * h
    return knee, a + direction * d


def _floor(out: np.ndarray, foot_joints) -> None:
    low = out[:, list(foot_joints), 1].min(axis=1)
    lift = np.where(low < 0, low, 0.0)
    out[:, :, 1] -= lift[:, None]


def cleanup_foot_contacts(joints: np.ndarray, contacts: np.ndarray, parents, foot_joints, threshold: float = 0.5,
                          blend: int = 3) -> np.ndarray:
    """(frames, J, 3) joints and (frames, 4) contacts → cleaned joints (frames, J, 3) float32, computed in float64."""
    out = np.array(joints, np.float64)
    frames = out.shape[0]
    if contacts.shape != (frames, 4):
        raise ValueError(f"cleanup_foot_contacts: contacts has shape {contacts.shape}, expected ({frames}, 4)")
    if len(foot_joints) != 4:
        raise ValueError("cleanup_foot_contacts: foot_joints must list l_ankle, l_foot, r_ankle, r_foot")
    _floor(out, foot_joints)
    targets = []
    for c, j in enumerate(foot_joints):
        tgt = np.zeros((frames, 3))
        wgt = np.zeros(frames)
        for s, e in _runs(contacts[:, c] > threshold):
            m = out[s:e + 1, j].sum(axis=0) / (e - s + 1)
            m[1] = max(0.0, m[1])
            for f in range(max(0, s - blend), min(frames - 1, e + blend) + 1):
                w = 1 - (s - f) / (blend + 1) if f < s else (1 - (f - e) / (blend + 1) if f > e else 1.0)
                if w > wgt[f]:
                    wgt[f], tgt[f] = w, m
        targets.append((j, tgt, wgt))
    for ci, fi in ((0, 1), (2, 3)):
        ank_j, ank_t, ank_w = targets[ci]
        ball_j, ball_t, ball_w = targets[fi]
        knee_j = parents[ank_j]
        hip_j = parents[knee_j]
        for f in range(frames):
            a0, b0 = out[f, ank_j].copy(), out[f, ball_j].copy()
            a = a0
            if ank_w[f] > 0:
                want = a0 + (ank_t[f] - a0) * ank_w[f]
                hip, knee = out[f, hip_j], out[f, knee_j]
                k, a = two_bone_ik(hip, want, knee, float(np.linalg.norm(knee - hip)), float(np.linalg.norm(a0 - knee)))
                out[f, knee_j] = k
                out[f, ank_j] = a
            foot_len = float(np.linalg.norm(b0 - a0))
            bt = b0 + (a - a0)                               # carried along with the ankle
            if ball_w[f] > 0:
                bt = bt + (ball_t[f] - bt) * ball_w[f]
            if ank_w[f] > 0 or ball_w[f] > 0:
                d = bt - a
                n = float(np.sqrt(d @ d))
                out[f, ball_j] = a + (d / n if n > 1e-12 else _normalize(b0 - a0, [0.0, 1.0, 0.0])) * foot_len
    _floor(out, foot_joints)
    return out.astype(np.float32)
