"""Write joint motions as BVH on the reference skeleton (emdm.skeleton), rotations from emdm.motion.ik.

The same file as the page's ``writeBVH`` (src/export/bvh.ts) at the motion's own frame rate: the same IK
(twist from body planes; tests/fixtures/parity/ik.bvh is this writer's output, which the TypeScript test
reads back number by number), the same hierarchy and number format.

Units (``units``): metres by default — Blender's importer (scale 1.0) and three.js read the numbers as scene
units, i.e. metres, so the pelvis stands ~0.9 high — or centimetres ("cm": offsets and root position ×100).
Lengths get 6 decimals in metres, 4 in centimetres (1 µm either way). BVH has no comment line that both
three's BVHLoader and Blender's importer skip (both want HIERARCHY first), so the unit goes in the file
name: ``bvh_path``. Y up. Hierarchy: the reference skeleton with the
offsets ``solve_ik`` adapts to the motion (the children of pelvis and spine3 at the motion's mean offsets,
every other bone at its mean length); the root OFFSET is 0 0 0 and its position channels carry the
pelvis's world position. Root: 6 channels (Xposition Yposition Zposition Zrotation Xrotation Yrotation),
other joints: 3 rotation channels in the same ZXY order, i.e. R = Rz · Rx · Ry (intrinsic, as BVH readers
apply the channels left to right). Leaf joints get an End Site 5 cm further along their bone.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.outdir import write_text_atomic
from emdm.motion.ik import solve_ik

UNITS = {"m": (1.0, 6, "metres"), "cm": (100.0, 4, "centimetres")}   # unit → (per metre, decimals, word)
END_SITE = 0.05  # metres along a leaf's bone


def _unit(units: str) -> tuple[float, int, str]:
    if units not in UNITS:
        raise ValueError(f"BVH units must be 'm' or 'cm', got {units!r}")
    return UNITS[units]


def bvh_path(prefix: Path | str, units: str = "m") -> Path:
    """``out/walk`` → ``out/walk.metres.bvh`` (or ``.centimetres.bvh``): the unit in the file name (appended:
    nothing of ``prefix`` is taken for a suffix)."""
    prefix = Path(prefix)
    return prefix.with_name(f"{prefix.name}.{_unit(units)[2]}.bvh")


def matrix_to_euler_zxy(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) → (..., 3) degrees (z, x, y) with R = Rz(z) Rx(x) Ry(y)."""
    # R = Rz Rx Ry: R[2,1] = sin x; R[2,0] = -cos x sin y; R[2,2] = cos x cos y; R[0,1] = -sin z cos x; R[1,1] = cos z cos x
    sx = np.clip(R[..., 2, 1], -1.0, 1.0)
    x = np.arcsin(sx)
    y = np.arctan2(-R[..., 2, 0], R[..., 2, 2])
    z = np.arctan2(-R[..., 0, 1], R[..., 1, 1])
    gimbal = np.abs(sx) >= 0.9999999                 # as eulerZXY in src/export/bvh.ts
    if np.any(gimbal):    # cos x ≈ 0: put everything into z
        z = np.where(gimbal, np.arctan2(R[..., 1, 0], R[..., 0, 0]), z)
        y = np.where(gimbal, 0.0, y)
    return np.degrees(np.stack([z, x, y], axis=-1))


def euler_zxy_to_matrix(deg: np.ndarray) -> np.ndarray:
    z, x, y = np.radians(deg[..., 0]), np.radians(deg[..., 1]), np.radians(deg[..., 2])
    cz, sz, cx, sx, cy, sy = np.cos(z), np.sin(z), np.cos(x), np.sin(x), np.cos(y), np.sin(y)
    one, zero = np.ones_like(z), np.zeros_like(z)
    Rz = np.stack([np.stack([cz, -sz, zero], -1), np.stack([sz, cz, zero], -1), np.stack([zero, zero, one], -1)], -2)
    Rx = np.stack([np.stack([one, zero, zero], -1), np.stack([zero, cx, -sx], -1), np.stack([zero, sx, cx], -1)], -2)
    Ry = np.stack([np.stack([cy, zero, sy], -1), np.stack([zero, one, zero], -1), np.stack([-sy, zero, cy], -1)], -2)
    return Rz @ Rx @ Ry


def _children(j: int) -> list[int]:
    return [c for c, p in enumerate(sk.PARENTS) if p == j]


def _num(v: float, digits: int = 4) -> str:
    """``digits`` decimals, never "-0.0000" (as the page writes numbers)."""
    s = f"{v:.{digits}f}"
    return s[1:] if s.startswith("-") and float(s) == 0 else s


def bvh_text(joints: np.ndarray, fps: float = sk.FPS, units: str = "m") -> str:
    """(F, 22, 3) joint positions (metres) → BVH text in ``units`` ("m" or "cm")."""
    scale, digits, _ = _unit(units)
    if np.asarray(joints).shape[0] < 1:
        raise ValueError("bvh_text: the motion has no frames")
    ik = solve_ik(joints)
    euler = matrix_to_euler_zxy(ik.local)                       # (F, 22, 3)
    lines = ["HIERARCHY"]
    order: list[int] = []

    def emit(j: int, depth: int) -> None:
        pad = "  " * depth
        off = (np.zeros(3) if j == 0 else ik.offsets[j]) * scale
        lines.append(f"{pad}{'ROOT' if j == 0 else 'JOINT'} {sk.JOINT_NAMES[j]}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {' '.join(_num(v, digits) for v in off)}")
        if j == 0:
            lines.append(f"{pad}  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation")
        else:
            lines.append(f"{pad}  CHANNELS 3 Zrotation Xrotation Yrotation")
        order.append(j)
        kids = _children(j)
        if not kids:
            d = sk.REFERENCE_OFFSETS[j]
            end = d / max(np.linalg.norm(d), 1e-9) * END_SITE * scale
            lines.append(f"{pad}  End Site")
            lines.append(f"{pad}  {{")
            lines.append(f"{pad}    OFFSET {' '.join(_num(v, digits) for v in end)}")
            lines.append(f"{pad}  }}")
        for c in kids:
            emit(c, depth + 1)
        lines.append(f"{pad}}}")

    emit(0, 0)
    n = len(ik.root)
    lines += ["MOTION", f"Frames: {n}", f"Frame Time: {1.0 / fps:.7f}"]
    for f in range(n):
        vals = [_num(v, digits) for v in ik.root[f] * scale]
        for j in order:
            vals += [_num(v) for v in euler[f, j]]
        lines.append(" ".join(vals))
    return "\n".join(lines) + "\n"


def write_bvh(joints: np.ndarray, path: Path | str, fps: float = sk.FPS, units: str = "m") -> Path:
    """Write ``bvh_text`` to ``path`` (name it with ``bvh_path`` so that it says the unit)."""
    return write_text_atomic(path, bvh_text(joints, fps, units))   # whole, or the old file kept
