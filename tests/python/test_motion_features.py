"""263-d features: layout, sign conventions and the exact inverse (recover_joints)."""

import json

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.motion import features as F
from emdm.motion.retarget import normalize_clip
from emdm.motion.synthetic import synthetic_walk


def test_layout_and_round_trip_is_exact():
    J = synthetic_walk()
    feats = F.extract_features(J)
    assert feats.shape == (59, 263) and feats.dtype == np.float32
    R = F.recover_joints(feats)
    assert np.abs(R - J[:-1]).max() < 1e-5
    # recover uses only [0:67]
    noisy = feats.copy()
    noisy[:, 67:] = np.random.default_rng(0).normal(size=(59, 196))
    np.testing.assert_array_equal(F.recover_joints(noisy), R)


def test_heading_sign_left_turn_is_positive_theta_and_negative_half_rate():
    p = sk.rest_pose()
    assert abs(F.heading_angles(p[None])[0]) < 1e-12, "rest pose faces +Z"
    turned = F.rot_y(np.deg2rad(30), p)
    assert np.isclose(F.heading_angles(turned[None])[0], np.deg2rad(30))
    facing = F.rot_y(np.deg2rad(30), np.array([0.0, 0.0, 1.0]))
    assert facing[0] > 0, "a +30 deg turn faces towards +X, the character's left"
    # constant left turn of w rad/frame -> feature[0] == -w/2 (HumanML3D half-angle quaternion)
    w = 0.05
    J = np.stack([F.rot_y(w * t, p) for t in range(5)])
    np.testing.assert_allclose(F.extract_features(J)[:, 0], -w / 2, atol=1e-7)


def test_root_velocity_is_in_the_root_frame_and_height_is_pelvis_y():
    p = sk.rest_pose()
    # facing +X (theta = 90 deg), walking towards +X at 0.05 m/frame
    base = F.rot_y(np.pi / 2, p)
    J = np.stack([base + [0.05 * t, 0, 0] for t in range(4)])
    f = F.extract_features(J)
    np.testing.assert_allclose(f[:, 1:3], [[0.0, 0.05]] * 3, atol=1e-7)   # forward = +z in the root frame
    np.testing.assert_allclose(f[:, 3], p[0, 1], atol=1e-7)
    # root-relative positions are rotation invariant: same as for the unturned pose
    np.testing.assert_allclose(f[0, 4:67], F.extract_features(np.stack([p, p]))[0, 4:67], atol=1e-6)
    # local velocities: every joint moves forward (+z in the root frame) 0.05 per frame
    v = f[:, 193:259].reshape(3, 22, 3)
    np.testing.assert_allclose(v, np.broadcast_to([0, 0, 0.05], v.shape), atol=1e-7)


def test_foot_contacts_follow_the_squared_step_threshold():
    p = sk.rest_pose()
    J = np.stack([p, p, p])
    J[1:, 10, 2] += 0.1          # left foot slides 10 cm between frames 0 and 1 (0.01 m^2 > 0.002)
    c = F.extract_features(J)[:, 259:263]
    np.testing.assert_array_equal(c, [[1, 0, 1, 1], [1, 1, 1, 1]])


def test_rest_pose_rotations_are_identity_6d():
    p = sk.rest_pose()
    r = F.extract_features(np.stack([p, p]))[0, 67:193].reshape(21, 6)
    np.testing.assert_allclose(r, np.tile([1, 0, 0, 0, 1, 0], (21, 1)), atol=1e-6)


def test_bad_shapes_are_named():
    with pytest.raises(ValueError, match=r"expected shape \(frames, 22, 3\)"):
        F.extract_features(np.zeros((5, 21, 3)))
    with pytest.raises(ValueError, match="at least 2 frames"):
        F.extract_features(np.zeros((1, 22, 3)))
    with pytest.raises(ValueError, match=r"expected shape \(frames, 263\)"):
        F.recover_joints(np.zeros((5, 60)))


def test_committed_fixture_matches_recover_joints():
    """tests/fixtures/data/recover_joints.json is what the TypeScript port is tested against."""
    fx = json.loads((paths.FIXTURES_DIR / "data" / "recover_joints.json").read_text())
    feats = np.array(fx["features"], dtype=np.float64)
    np.testing.assert_allclose(F.recover_joints(feats), np.array(fx["joints"]), atol=1e-6)


SHARED = paths.shared_data_dir()


@pytest.mark.skipif(not (SHARED / "bandai-namco-motion.tar.xz").is_file(),
                    reason=f"real mocap not found: {SHARED}/bandai-namco-motion.tar.xz "
                           "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")
def test_real_clip_round_trip_within_1mm():
    from emdm.data.unpack import unpack_archive
    from emdm.mocap.jointmap import load_joint_map
    from emdm.mocap.load import load_bvh_clip
    from emdm.motion.retarget import prepare_take

    root = unpack_archive(SHARED / "bandai-namco-motion.tar.xz")
    for name in ("dataset-2_walk-turn-left_active_001.bvh", "dataset-1_dance-short_normal_001.bvh"):
        clip = load_bvh_clip(next(root.rglob(name)), load_joint_map("bandai"))
        J = normalize_clip(prepare_take(clip.joints, clip.fps))[:196]
        err = np.abs(F.recover_joints(F.extract_features(J)) - J[:-1]).max()
        assert err < 1e-3, f"{name}: round-trip error {err * 1000:.3f} mm"
