"""Inverse kinematics: 22 joint positions per frame → root translation + local joint rotations, with bone
TWIST taken from body planes. The same algorithm as the page's ``src/motion/ik.ts`` (``solveIK``), line for
line, so a BVH from ``emdm.sample`` and one from the page carry the same angles; the fixture
``tests/fixtures/parity/ik.*`` (``python -m emdm.motion.ik_fixture``) holds Python's numbers and both
languages test against it.

Each non-leaf joint's global rotation G_j maps its rest frame onto a frame built from
  primary   = direction to its (main) child, measured from the joint's FK position (so bone length
              differences never accumulate down a chain),
  secondary = a twist reference:
    pelvis       hips across (l_hip − r_hip) is primary, spine up is secondary
    spine1/2     across vector blended 2/3:1/3 and 1/3:2/3 between hips and chest
    spine3       neck up (primary), chest across = l_collar − r_collar (secondary)
    neck         chest across (the head has no child joint: its twist follows the chest)
    collars      chest up
    hips, knees  the leg's bend-plane normal (hip→knee × knee→ankle): the knee is a hinge
    ankles       the knee axis
    shoulders, elbows  the arm's bend-plane normal: the elbow is a hinge
  When a limb is nearly straight its bend normal is undefined: it is blended towards the previous
  frame's axis (carried in the parent's frame), which keeps the twist continuous.
Leaves (feet, head, wrists) keep the parent's rotation (local identity).

Offsets (``IKResult.offsets``): the children of the two multi-child joints (pelvis: hips + spine1;
spine3: neck + collars) get the motion's own mean offset in the parent's frame, every other bone its
reference direction at the motion's mean bone length, so ``forward_kinematics(root, local, offsets)``
reproduces the joints of a retargeted clip (``adapt_offsets=False`` keeps the reference skeleton).

Rotations are 3×3 matrices (column vectors: world = G · local); local = G_parentᵀ · G.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from emdm import skeleton as sk

_N = {n: i for i, n in enumerate(sk.JOINT_NAMES)}
X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])


class IKResult(NamedTuple):
    root: np.ndarray      # (F, 3) world position of the pelvis
    local: np.ndarray     # (F, 22, 3, 3) local rotations (the pelvis: global)
    offsets: np.ndarray   # (22, 3) rest offsets that go with them, metres


def rest_positions(offsets: np.ndarray | None = None) -> np.ndarray:
    """(22, 3) world positions of the rest pose of ``offsets`` (default: the reference skeleton)."""
    off = sk.REFERENCE_OFFSETS if offsets is None else offsets
    pos = np.zeros((sk.NUM_JOINTS, 3))
    for j, p in enumerate(sk.PARENTS):
        pos[j] = off[j] + (pos[p] if p >= 0 else 0.0)
    return pos


# ------------------------------------------------------------------------------------------------ vector math
# vectorised over leading axes; thresholds and fallbacks as in src/motion/math3.ts

def _norm(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=-1, keepdims=True)


def _normalize(a: np.ndarray, fallback=(0.0, 1.0, 0.0)) -> np.ndarray:
    n = _norm(a)
    ok = n > 1e-12
    return np.where(ok, a / np.where(ok, n, 1.0), np.asarray(fallback, dtype=float))


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1, keepdims=True)


def frame(primary: np.ndarray, secondary: np.ndarray, spare=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Orthonormal frame (..., 3, 3), columns [e1 e2 e3]: e1 along ``primary``, e2 = the part of ``secondary``
    orthogonal to it (``spare`` when they are nearly parallel)."""
    primary, secondary = np.broadcast_arrays(np.asarray(primary, float), np.asarray(secondary, float))
    e1 = _normalize(primary)
    s = secondary - e1 * _dot(secondary, e1)
    degenerate = _norm(s) < 1e-6 * np.maximum(1.0, _norm(secondary))
    if np.any(degenerate):
        sp = np.asarray(spare, float)
        s2 = sp - e1 * _dot(sp, e1)
        s2 = np.where(_norm(s2) < 1e-6, X - e1 * e1[..., :1], s2)
        s = np.where(degenerate, s2, s)
    e2 = _normalize(s)
    e3 = np.cross(e1, e2)
    return np.stack([e1, e2, e3], axis=-1)


def align_frames(primary0, secondary0, primary, secondary) -> np.ndarray:
    """The rotation taking the rest frame (primary0, secondary0) onto (primary, secondary): F·F0ᵀ."""
    return frame(primary, secondary) @ np.swapaxes(frame(primary0, secondary0), -1, -2)


def _mv(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", m, v)


def _mtv(m: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...ji,...j->...i", m, v)


def _mix(a: np.ndarray, b: np.ndarray, wa: float) -> np.ndarray:
    return _normalize(a) * wa + _normalize(b) * (1.0 - wa)


def _bend_axes(a: np.ndarray, b: np.ndarray, c: np.ndarray, G_parent: np.ndarray, rest_axis: np.ndarray) -> np.ndarray:
    """Per frame (F, 3): the bend-plane normal of a limb a→b→c (each (F, 3)), sign-aligned with and blended
    towards a reference when straight; the reference is the previous frame's axis carried by the parent's
    rotation G_parent (F, 3, 3) (the first frame: ``rest_axis`` carried by it)."""
    u, w = b - a, c - b
    n = np.cross(u, w)
    n_len = np.linalg.norm(n, axis=-1)
    sin = n_len / np.maximum(np.linalg.norm(u, axis=-1) * np.linalg.norm(w, axis=-1), 1e-12)
    wgt = np.clip((sin - 0.03) / (0.2 - 0.03), 0.0, 1.0)
    out = np.zeros_like(n)
    prev = [float(v) for v in rest_axis]
    for f in range(len(n)):                       # sequential: each frame's reference is the previous axis
        g = G_parent[f].tolist()
        ref = [g[r][0] * prev[0] + g[r][1] * prev[1] + g[r][2] * prev[2] for r in range(3)]
        if n_len[f] > 1e-12:
            nh = [float(v) / float(n_len[f]) for v in n[f]]
        else:
            nh = ref
        if nh[0] * ref[0] + nh[1] * ref[1] + nh[2] * ref[2] < 0:
            nh = [-v for v in nh]                 # never flip the hinge: a reversed bend is hyperextension
        r_len = math.hypot(*ref)
        rn = [v / r_len for v in ref] if r_len > 1e-12 else [0.0, 1.0, 0.0]
        wf = float(wgt[f])
        v = [nh[k] * wf + rn[k] * (1 - wf) for k in range(3)]
        v_len = math.hypot(*v)
        axis = [x / v_len for x in v] if v_len > 1e-12 else ref
        prev = [g[0][k] * axis[0] + g[1][k] * axis[1] + g[2][k] * axis[2] for k in range(3)]   # Gᵀ·axis
        out[f] = axis
    return out


def _rest_axis(rest: np.ndarray, a: str, b: str, default: np.ndarray) -> np.ndarray:
    """The rest limb's own bend normal when it is visibly bent, else the anatomical default."""
    ra, rb = rest[_N[a]], rest[_N[b]]
    n = np.cross(ra, rb)
    sin = np.linalg.norm(n) / max(np.linalg.norm(ra) * np.linalg.norm(rb), 1e-12)
    if sin < 0.03:
        return default
    nh = _normalize(n)
    return -nh if np.dot(nh, default) < 0 else nh


# ------------------------------------------------------------------------------------------------ offsets

def adapted_offsets(joints: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(22, 3) offsets for the motion (F, 22, 3): see the module docstring."""
    P = lambda n: joints[:, _N[n]]   # noqa: E731
    out = offsets.copy()
    groups = [
        ("pelvis", align_frames(offsets[_N["l_hip"]] - offsets[_N["r_hip"]], offsets[_N["spine1"]],
                                P("l_hip") - P("r_hip"), P("spine1") - P("pelvis")), ("l_hip", "r_hip", "spine1")),
        ("spine3", align_frames(offsets[_N["neck"]], offsets[_N["l_collar"]] - offsets[_N["r_collar"]],
                                P("neck") - P("spine3"), P("l_collar") - P("r_collar")), ("neck", "l_collar", "r_collar")),
    ]
    adapted = set()
    for parent, G, kids in groups:
        for k in kids:
            m = _mtv(G, P(k) - P(parent)).mean(axis=0)
            if np.all(np.isfinite(m)) and np.linalg.norm(m) > 1e-6:
                out[_N[k]] = m
            adapted.add(_N[k])
    for j, p in enumerate(sk.PARENTS):
        if p < 0 or j in adapted:
            continue
        length = float(np.linalg.norm(joints[:, j] - joints[:, p], axis=-1).mean())
        ref = float(np.linalg.norm(offsets[j]))
        if np.isfinite(length) and length > 1e-6 and ref > 1e-9:
            out[j] = offsets[j] * (length / ref)
    return out


# ------------------------------------------------------------------------------------------------ IK

def solve_ik(joints: np.ndarray, offsets: np.ndarray | None = None, adapt_offsets: bool = True) -> IKResult:
    """(F, 22, 3) joints (metres) → IKResult(root (F, 3), local (F, 22, 3, 3), offsets (22, 3)).

    ``offsets``: the rig's rest offsets (default ``emdm.skeleton.REFERENCE_OFFSETS``); they define the rest
    frames (rotation = identity)."""
    P_all = np.asarray(joints, dtype=np.float64)
    if P_all.ndim != 3 or P_all.shape[1:] != (sk.NUM_JOINTS, 3):
        raise ValueError(f"solve_ik: expected joints of shape (frames, 22, 3), got {P_all.shape}")
    if not np.all(np.isfinite(P_all)):
        raise ValueError("solve_ik: joints contain NaN or infinite values")
    rest = np.asarray(sk.REFERENCE_OFFSETS if offsets is None else offsets, dtype=np.float64)
    F, J = P_all.shape[0], sk.NUM_JOINTS
    off = rest if not adapt_offsets or F == 0 else adapted_offsets(P_all, rest)
    P = lambda n: P_all[:, _N[n]]    # noqa: E731
    legs = {s: _rest_axis(rest, f"{s}_knee", f"{s}_ankle", X) for s in "lr"}
    arms = {s: _rest_axis(rest, f"{s}_elbow", f"{s}_wrist", np.array([0.0, -1.0 if s == "l" else 1.0, 0.0])) for s in "lr"}
    hip_across = P("l_hip") - P("r_hip")
    chest_across = P("l_collar") - P("r_collar")       # the collars are rigid with the chest, the shoulders are not

    G = np.zeros((F, J, 3, 3))
    Q = np.zeros((F, J, 3))                            # FK positions (parents' rotations applied to offsets)

    def limb_axis(parent: int, a: str, b: str, c: str, rest_axis: np.ndarray) -> np.ndarray:
        return _bend_axes(P(a), P(b), P(c), G[:, parent], rest_axis)

    for j, name in enumerate(sk.JOINT_NAMES):        # parents precede children (SMPL order)
        p = sk.PARENTS[j]
        Gp = np.broadcast_to(np.eye(3), (F, 3, 3)) if p < 0 else G[:, p]
        Q[:, j] = P_all[:, j] if p < 0 else Q[:, p] + _mv(Gp, off[j])
        to = lambda c: P(c) - Q[:, j]   # noqa: E731
        s = name[0]
        if name == "pelvis":
            G[:, j] = align_frames(rest[_N["l_hip"]] - rest[_N["r_hip"]], rest[_N["spine1"]], hip_across, to("spine1"))
        elif name == "spine1":
            G[:, j] = align_frames(rest[_N["spine2"]], X, to("spine2"), _mix(hip_across, chest_across, 2 / 3))
        elif name == "spine2":
            G[:, j] = align_frames(rest[_N["spine3"]], X, to("spine3"), _mix(hip_across, chest_across, 1 / 3))
        elif name == "spine3":
            G[:, j] = align_frames(rest[_N["neck"]], rest[_N["l_collar"]] - rest[_N["r_collar"]], to("neck"), chest_across)
        elif name == "neck":
            G[:, j] = align_frames(rest[_N["head"]], X, to("head"), _mv(Gp, X))
        elif name.endswith("_collar"):
            G[:, j] = align_frames(rest[_N[f"{s}_shoulder"]], Y, to(f"{s}_shoulder"), _mv(Gp, Y))
        elif name.endswith("_hip"):
            axis = limb_axis(p, name, f"{s}_knee", f"{s}_ankle", legs[s])
            G[:, j] = align_frames(rest[_N[f"{s}_knee"]], legs[s], to(f"{s}_knee"), axis)
        elif name.endswith("_knee"):
            G[:, j] = align_frames(rest[_N[f"{s}_ankle"]], legs[s], to(f"{s}_ankle"), _mv(Gp, legs[s]))
        elif name.endswith("_ankle"):
            G[:, j] = align_frames(rest[_N[f"{s}_foot"]], legs[s], to(f"{s}_foot"), _mv(Gp, legs[s]))
        elif name.endswith("_shoulder"):
            axis = limb_axis(p, name, f"{s}_elbow", f"{s}_wrist", arms[s])
            G[:, j] = align_frames(rest[_N[f"{s}_elbow"]], arms[s], to(f"{s}_elbow"), axis)
        elif name.endswith("_elbow"):
            G[:, j] = align_frames(rest[_N[f"{s}_wrist"]], arms[s], to(f"{s}_wrist"), _mv(Gp, arms[s]))
        else:                                            # leaves: feet, head, wrists
            G[:, j] = Gp
    local = G.copy()
    for j in range(1, J):
        local[:, j] = np.swapaxes(G[:, sk.PARENTS[j]], -1, -2) @ G[:, j]
    return IKResult(P_all[:, 0].copy(), local, off.copy())


def forward_kinematics(root: np.ndarray, local: np.ndarray, offsets: np.ndarray | None = None) -> np.ndarray:
    """(F, 3) root positions + (F, 22, 3, 3) local rotations → (F, 22, 3) joints (default: reference offsets)."""
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


def quaternions(local: np.ndarray) -> np.ndarray:
    """(F, J, 3, 3) rotations → (F, J, 4) unit quaternions (x, y, z, w) by Shepperd's method, each joint's sign
    kept continuous over frames (as ``solveIK`` returns them)."""
    m = np.asarray(local, dtype=np.float64)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    tr = m00 + m11 + m22
    with np.errstate(invalid="ignore", divide="ignore"):
        s0 = np.sqrt(np.maximum(tr + 1, 0)) * 2
        s1 = np.sqrt(np.maximum(1 + m00 - m11 - m22, 0)) * 2
        s2 = np.sqrt(np.maximum(1 + m11 - m00 - m22, 0)) * 2
        s3 = np.sqrt(np.maximum(1 + m22 - m00 - m11, 0)) * 2
        cands = [
            np.stack([(m21 - m12) / s0, (m02 - m20) / s0, (m10 - m01) / s0, 0.25 * s0], -1),
            np.stack([0.25 * s1, (m01 + m10) / s1, (m02 + m20) / s1, (m21 - m12) / s1], -1),
            np.stack([(m01 + m10) / s2, 0.25 * s2, (m12 + m21) / s2, (m02 - m20) / s2], -1),
            np.stack([(m02 + m20) / s3, (m12 + m21) / s3, 0.25 * s3, (m10 - m01) / s3], -1),
        ]
    branch = np.where(tr > 0, 0, np.where((m00 > m11) & (m00 > m22), 1, np.where(m11 > m22, 2, 3)))
    q = np.choose(branch[..., None], cands)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    if q.shape[0] > 1:               # flip where a frame's quaternion points away from the previous (flipped) one
        step = np.where(np.sum(q[1:] * q[:-1], axis=-1) < 0, -1.0, 1.0)
        q[1:] *= np.cumprod(step, axis=0)[..., None]
    return q
