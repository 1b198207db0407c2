"""Write joint motions as a binary glTF 2.0 file (.glb): a skinned skeleton with one animation.

    from emdm.writers.glb import write_glb
    write_glb(joints, "out/walk.glb")          # joints (frames, 22, 3) metres, 20 fps

The rig is the BVH writer's (``emdm.writers.bvh``): the reference skeleton at the offsets ``solve_ik`` adapts to
the motion, one node per joint named as ``emdm.skeleton.JOINT_NAMES``, rest rotations identity, Y up, metres. The
animation ("motion") has the pelvis's translation and every joint's rotation (unit quaternions x, y, z, w, LINEAR)
at each frame's time (frame / fps), so evaluating it reproduces the BVH file's poses. glTF skins a mesh, not bare
nodes: the file carries a small skinned mesh (a tetrahedron at each joint, bound to that joint only) so that
importers (three.js GLTFLoader, Blender) build a Skeleton they can retarget from. Everything sits in one buffer,
each view 4-byte aligned as the spec asks; POSITION and the animation's input have min/max.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.outdir import write_bytes_atomic
from emdm.motion.ik import forward_kinematics, quaternions, solve_ik

FLOAT, UBYTE, USHORT = 5126, 5121, 5123          # glTF componentType codes
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
MARKER = 0.02                                     # metres: the tetrahedron's size at each joint
_TETRA = np.array([[0, 1, 0], [1, -1, 1], [-1, -1, 1], [0, -1, -1]], np.float32) * MARKER
_TETRA_FACES = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]], np.uint16)


class _Buffer:
    """One binary buffer and the bufferViews/accessors that point into it."""

    def __init__(self):
        self.data = bytearray()
        self.views: list[dict] = []
        self.accessors: list[dict] = []

    def add(self, arr: np.ndarray, kind: str, ctype: int, target: int | None = None, minmax: bool = False) -> int:
        """Append ``arr`` (rows of ``kind``: SCALAR, VEC3, VEC4, MAT4) as a new view and accessor; its index."""
        while len(self.data) % 4:
            self.data.append(0)
        raw = np.ascontiguousarray(arr).tobytes()
        view = {"buffer": 0, "byteOffset": len(self.data), "byteLength": len(raw)}
        if target is not None:
            view["target"] = target
        self.data += raw
        self.views.append(view)
        acc = {"bufferView": len(self.views) - 1, "componentType": ctype, "count": int(arr.shape[0]), "type": kind}
        if minmax:
            flat = arr.reshape(arr.shape[0], -1)
            acc["min"], acc["max"] = flat.min(0).tolist(), flat.max(0).tolist()
        self.accessors.append(acc)
        return len(self.accessors) - 1


def glb_bytes(joints: np.ndarray, fps: float = sk.FPS) -> bytes:
    """The .glb file of (frames, 22, 3) joints in metres; ValueError for another shape or non-finite values."""
    joints = np.asarray(joints, np.float64)
    if joints.ndim != 3 or joints.shape[1:] != (sk.NUM_JOINTS, 3) or joints.shape[0] < 1:
        raise ValueError(f"glb: expected joints of shape (frames ≥ 1, {sk.NUM_JOINTS}, 3), got {joints.shape}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"glb: fps must be a finite number > 0, got {fps}")
    ik = solve_ik(joints)                          # raises on NaN/Infinity
    frames = joints.shape[0]
    rest = forward_kinematics(np.zeros((1, 3)), np.broadcast_to(np.eye(3), (1, sk.NUM_JOINTS, 3, 3)), ik.offsets)[0]
    buf = _Buffer()

    verts = (rest[:, None, :] + _TETRA[None]).reshape(-1, 3).astype(np.float32)
    joint_ids = np.zeros((len(verts), 4), np.uint8)
    joint_ids[:, 0] = np.repeat(np.arange(sk.NUM_JOINTS), len(_TETRA))
    weights = np.zeros((len(verts), 4), np.float32)
    weights[:, 0] = 1.0
    faces = (_TETRA_FACES[None] + (np.arange(sk.NUM_JOINTS) * len(_TETRA))[:, None, None]).reshape(-1).astype(np.uint16)
    attrs = {"POSITION": buf.add(verts, "VEC3", FLOAT, ARRAY_BUFFER, minmax=True),
             "JOINTS_0": buf.add(joint_ids, "VEC4", UBYTE, ARRAY_BUFFER),
             "WEIGHTS_0": buf.add(weights, "VEC4", FLOAT, ARRAY_BUFFER)}
    indices = buf.add(faces, "SCALAR", USHORT, ELEMENT_ARRAY_BUFFER)
    ibm = np.tile(np.eye(4, dtype=np.float32), (sk.NUM_JOINTS, 1, 1))
    ibm[:, 3, :3] = -rest                          # column-major: the inverse bind is a translation by -rest
    ibm_acc = buf.add(ibm.reshape(sk.NUM_JOINTS, 16), "MAT4", FLOAT)

    times = (np.arange(frames) / fps).astype(np.float32)
    t_acc = buf.add(times, "SCALAR", FLOAT, minmax=True)
    quat = quaternions(ik.local).astype(np.float32)            # (F, 22, 4) x, y, z, w
    quat /= np.linalg.norm(quat, axis=-1, keepdims=True)
    samplers = [{"input": t_acc, "output": buf.add(ik.root.astype(np.float32), "VEC3", FLOAT), "interpolation": "LINEAR"}]
    channels = [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]
    for j in range(sk.NUM_JOINTS):
        samplers.append({"input": t_acc, "output": buf.add(quat[:, j], "VEC4", FLOAT), "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": j, "path": "rotation"}})

    nodes = []
    for j, name in enumerate(sk.JOINT_NAMES):
        node = {"name": name, "translation": (ik.root[0] if j == 0 else ik.offsets[j]).astype(float).tolist()}
        kids = [c for c in range(sk.NUM_JOINTS) if sk.PARENTS[c] == j]
        if kids:
            node["children"] = kids
        nodes.append(node)
    nodes.append({"name": "body", "mesh": 0, "skin": 0})
    doc = {
        # the name this writer first had: kept, so that files stay byte for byte what they were
        "asset": {"version": "2.0", "generator": "emdm.mocap.glb_writer"},
        "scene": 0,
        "scenes": [{"nodes": [0, sk.NUM_JOINTS]}],
        "nodes": nodes,
        "meshes": [{"name": "joints", "primitives": [{"attributes": attrs, "indices": indices, "mode": 4}]}],
        "skins": [{"name": "skeleton", "joints": list(range(sk.NUM_JOINTS)), "skeleton": 0,
                   "inverseBindMatrices": ibm_acc}],
        "animations": [{"name": "motion", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": len(buf.data)}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    }
    return _pack(doc, bytes(buf.data))


def _pack(doc: dict, binary: bytes) -> bytes:
    """GLB container: 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with zeros (4-byte units)."""
    js = json.dumps(doc, separators=(",", ":")).encode()
    js += b" " * (-len(js) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(js) + 8 + len(binary)
    return (struct.pack("<4sII", b"glTF", 2, total) + struct.pack("<I4s", len(js), b"JSON") + js
            + struct.pack("<I4s", len(binary), b"BIN\0") + binary)


def write_glb(joints: np.ndarray, path: Path | str, fps: float = sk.FPS) -> Path:
    """Write ``glb_bytes(joints, fps)`` to ``path``; the path written."""
    return write_bytes_atomic(path, glb_bytes(joints, fps))   # whole, or the old file kept
