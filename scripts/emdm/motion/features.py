"""The 263-d HumanML3D motion features and their inverse (numpy, pure functions).

Layout per frame t (t = 0 .. F-2; a clip of F joint frames gives F-1 feature frames):

    [0]        root angular velocity about +Y, HALF-ANGLE convention (see below)
    [1:3]      root linear velocity (x, z) from frame t to t+1, expressed in the root frame of t+1
    [3]        root (pelvis) height y at frame t, metres above the floor
    [4:67]     joints 1..21 (not the pelvis) relative to the root's ground point, in the root frame
               of t: x, z are rotated and measured from the pelvis x, z; y is the world height
    [67:193]   joints 1..21 local rotations, 6D (first two columns of the 3x3 matrix, col0 then col1)
    [193:259]  joints 0..21 velocity p[t+1] - p[t], in the root frame of t (metres per frame)
    [259:263]  foot contacts of l_ankle, l_foot, r_ankle, r_foot: 1.0 when the joint's squared
               displacement to the next frame is < CONTACT_THRESHOLD (0.002 m^2 per frame at 20 fps)

These are exactly HumanML3D's conventions, so a real HumanML3D ``new_joint_vecs`` folder recovers
correctly with ``recover_joints``, and ``recover_joints`` is easy to port (torch, TypeScript).

Conventions (Y up, metres, the rest skeleton faces +Z with its left side at +X):

* Facing: ``across = (p[r_hip] - p[l_hip]) + (p[r_shoulder] - p[l_shoulder])``, with y set to 0;
  ``forward = normalize(cross((0, 1, 0), across))`` (for the rest pose across = -X, forward = +Z).
* Heading ``theta = atan2(forward.x, forward.z)``: the angle about +Y that turns +Z into forward
  (right-handed: positive theta turns +Z towards +X, i.e. a LEFT turn when facing +Z).
* ``Ry(a)`` is the right-handed rotation about +Y: ``(x, y, z) -> (cos a x + sin a z, y,
  -sin a x + cos a z)``. The root frame of t is world -> ``Ry(-theta_t)`` (forward becomes +Z).
* Feature [0] at t is ``wrap(-(theta_{t+1} - theta_t)) / 2`` (wrap to (-pi, pi]): HumanML3D stores the
  change of the quaternion ``(cos a, 0, sin a, 0)`` angle ``a``, which is half of the rotation angle.

Recovery (``recover_joints``, only features [0:67] are used), for N feature frames:

    a_0 = 0, a_t = sum_{k<t} f[k, 0]                    (so theta_t = -2 a_t; theta_0 = 0)
    root_xz_0 = (0, 0), root_xz_{t} = root_xz_{t-1} + Ry(-2 a_t) (f[t-1, 1], f[t-1, 2])
    root_y_t = f[t, 3]
    joint_j,t = Ry(-2 a_t) f[t, 4+3(j-1) : 7+3(j-1)] + (root_x_t, 0, root_z_t)   for j = 1..21

``recover_joints(extract_features(J))`` equals ``J[:-1]`` to float precision when J's first frame has
its pelvis at x = z = 0 and faces +Z by the facing rule above (``emdm.motion.retarget`` ensures it).
"""

from __future__ import annotations

import numpy as np

from emdm import skeleton as sk

CONTACT_THRESHOLD = 0.002  # squared metres per frame (HumanML3D's velfactor at 20 fps)

ROOT_ROT_VEL = slice(0, 1)
ROOT_LIN_VEL = slice(1, 3)
ROOT_HEIGHT = slice(3, 4)
RIC = slice(4, 67)
ROT6D = slice(67, 193)
LOCAL_VEL = slice(193, 259)
CONTACTS = slice(259, 263)


def check_joints(joints: np.ndarray, name: str = "joints") -> np.ndarray:
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (sk.NUM_JOINTS, 3):
        raise ValueError(f"{name}: expected shape (frames, 22, 3), got {j.shape}")
    if not np.all(np.isfinite(j)):
        raise ValueError(f"{name}: contains NaN or infinite values")
    return j


def rot_y(angle: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vectors v (..., 3) about +Y by angle (broadcast over the leading axes), right-handed."""
    c, s = np.cos(angle), np.sin(angle)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return np.stack([c * x + s * z, y, -s * x + c * z], axis=-1)


def heading_angles(joints: np.ndarray) -> np.ndarray:
    """theta (F,): the angle about +Y that turns +Z into each frame's forward direction."""
    j = check_joints(joints)
    across = (j[:, sk.R_HIP] - j[:, sk.L_HIP]) + (j[:, sk.R_SHOULDER] - j[:, sk.L_SHOULDER])
    # forward = cross(up, across) = (across.z, 0, -across.x)
    fx, fz = across[:, 2], -across[:, 0]
    return np.arctan2(fx, fz)


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def foot_contacts(joints: np.ndarray, threshold: float = CONTACT_THRESHOLD) -> np.ndarray:
    """(F-1, 4) float contacts for l_ankle, l_foot, r_ankle, r_foot (squared step < threshold)."""
    j = check_joints(joints)
    step = j[1:, sk.FOOT_JOINTS] - j[:-1, sk.FOOT_JOINTS]
    return ((step ** 2).sum(-1) < threshold).astype(np.float64)


def _between(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of the shortest arc turning unit u into unit v."""
    k = np.cross(u, v)
    c = np.sum(u * v, axis=-1)
    # opposite vectors: rotate by pi about any axis perpendicular to u
    opposite = c < -1.0 + 1e-8
    if np.any(opposite):
        alt = np.cross(u, np.array([1.0, 0.0, 0.0]))
        alt = np.where(np.linalg.norm(alt, axis=-1, keepdims=True) < 1e-6, np.cross(u, np.array([0.0, 0.0, 1.0])), alt)
        alt /= np.linalg.norm(alt, axis=-1, keepdims=True)
        outer = 2.0 * alt[..., :, None] * alt[..., None, :] - np.eye(3)
    K = np.zeros(k.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2] = -k[..., 2], k[..., 1]
    K[..., 1, 0], K[..., 1, 2] = k[..., 2], -k[..., 0]
    K[..., 2, 0], K[..., 2, 1] = -k[..., 1], k[..., 0]
    scale = 1.0 / np.maximum(1.0 + c, 1e-8)
    R = np.eye(3) + K + (K @ K) * scale[..., None, None]
    if np.any(opposite):
        R = np.where(opposite[..., None, None], outer, R)
    return R


def local_rotations(joints: np.ndarray) -> np.ndarray:
    """(F, 21, 3, 3) swing-only local rotations of joints 1..21 (no twist; not used by recovery).

    The rotation stored for joint b turns the reference bone parent(b)->b (REFERENCE_OFFSETS[b])
    into the observed bone direction, relative to the previous bone of its kinematic chain (the
    first bone of a chain from the pelvis is relative to the heading rotation Ry(theta))."""
    j = check_joints(joints)
    F = j.shape[0]
    glob = np.zeros((F, sk.NUM_JOINTS, 3, 3))
    theta = heading_angles(j)
    c, s = np.cos(theta), np.sin(theta)
    root = np.zeros((F, 3, 3))
    root[:, 0, 0], root[:, 0, 2], root[:, 1, 1], root[:, 2, 0], root[:, 2, 2] = c, s, 1.0, -s, c
    glob[:, 0] = root
    local = np.tile(np.eye(3), (F, sk.NUM_JOINTS, 1, 1))
    rest = sk.REFERENCE_OFFSETS / np.maximum(np.linalg.norm(sk.REFERENCE_OFFSETS, axis=1, keepdims=True), 1e-12)
    for chain in sk.KINEMATIC_CHAINS:
        parent_glob = glob[:, chain[0]]
        for a, b in zip(chain[:-1], chain[1:]):
            v = j[:, b] - j[:, a]
            n = np.linalg.norm(v, axis=-1, keepdims=True)
            v = np.where(n > 1e-9, v / np.maximum(n, 1e-12), rest[b])
            g = _between(np.broadcast_to(rest[b], v.shape), v)
            local[:, b] = np.swapaxes(parent_glob, -1, -2) @ g
            glob[:, b] = g
            parent_glob = g
    return local[:, 1:]


def extract_features(joints: np.ndarray) -> np.ndarray:
    """(F, 22, 3) joint positions (metres, Y up, floor y = 0) -> (F-1, 263) float32 features."""
    j = check_joints(joints)
    F = j.shape[0]
    if F < 2:
        raise ValueError(f"joints: need at least 2 frames to compute features, got {F}")
    theta = heading_angles(j)
    phi = -theta                                      # world -> root-frame rotation angle
    root = j[:, 0]
    rot_vel = _wrap(phi[1:] - phi[:-1]) / 2.0         # half-angle convention (HumanML3D)
    lin = root[1:] - root[:-1]
    lin[:, 1] = 0.0
    lin_vel = rot_y(phi[1:], lin)[:, [0, 2]]          # in the root frame of t+1
    height = root[:-1, 1:2]
    rel = j.copy()
    rel[..., 0] -= root[:, None, 0]
    rel[..., 2] -= root[:, None, 2]
    ric = rot_y(phi[:, None], rel)[:-1, 1:].reshape(F - 1, 63)
    rots = local_rotations(j)[:-1]                    # (F-1, 21, 3, 3)
    rot6d = np.concatenate([rots[..., :, 0], rots[..., :, 1]], axis=-1).reshape(F - 1, 126)
    vel = rot_y(phi[:-1, None], j[1:] - j[:-1]).reshape(F - 1, 66)
    contacts = foot_contacts(j)
    out = np.concatenate([rot_vel[:, None], lin_vel, height, ric, rot6d, vel, contacts], axis=1)
    assert out.shape[1] == sk.FEATURE_DIM
    return out.astype(np.float32)


def recover_root(features: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, >=4) features -> (theta (N,), root positions (N, 3)); theta_0 = 0, root_xz_0 = 0."""
    f = np.asarray(features, dtype=np.float64)
    a = np.zeros(f.shape[0])
    a[1:] = np.cumsum(f[:-1, 0])
    theta = -2.0 * a
    step = np.zeros((f.shape[0], 3))
    step[1:, 0], step[1:, 2] = f[:-1, 1], f[:-1, 2]
    root = np.cumsum(rot_y(theta, step), axis=0)
    root[:, 1] = f[:, 3]
    return theta, root


def recover_joints(features: np.ndarray) -> np.ndarray:
    """(N, 263) (or (N, >=67)) features -> (N, 22, 3) joint positions; uses only [0:67]."""
    f = np.asarray(features, dtype=np.float64)
    if f.ndim != 2 or f.shape[1] < 67:
        raise ValueError(f"features: expected shape (frames, 263), got {f.shape}")
    theta, root = recover_root(f)
    rel = f[:, 4:67].reshape(-1, 21, 3)
    world = rot_y(theta[:, None], rel)
    world[..., 0] += root[:, None, 0]
    world[..., 2] += root[:, None, 2]
    return np.concatenate([root[:, None], world], axis=1)
