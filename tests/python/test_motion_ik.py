"""emdm.motion.ik: joints → local rotations with twist, the same algorithm as the page's src/motion/ik.ts.

The parity fixture tests/fixtures/parity/ik.* (``python -m emdm.motion.ik_fixture``) holds Python's angles and
BVH; tests/unit/coreIk.test.ts checks that the page's solveIK / writeBVH give the same, and here that Python
still gives them, so the two cannot drift apart without one side's test failing.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from emdm import skeleton as sk
from emdm.mocap.bvh import forward_kinematics as bvh_fk
from emdm.mocap.bvh import parse_bvh_text
from emdm.writers.bvh import bvh_path, bvh_text
from emdm.motion import ik
from emdm.motion import ik_fixture

N = {n: i for i, n in enumerate(sk.JOINT_NAMES)}
COMMITTED = ik_fixture.PARITY_DIR
REGENERATE = "regenerate it with `.venv/bin/python -m emdm.motion.ik_fixture` and commit tests/fixtures/parity/ik.*"


def committed_inputs() -> dict[str, tuple[np.ndarray, str]]:
    meta = json.loads((COMMITTED / "ik.json").read_text())
    return {c: (ik_fixture.read_case_array(COMMITTED, "ik", f"{c}_joints"), m["source"]) for c, m in meta["cases"].items()}


def quat_angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between unit quaternions (..., 4), well conditioned near 0."""
    b = np.where(np.sum(a * b, -1, keepdims=True) < 0, -b, b)
    return 2 * np.arctan2(np.linalg.norm(a - b, axis=-1), np.linalg.norm(a + b, axis=-1))


def bvh_number_diff(a: str, b: str) -> float:
    """Largest difference between the numbers of two BVH texts that agree in every other token."""
    la, lb = a.splitlines(), b.splitlines()
    assert len(la) == len(lb), f"{len(la)} lines vs {len(lb)}"
    worst = 0.0
    for i, (x, y) in enumerate(zip(la, lb)):
        tx, ty = x.split(), y.split()
        assert len(tx) == len(ty), f"line {i + 1}: {x!r} vs {y!r}"
        for u, v in zip(tx, ty):
            try:
                worst = max(worst, abs(float(u) - float(v)))
            except ValueError:
                assert u == v, f"line {i + 1}: {x!r} vs {y!r}"
    return worst


def fixture_differences(out) -> dict[str, float]:
    """Max angle (rad) / root / offsets / BVH-number difference between the committed fixture and ``out``."""
    got = {}
    for case in committed_inputs():
        a = {k: ik_fixture.read_case_array(COMMITTED, "ik", f"{case}_{k}") for k in ("quats", "root", "offsets")}
        b = {k: ik_fixture.read_case_array(out, "ik", f"{case}_{k}") for k in ("quats", "root", "offsets")}
        got[f"{case} angle"] = float(quat_angle(a["quats"].astype(float), b["quats"].astype(float)).max())
        got[f"{case} root"] = float(np.abs(a["root"] - b["root"]).max())
        got[f"{case} offsets"] = float(np.abs(a["offsets"] - b["offsets"]).max())
    got["bvh"] = bvh_number_diff((COMMITTED / "ik.bvh").read_text(), (out / "ik.bvh").read_text())
    return got


def test_the_committed_ik_fixture_is_what_python_computes(tmp_path):
    ik_fixture.make(tmp_path, committed_inputs())
    diffs = fixture_differences(tmp_path)
    bad = {k: v for k, v in diffs.items()
           if v > (2e-6 if "angle" in k else 2e-4 if k == "bvh" else 1e-6)}
    assert not bad, f"tests/fixtures/parity/ik.* is stale (the TypeScript IK test compares with it): {bad}; {REGENERATE}"


def test_a_changed_twist_rule_makes_the_fixture_stale(tmp_path, monkeypatch):
    """The spine's twist reference blended 1:1 instead of 2:1 / 1:2 between hips and chest must be caught."""
    monkeypatch.setattr(ik, "_mix", lambda a, b, wa: ik._normalize(a) * 0.5 + ik._normalize(b) * 0.5)
    ik_fixture.make(tmp_path, committed_inputs())
    diffs = fixture_differences(tmp_path)
    assert diffs["real angle"] > 1e-3 and diffs["bvh"] > 1e-2, diffs


def rest_joints(frames: int = 1) -> np.ndarray:
    return np.broadcast_to(ik.rest_positions(), (frames, sk.NUM_JOINTS, 3)).copy()


def test_the_rest_pose_gives_identity_rotations():
    res = ik.solve_ik(rest_joints())
    np.testing.assert_allclose(res.local, np.broadcast_to(np.eye(3), res.local.shape), atol=1e-12)
    np.testing.assert_allclose(res.offsets, sk.REFERENCE_OFFSETS, atol=1e-12)


def test_fk_of_ik_reproduces_a_posed_reference_skeleton_exactly():
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    local = Rotation.from_rotvec(rng.normal(size=(12 * 22, 3)) * 0.6).as_matrix().reshape(12, 22, 3, 3)
    joints = ik.forward_kinematics(rng.normal(size=(12, 3)), local)
    res = ik.solve_ik(joints)
    np.testing.assert_allclose(ik.forward_kinematics(res.root, res.local, res.offsets), joints, atol=1e-9)
    np.testing.assert_allclose(res.offsets, sk.REFERENCE_OFFSETS, atol=1e-9)   # a rigid reference body keeps them


def test_a_bent_knee_and_elbow_are_pure_hinges_and_the_hip_twist_is_recovered():
    rest = sk.REFERENCE_OFFSETS
    knee_axis = np.cross(rest[N["l_knee"]], rest[N["l_ankle"]])    # the rest leg's own bend normal (it is bent)
    local = np.broadcast_to(np.eye(3), (1, 22, 3, 3)).copy()
    local[0, N["l_knee"]] = ik_fixture._axis_angle(knee_axis, [0.6])[0]
    local[0, N["r_elbow"]] = ik_fixture._axis_angle([0, 1, 0], [1.0])[0]
    hip = ik_fixture._axis_angle([0.2, 0.0, 1.0], [0.5])[0] @ ik_fixture._axis_angle([0, 1, 0], [0.4])[0]   # swing + twist
    local[0, N["l_hip"]] = hip
    joints = ik.forward_kinematics(np.array([[0.0, 0.94, 0.0]]), local)
    res = ik.solve_ik(joints)
    k = ik.quaternions(res.local)[0, N["l_knee"]]
    assert np.linalg.norm(np.cross(k[:3], knee_axis)) / np.linalg.norm(knee_axis) < 1e-6, "the knee turns about its hinge only"
    e = ik.quaternions(res.local)[0, N["r_elbow"]]
    assert abs(e[0]) < 1e-9 and abs(e[2]) < 1e-9, "the elbow turns about the arm's Y hinge only"
    np.testing.assert_allclose(res.local[0, N["l_hip"]], hip, atol=1e-9)       # twist from the knee's bend plane
    np.testing.assert_allclose(ik.forward_kinematics(res.root, res.local, res.offsets), joints, atol=1e-9)


def test_twist_stays_continuous_when_limbs_straighten():
    q = ik.quaternions(ik.solve_ik(ik_fixture.bend_joints(40)).local)
    step = quat_angle(q[1:], q[:-1])
    assert step.max() < 0.35, f"{sk.JOINT_NAMES[int(step.max(axis=0).argmax())]} jumps {step.max():.2f} rad in one frame"


def test_a_real_clip_is_followed_within_1_cm_with_the_adapted_offsets():
    joints = ik_fixture.read_case_array(COMMITTED, "recover", "joints").astype(np.float64)
    res = ik.solve_ik(joints)
    err = np.linalg.norm(ik.forward_kinematics(res.root, res.local, res.offsets) - joints, axis=-1).max()
    ref = ik.solve_ik(joints, adapt_offsets=False)
    err_ref = np.linalg.norm(ik.forward_kinematics(ref.root, ref.local) - joints, axis=-1).max()
    assert err < 0.01 < err_ref, (err, err_ref)   # the clip's pelvis/chest differ from the reference by cm


@pytest.mark.parametrize("units,per_metre", [("m", 1.0), ("cm", 100.0)])
def test_the_bvh_writer_uses_it_and_reads_back_within_1_cm_on_a_real_clip(units, per_metre):
    """Metres by default: the project's reader puts the pelvis ~0.9 (m) up, as Blender at import scale 1.0
    would; in centimetres ~90."""
    joints = ik_fixture.read_case_array(COMMITTED, "recover", "joints")
    text = bvh_text(joints, units=units) if units != "m" else bvh_text(joints)   # "m": the default
    bvh = parse_bvh_text(text, "real.bvh")
    fk = bvh_fk(bvh)[:, [bvh.index(n) for n in sk.JOINT_NAMES]]          # file units
    pelvis_y = joints[:, N["pelvis"], 1]
    assert 0.7 < pelvis_y.mean() < 1.1                                   # a standing clip, metres
    np.testing.assert_allclose(fk[:, N["pelvis"], 1], per_metre * pelvis_y, atol=1e-3 * per_metre)
    assert np.linalg.norm(fk / per_metre - joints, axis=-1).max() < 0.01
    res = ik.solve_ik(joints)
    l_hip = text.split("JOINT l_hip", 1)[1].split("OFFSET", 1)[1].split("\n", 1)[0].split()
    np.testing.assert_allclose([float(v) for v in l_hip], res.offsets[N["l_hip"]] * per_metre, atol=1e-4)


def test_the_metres_bvh_is_the_centimetres_one_divided_by_100():
    """Same lines and rotations; every length (OFFSETs, root position channels) ÷ 100, with 6 decimals for 4."""
    joints = ik_fixture.read_case_array(COMMITTED, "recover", "joints")[:8]
    m, cm = bvh_text(joints, fps=30).splitlines(), bvh_text(joints, fps=30, units="cm").splitlines()
    assert len(m) == len(cm)
    start = m.index("MOTION") + 3
    worst = 0.0
    for i, (a, b) in enumerate(zip(m, cm)):
        ta, tb = a.split(), b.split()
        assert len(ta) == len(tb), i
        is_length = [ta[0] == "OFFSET" or (i >= start and k < 3) for k in range(len(ta))]
        for k, (x, y) in enumerate(zip(ta, tb)):
            try:
                u, v = float(x), float(y)
            except ValueError:
                assert x == y, (i, a, b)
                continue
            worst = max(worst, abs(u * 100 - v) if is_length[k] else abs(u - v))
        if ta[0] == "OFFSET":
            assert all(len(t.split(".")[1]) == 6 for t in ta[1:]), a
    assert worst <= 1e-4 + 1e-9, worst


def test_bvh_file_names_say_the_unit_and_other_units_are_refused(tmp_path):
    assert bvh_path(tmp_path / "walk").name == "walk.metres.bvh"
    assert bvh_path(tmp_path / "walk_0", "cm").name == "walk_0.centimetres.bvh"
    with pytest.raises(ValueError, match="BVH units must be 'm' or 'cm', got 'mm'"):
        bvh_text(np.zeros((2, 22, 3)), units="mm")


def test_bad_joints_are_refused_with_the_shape_or_the_values():
    with pytest.raises(ValueError, match=r"expected joints of shape \(frames, 22, 3\), got \(5, 21, 3\)"):
        ik.solve_ik(np.zeros((5, 21, 3)))
    j = rest_joints(2)
    j[1, 3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN or infinite"):
        ik.solve_ik(j)
