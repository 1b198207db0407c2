"""Plausibility measures on synthetic motions whose penetration, floating and skating are known."""

import numpy as np
import pytest

from emdm.eval.plausibility import batch_plausibility, motion_plausibility

FPS = 20.0


def _standing(frames=40, toe_height=0.02):
    """22 joints: body joints high above the floor, the two toe joints (10, 11) at toe_height."""
    j = np.zeros((frames, 22, 3))
    j[:, :, 1] = np.linspace(0.1, 1.7, 22)[None, :]      # body well above the floor
    j[:, 10, :] = [0.1, toe_height, 0.0]
    j[:, 11, :] = [-0.1, toe_height, 0.0]
    return j


def test_still_standing_motion_is_clean():
    p = motion_plausibility(_standing(), FPS)
    assert p.penetration_mm == 0.0 and p.floating_mm == 0.0
    assert p.skate_cm_s == 0.0 and p.skate_ratio == 0.0
    assert p.contact_pairs == 2 * 39


def test_penetration_is_depth_of_lowest_joint():
    j = _standing(toe_height=-0.03)                     # both toes 3 cm under the floor
    p = motion_plausibility(j, FPS)
    assert p.penetration_mm == pytest.approx(30.0)
    assert p.floating_mm == 0.0


def test_floating_counts_height_beyond_tolerance():
    j = _standing(toe_height=0.15)                      # lowest joint 15 cm up: 10 cm beyond 5 cm
    j[:, :, 1] = np.maximum(j[:, :, 1], 0.15)
    p = motion_plausibility(j, FPS, float_tol=0.05)
    assert p.floating_mm == pytest.approx(100.0)
    assert p.penetration_mm == 0.0
    assert p.contact_pairs == 0 and p.skate_cm_s == 0.0   # nothing touches the floor


def test_half_the_frames_floating():
    j = _standing(frames=40)
    j[20:, :, 1] += 0.25                                # jump: lowest joint at 0.27 m for 20 frames
    p = motion_plausibility(j, FPS, float_tol=0.05)
    assert p.floating_mm == pytest.approx(0.5 * (270.0 - 50.0))


def test_sliding_foot_in_contact_is_skate():
    j = _standing(frames=41)
    # left toe slides along +x at 0.8 m/s while on the floor; the right foot stays planted
    j[:, 10, 0] = 0.1 + 0.8 * np.arange(41) / FPS
    p = motion_plausibility(j, FPS)
    # mean over both feet's contact pairs: (0.8 m/s · 40 + 0 · 40) / 80
    assert p.skate_cm_s == pytest.approx(40.0)
    assert p.skate_ratio == pytest.approx(1.0)          # every pair has a foot sliding > 0.5 m/s
    assert p.phys_err_mm == pytest.approx(0.4 / FPS * 1000)


def test_a_lifted_moving_foot_is_not_skate():
    j = _standing(frames=41)
    j[:, 10, 0] = 0.1 + 0.8 * np.arange(41) / FPS     # moving fast …
    j[:, 10, 1] = 0.2                                   # … in the air (swing phase)
    p = motion_plausibility(j, FPS)
    assert p.skate_cm_s == 0.0 and p.skate_ratio == 0.0
    assert p.contact_pairs == 40                         # only the planted right foot


def test_vertical_motion_of_a_planted_foot_is_not_skate():
    j = _standing(frames=41)
    j[:, 10, 1] = 0.01 + 0.02 * (np.arange(41) % 2)    # bobs up and down under the threshold
    assert motion_plausibility(j, FPS).skate_cm_s == 0.0


def test_batch_reports_per_motion_and_names_the_bad_one():
    good = _standing()
    out = batch_plausibility([good, _standing(toe_height=-0.01)], FPS)
    np.testing.assert_allclose(out["penetration_mm"], [0.0, 10.0])
    with pytest.raises(ValueError, match="motion 1: joints: expected shape"):
        batch_plausibility([good, good[:, :, :2]], FPS)
