"""The IK parity fixture: joint positions → root, local rotations and offsets by ``emdm.motion.ik.solve_ik``,
and the BVH (in centimetres) ``emdm.writers.bvh`` makes of one of them, which the page's ``solveIK`` / ``writeBVH`` must
reproduce (tests/unit/coreIk.test.ts) and Python's must still give (tests/python/test_motion_ik.py):

    .venv/bin/python -m emdm.motion.ik_fixture        # writes tests/fixtures/parity/ik.{json,bin,bvh}

Cases (each: ``<case>_joints`` (F, 22, 3) input, ``<case>_root`` (F, 3), ``<case>_quats`` (F, 22, 4) local
x, y, z, w with the sign kept continuous, ``<case>_offsets`` (22, 3)):

* ``real``: the joints of the recover fixture (a real retargeted clip from the prepared dataset);
* ``generated``: the joints of the emdm-t2m-web parity run (a generated motion: not a rigid skeleton);
* ``bend``: the reference skeleton with the knees and elbows bending, straightening (where the bend
  normal is undefined and the previous frame's axis carries the twist) and bending again, while the body
  turns and the upper arms twist.

The input joints are copied into the fixture, so it does not go stale when the other fixtures change.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from emdm import paths
from emdm import skeleton as sk
from emdm.fixtures import write_case
from emdm.writers.bvh import bvh_text
from emdm.motion.ik import forward_kinematics, quaternions, solve_ik

PARITY_DIR = paths.FIXTURES_DIR / "parity"
NAME = "ik"
CASES = ("real", "generated", "bend")
BVH_CASE = "generated"


def read_case_array(folder: Path, case: str, key: str) -> np.ndarray:
    """One float32 array of a parity case (``<case>.json`` + ``.bin``, as ``emdm.fixtures.write_case`` writes)."""
    meta = json.loads((folder / f"{case}.json").read_text())
    if key not in meta["arrays"]:
        raise KeyError(f"{folder / f'{case}.json'}: no array {key!r}")
    a = meta["arrays"][key]
    n = int(np.prod(a["shape"], dtype=np.int64))
    return np.frombuffer((folder / meta["bin"]).read_bytes(), "<f4", count=n, offset=a["offset"]).reshape(a["shape"])


def _axis_angle(axis, angle: np.ndarray) -> np.ndarray:
    """(F,) angles about a fixed axis → (F, 3, 3) rotations (Rodrigues)."""
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    a = np.asarray(angle, float)[:, None, None]
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * (K @ K)


def bend_joints(frames: int = 40) -> np.ndarray:
    """(frames, 22, 3) float32: the reference skeleton bending, straightening and bending its limbs again."""
    ph = np.linspace(0.0, 2.0 * np.pi, frames)
    local = np.broadcast_to(np.eye(3), (frames, sk.NUM_JOINTS, 3, 3)).copy()
    n = {name: i for i, name in enumerate(sk.JOINT_NAMES)}
    flex = 0.3 * (1 + np.cos(ph)) - 0.13          # the rest leg is bent ~0.13 rad: straight twice, then bent back
    local[:, 0] = _axis_angle([0, 1, 0], 0.8 * np.sin(ph / 2))
    local[:, n["l_knee"]] = _axis_angle([1, 0, 0], flex)
    local[:, n["r_knee"]] = _axis_angle([1, 0, 0], 0.6 - flex)
    local[:, n["l_hip"]] = _axis_angle([0.2, 0.1, 1.0], 0.4 * np.sin(ph))
    local[:, n["l_elbow"]] = _axis_angle([0, -1, 0], 0.9 * (1 - np.cos(ph)) / 2)
    local[:, n["r_elbow"]] = _axis_angle([0, 1, 0], 0.02 + 0.7 * np.sin(ph) ** 2)
    local[:, n["l_shoulder"]] = _axis_angle([1, 0, 0], 0.7 * np.sin(ph))          # twist about the upper arm
    local[:, n["r_shoulder"]] = _axis_angle([0.3, 0, 1], -0.5 * np.cos(ph))
    local[:, n["spine2"]] = _axis_angle([0, 1, 0], 0.3 * np.sin(2 * ph))
    root = np.stack([0.02 * np.arange(frames), 0.92 + 0.01 * np.sin(ph), 0.03 * np.arange(frames)], -1)
    return forward_kinematics(root, local).astype(np.float32)


def case_inputs(parity_dir: Path = PARITY_DIR) -> dict[str, tuple[np.ndarray, str]]:
    """The input joints of each case and where they came from."""
    return {
        "real": (read_case_array(parity_dir, "recover", "joints"),
                 "recover fixture joints (" + json.loads((parity_dir / "recover.json").read_text())["source"] + ")"),
        "generated": (read_case_array(parity_dir, "model-emdm-t2m-web", "joints"),
                      "model-emdm-t2m-web parity run joints"),
        "bend": (bend_joints(), "emdm.motion.ik_fixture.bend_joints"),
    }


def solve_case(joints: np.ndarray) -> dict[str, np.ndarray]:
    ik = solve_ik(joints)
    return {"root": ik.root, "quats": quaternions(ik.local), "offsets": ik.offsets}


def make(out_dir: Path = PARITY_DIR, inputs: dict[str, tuple[np.ndarray, str]] | None = None) -> Path:
    """Write ``ik.json`` / ``ik.bin`` and ``ik.bvh`` (the writer's BVH of the ``generated`` case) into ``out_dir``."""
    inputs = case_inputs() if inputs is None else inputs
    arrays: dict[str, np.ndarray] = {}
    meta = {"cases": {}, "bvh": f"{NAME}.bvh", "bvhCase": BVH_CASE, "fps": sk.FPS}
    for case, (joints, source) in inputs.items():
        joints = np.asarray(joints, dtype=np.float32)
        arrays[f"{case}_joints"] = joints
        for key, value in solve_case(joints).items():
            arrays[f"{case}_{key}"] = value
        meta["cases"][case] = {"frames": int(joints.shape[0]), "source": source}
    path = write_case(out_dir, NAME, meta, arrays)
    # in centimetres (4 decimals, as it has been written since the fixture began); tests/unit/coreIk.test.ts
    # asks writeBVH for cm too, and both sides test that the metres file is this one ÷ 100
    bvh = bvh_text(np.asarray(inputs[BVH_CASE][0], dtype=np.float32), units="cm")
    (out_dir / f"{NAME}.bvh").write_text(bvh)
    return path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.motion.ik_fixture", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PARITY_DIR)
    args = ap.parse_args(argv)
    path = make(args.out)
    print(f"ik_fixture: wrote {path} and {path.with_suffix('.bvh')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
