"""Joint maps (data, per source skeleton): validation, lerp points, z-up, and on real clips:
every built-in map gives a body whose left side is +X when it walks forward (+Z)."""

import json

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.jointmap import BUILTIN_DIR, load_joint_map, parse_joint_map


def _identity_map(**over):
    d = {"name": "t", "format": "bvh", "scale": 1.0, "up": "y", "joints": {n: n for n in sk.JOINT_NAMES}}
    d.update(over)
    return d


@pytest.mark.parametrize("name", ["bandai", "cmu_asfamc", "cmu_cc_bvh"])
def test_builtin_maps_cover_all_22_joints(name):
    m = load_joint_map(name)
    assert set(m.joints) == set(sk.JOINT_NAMES)
    assert (BUILTIN_DIR / f"{name}.json").is_file()


def test_apply_lerp_mean_scale_and_z_up():
    d = _identity_map(scale=0.01, up="z")
    d["joints"]["spine2"] = {"lerp": ["spine1", "spine3", 0.25]}
    d["joints"]["neck"] = {"mean": ["l_collar", "r_collar"]}
    m = parse_joint_map(d, "t.json")
    # source points in cm, Z up: a point at (x, y, z) maps to metres (x, z, -y)
    pts = np.arange(22 * 3, dtype=float).reshape(1, 22, 3) * 100
    out = m.apply(list(sk.JOINT_NAMES), pts)
    src = pts[0] * 0.01
    conv = lambda p: np.array([p[0], p[2], -p[1]])
    np.testing.assert_allclose(out[0, 0], conv(src[0]))
    np.testing.assert_allclose(out[0, 6], conv(src[3] + 0.25 * (src[9] - src[3])))
    np.testing.assert_allclose(out[0, 12], conv((src[13] + src[14]) / 2))
    # the z-up turn is a rotation (handedness kept): det = +1
    M = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]])
    assert np.isclose(np.linalg.det(M), 1.0)


@pytest.mark.parametrize("edit,field", [
    (lambda d: d["joints"].pop("l_wrist"), "joints"),
    (lambda d: d.update(format="fbx"), "format"),
    (lambda d: d.update(scale=None), "scale"),
    (lambda d: d.update(up="x"), "up"),
    (lambda d: d["joints"].update(spine2={"lerp": ["a", "b"]}), "joints.spine2"),
    (lambda d: d["joints"].update(l_toe="x"), "joints"),
])
def test_invalid_maps_name_the_field(tmp_path, edit, field):
    d = _identity_map()
    edit(d)
    p = tmp_path / "m.json"
    p.write_text(json.dumps(d))
    with pytest.raises(MocapFormatError, match=f"field '{field}'") as e:
        load_joint_map(p)
    assert str(p) in str(e.value)


def test_unknown_name_and_broken_json_say_what_to_do(tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        load_joint_map("no_such_rig")
    assert "'no_such_rig'" in str(e.value) and "bandai, cmu_asfamc, cmu_cc_bvh" in str(e.value)
    p = tmp_path / "m.json"
    p.write_text('{"name": "m",\n  "format": "bvh" "scale": 1}')
    with pytest.raises(MocapFormatError, match="column 19") as e:
        load_joint_map(p)
    assert e.value.line == 2 and e.value.path == str(p)


def test_missing_source_point_is_reported():
    m = parse_joint_map(_identity_map(), "t.json")
    with pytest.raises(MocapFormatError, match="needs point 'head'"):
        m.apply([n for n in sk.JOINT_NAMES if n != "head"], np.zeros((1, 21, 3)), "clip.bvh")


SHARED = paths.shared_data_dir()
ARCHIVES = {"bandai": "bandai-namco-motion.tar.xz", "hdm05": "hdm05-subset.tar.xz", "cmu": "cmu-mocap-subset.tar.xz"}


@pytest.mark.skipif(not all((SHARED / a).is_file() for a in ARCHIVES.values()),
                    reason=f"real mocap archives not found in {SHARED} "
                           "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")
@pytest.mark.parametrize("source,pattern,kind", [
    ("bandai", "dataset-2_walk_normal_001.bvh", "bvh"),
    ("cmu", "002_01.bvh", "bvh"),          # Character Creator rig
    ("cmu", "02_01.amc", "amc"),           # the same trial as ASF/AMC
    ("hdm05", "HDM_bd_sneak2StepsLStart_001_120.amc", "amc"),
])
def test_real_walks_face_forward_with_left_at_plus_x(source, pattern, kind):
    from emdm.data.unpack import unpack_archive
    from emdm.mocap import asfamc
    from emdm.mocap.load import find_asf, load_amc_clip, load_bvh_clip
    from emdm.motion.features import heading_angles
    from emdm.motion.retarget import normalize_clip, prepare_take

    root = unpack_archive(SHARED / ARCHIVES[source])
    f = next(root.rglob(pattern))
    if kind == "bvh":
        clip = load_bvh_clip(f, load_joint_map("cmu_cc_bvh" if source == "cmu" else "bandai"))
    else:
        clip = load_amc_clip(f, asfamc.read_asf(find_asf(f)), load_joint_map("cmu_asfamc"))
    J = normalize_clip(prepare_take(clip.joints, clip.fps))
    assert J[-1, 0, 2] > 0.8, "walking forward (+Z) from the first frame's facing"
    assert abs(J[-1, 0, 0]) < 0.5 * J[-1, 0, 2], "mostly straight ahead"
    assert np.all(J[:, 1, 0] - J[:, 2, 0] > 0) or np.median(np.cos(heading_angles(J))) > 0.8
    lr = J[0, [1, 16, 18, 20], 0] - J[0, [2, 17, 19, 21], 0]
    assert np.all(lr > 0), "left hip/shoulder/elbow/wrist at +X of the right ones in the first frame"
    head_up = J[:, 15, 1] - np.minimum(J[:, 10, 1], J[:, 11, 1])
    assert np.median(head_up) > 1.3, "upright: head well above the feet"
