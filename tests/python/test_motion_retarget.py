"""Retargeting: 20 fps, reference bone lengths, floor, first-frame origin and facing, windows."""

import numpy as np
import pytest

from emdm import paths
from emdm import skeleton as sk
from emdm.motion import retarget as rt
from emdm.motion.features import heading_angles, rot_y
from emdm.motion.synthetic import synthetic_walk


def _bones(J):
    return np.linalg.norm(J[:, 1:] - J[:, sk.PARENTS[1:]], axis=-1)


def test_resample_30_to_20_fps_interpolates_linearly():
    t = np.arange(31) / 30.0                          # one second at 30 fps
    J = np.zeros((31, 22, 3))
    J[..., 2] = t[:, None]                            # moving 1 m/s along z
    R = rt.resample(J, 30.0)
    assert R.shape[0] == 21
    np.testing.assert_allclose(R[:, 0, 2], np.arange(21) / 20.0, atol=1e-12)
    R120 = rt.resample(np.repeat(J, 4, axis=0)[:121], 120.0)
    assert R120.shape[0] == 21


def test_retarget_gives_reference_bone_lengths_and_keeps_directions():
    rng = np.random.default_rng(1)
    J = synthetic_walk(30)
    src = J * 1.2 + rng.normal(0, 0.01, J.shape)      # a bigger, noisy source body
    out = rt.retarget(src)
    np.testing.assert_allclose(_bones(out), np.broadcast_to(sk.bone_lengths()[1:], (30, 21)), atol=1e-12)
    for b in (4, 18, 15):
        p = sk.PARENTS[b]
        d_src = src[:, b] - src[:, p]
        d_out = out[:, b] - out[:, p]
        cos = (d_src * d_out).sum(-1) / np.linalg.norm(d_src, axis=-1) / np.linalg.norm(d_out, axis=-1)
        assert np.all(cos > 1 - 1e-9)
    # the pelvis path is scaled by reference leg / source leg
    scale = rt.reference_leg_length() / rt.leg_length(src)
    np.testing.assert_allclose(out[:, 0], src[:, 0] * scale)


def test_floor_and_first_frame_normalisation():
    J = rot_y(1.0, synthetic_walk(20)) + [3.0, 0.7, -2.0]
    F = rt.normalize_clip(rt.put_on_floor(J))
    assert abs(F[..., 1].min()) < 1e-12
    np.testing.assert_allclose(F[0, 0, [0, 2]], 0.0, atol=1e-12)
    assert abs(heading_angles(F[:1])[0]) < 1e-9


@pytest.mark.parametrize("frames", [10, 16, 40, 196, 197, 500, 1000])
def test_windows_cover_long_takes_with_overlap(frames):
    w = rt.window_starts(frames, 196, 98, 16)
    if frames < 16:
        assert w == []
        return
    assert w[0][0] == 0 and w[-1][1] == frames
    assert all(16 <= e - s <= 196 for s, e in w)
    assert all(b[0] < a[1] for a, b in zip(w[:-1], w[1:])), "consecutive windows overlap"
    if frames > 196:
        assert all(e - s == 196 for s, e in w)


SHARED = paths.shared_data_dir()


@pytest.mark.skipif(not (SHARED / "cmu-mocap-subset.tar.xz").is_file(),
                    reason=f"real mocap not found: {SHARED}/cmu-mocap-subset.tar.xz "
                           "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")
def test_real_clips_of_different_bodies_get_identical_bone_lengths():
    from emdm.data.unpack import unpack_archive
    from emdm.mocap import asfamc
    from emdm.mocap.jointmap import load_joint_map
    from emdm.mocap.load import load_amc_clip, load_bvh_clip

    root = unpack_archive(SHARED / "cmu-mocap-subset.tar.xz")
    a = load_bvh_clip(next(root.rglob("005_01.bvh")), load_joint_map("cmu_cc_bvh"))
    f = next(root.rglob("01_01.amc"))
    b = load_amc_clip(f, asfamc.read_asf(f.parent / "01.asf"), load_joint_map("cmu_asfamc"))
    assert abs(rt.leg_length(a.joints) - rt.leg_length(b.joints)) > 0.01, "the sources differ"
    for clip in (a, b):
        J = rt.prepare_take(clip.joints, clip.fps)
        np.testing.assert_allclose(_bones(J), np.broadcast_to(sk.bone_lengths()[1:], _bones(J).shape), atol=1e-9)
        assert abs(J[..., 1].min()) < 1e-12
