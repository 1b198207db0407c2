"""Foot-contact clean-up (Python twin of src/motion/footContact.ts, parity-tested on tests/fixtures/parity/decode.*).

The model predicts per-frame contacts for l_ankle, l_foot, r_ankle, r_foot (features [259:263]); where a joint is
in contact it should neither skate nor sink:

1. Floor: each frame whose lowest foot joint is below y = 0 is lifted as a whole by that depth.
2. Pinning: every contact run (≥ 2 frames with contact > threshold, gaps of up to ``gap`` frames closed: the
   model's contacts flicker) of a foot joint is held at the run's mean position (y clamped to ≥ 0); the correction
   fades in and out over ``blend`` frames on both sides (smoothstep); where one plant's fade-out overlaps the next's
   fade-in (a run's short swing) the target is their weight-mixed mean, never a stride's jump in one frame. A run
   whose joint strays more than ``max_drift`` m (horizontally) from that mean is no plant but a contact the model got wrong (a foot sliding at walking speed):
   pinning it would hold the foot and then throw it up to a metre in one frame, so it is left as it is. A *stance*
   (a run of at most ``stance_frames`` frames: a step's foot is down for under a second) may stray up to
   ``stance_drift`` m: the generated runs' stances slide 20–40 cm (the model's runs outpace their strides), which the
   10 cm limit left sliding (the runs' foot skate 94 cm/s at the realism benchmark, real runs 37; 47 with it, and no
   joint step past the real clips' largest). A longer contact that strays is the body moving its foot (a pivot, a
   shuffle over seconds); held, its leg could not reach and the foot was dragged.
3. Legs follow: a moved ankle re-solves its knee with two-bone IK (hip fixed, that frame's thigh and shin lengths,
   bending in the original knee's plane); the ball of the foot is placed at its original distance from the ankle,
   towards its pinned target; step 1 is repeated at the end (vertical lifts only).
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk


def contacts_from_features(features: np.ndarray) -> np.ndarray:
    """The 4 contact channels of de-normalised features (frames, dim) → (frames, 4)."""
    return np.asarray(features, np.float64)[:, -4:]


FOOT_CLEANUP = {"threshold": 0.5, "blend": 3, "gap": 2, "max_drift": 0.1,    # footContact.ts FOOT_CLEANUP
                "stance_drift": 0.2, "stance_frames": 20}


def _runs(on: np.ndarray, gap: int) -> list[tuple[int, int]]:
    """[first, last] of every run of True, gaps of up to ``gap`` frames closed, of at least 2 frames."""
    raw, s = [], -1
    for f in range(len(on) + 1):
        cur = f < len(on) and bool(on[f])
        if cur and s < 0:
            s = f
        if not cur and s >= 0:
            if raw and s - raw[-1][1] - 1 <= gap:
                raw[-1][1] = f - 1
            else:
                raw.append([s, f - 1])
            s = -1
    return [(a, b) for a, b in raw if b - a + 1 >= 2]


def plant_runs(joints: np.ndarray, contacts: np.ndarray, threshold: float = FOOT_CLEANUP["threshold"],
               gap: int = FOOT_CLEANUP["gap"], max_drift: float = FOOT_CLEANUP["max_drift"], foot_joints=None,
               stance_drift: float = FOOT_CLEANUP["stance_drift"], stance_frames: int = FOOT_CLEANUP["stance_frames"]) -> list:
    """Per foot joint (l_ankle, l_foot, r_ankle, r_foot), the contact runs the clean-up pins: (first, last, mean
    position) — footContact.ts ``plantRuns``. A run may stray ``max_drift`` from its mean, a stance (at most
    ``stance_frames`` frames) the larger of that and ``stance_drift``."""
    out = []
    for c, j in enumerate(sk.FOOT_JOINTS if foot_joints is None else foot_joints):
        rs = []
        for s, e in _runs(contacts[:, c] > threshold, gap):
            m = joints[s:e + 1, j].astype(np.float64).sum(axis=0) / (e - s + 1)
            limit = max(max_drift, stance_drift) if e - s + 1 <= stance_frames else max_drift
            if np.hypot(joints[s:e + 1, j, 0] - m[0], joints[s:e + 1, j, 2] - m[2]).max() <= limit:
                rs.append((s, e, m))
        out.append(rs)
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


def fade_weight(u: float) -> float:
    """A pin's weight over its fade (u: 0 → 1 linearly): smoothstep (footContact.ts ``fadeWeight``)."""
    return u * u * (3 - 2 * u)


def _floor(out: np.ndarray, foot_joints) -> None:
    low = out[:, list(foot_joints), 1].min(axis=1)
    lift = np.where(low < 0, low, 0.0)
    out[:, :, 1] -= lift[:, None]


def cleanup_foot_contacts(joints: np.ndarray, contacts: np.ndarray, parents, foot_joints,
                          threshold: float = FOOT_CLEANUP["threshold"], blend: int = FOOT_CLEANUP["blend"],
                          gap: int = FOOT_CLEANUP["gap"], max_drift: float = FOOT_CLEANUP["max_drift"],
                          stance_drift: float = FOOT_CLEANUP["stance_drift"],
                          stance_frames: int = FOOT_CLEANUP["stance_frames"]) -> np.ndarray:
    """(frames, J, 3) joints and (frames, 4) contacts → cleaned joints (frames, J, 3) float32, computed in float64."""
    out = np.array(joints, np.float64)
    frames = out.shape[0]
    if contacts.shape != (frames, 4):
        raise ValueError(f"cleanup_foot_contacts: contacts has shape {contacts.shape}, expected ({frames}, 4)")
    if len(foot_joints) != 4:
        raise ValueError("cleanup_foot_contacts: foot_joints must list l_ankle, l_foot, r_ankle, r_foot")
    _floor(out, foot_joints)
    targets = []
    planted = plant_runs(out, contacts, threshold, gap, max_drift, foot_joints=foot_joints, stance_drift=stance_drift,
                         stance_frames=stance_frames)
    for c, j in enumerate(foot_joints):
        tgt = np.zeros((frames, 3))
        wgt = np.zeros(frames)
        acc = np.zeros((frames, 3))
        wsum = np.zeros(frames)
        pins = [(s, e, np.array([mean[0], max(0.0, mean[1]), mean[2]])) for s, e, mean in planted[c]]
        for s, e, m in pins:
            for f in range(max(0, s - blend), min(frames - 1, e + blend) + 1):
                w = fade_weight(1 - (s - f) / (blend + 1) if f < s else (1 - (f - e) / (blend + 1) if f > e else 1.0))
                acc[f] += w * m
                wsum[f] += w
                wgt[f] = max(wgt[f], w)
        on = wsum > 0
        tgt[on] = acc[on] / wsum[on, None]      # overlapping fades (a run's short swing): their weight-mixed mean
        for s, e, m in pins:                    # a run's own frames keep its pin (a neighbour's fade reaches them
            tgt[s:e + 1] = m                    # only when blend > gap + 1)
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
