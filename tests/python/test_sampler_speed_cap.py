"""The sampler's root speed cap (``speed_cap``): a motion goes no faster than its first step's conditional x̂0, by
scaling its root velocity channels only; off, the sampler is bit for bit as before. Known answers with a step model
whose root speed is chosen per step and per condition row."""

import dataclasses

import numpy as np
import pytest

from emdm.sampler import SampleError, SamplingSettings, sample_features
from emdm.sampler.sampler import CAP_MIN_SPEED

D, Z, F = 8, 4, 40
NORM = (0.01, 0.02, 0.5, 0.25)          # m1, m2, s1, s2: de-normalised v = x·s + m


def settings(**kw):
    base = SamplingSettings("ddgan", steps=10, guidance=1.0, z_dim=Z, feature_dim=D)
    return dataclasses.replace(base, **kw)


def model(first: float, later: float, uncond: float | None = None):
    """A step whose x̂0 walks along +z at ``first`` m/frame at t = 1 and ``later`` after (``uncond`` for the
    all-zero condition rows), x at 3/4 of z (heading fixed); the other channels carry x_t through."""
    def step(x, z, c, t, m):
        out = x.copy()
        for i in range(len(x)):
            speed = first if t[i] >= 1.0 else later
            if uncond is not None and not np.any(c[i]):
                speed = uncond
            vx, vz = 0.6 * speed, 0.8 * speed
            out[i, :, 1] = (vx - NORM[0]) / NORM[2]
            out[i, :, 2] = (vz - NORM[1]) / NORM[3]
        return out
    return step


def speed(x):
    v = np.hypot(x[..., 1] * NORM[2] + NORM[0], x[..., 2] * NORM[3] + NORM[1])
    return np.median(v, axis=-1)


COND = np.ones(3, np.float32)


def test_a_motion_that_speeds_up_after_the_first_step_is_capped_at_its_speed():
    fast = model(0.10, 0.14)
    x = sample_features(fast, COND, F, settings(speed_cap=1.0, root_norm=NORM), seed=1)
    assert speed(x)[0] == pytest.approx(0.10, rel=1e-5)
    v = x[0, :, 1:3] * np.array(NORM[2:]) + np.array(NORM[:2])
    assert np.allclose(v[:, 0] / v[:, 1], 0.75, rtol=1e-5)           # heading kept
    plain = sample_features(fast, COND, F, settings(), seed=1)
    assert speed(plain)[0] == pytest.approx(0.14, rel=1e-5)
    assert np.array_equal(np.delete(x, [1, 2], axis=2), np.delete(plain, [1, 2], axis=2))   # only channels 1-2
    loose = sample_features(fast, COND, F, settings(speed_cap=1.5, root_norm=NORM), seed=1)
    assert np.array_equal(loose, plain)                                # 0.14 < 1.5 × 0.10: as it was


def test_never_faster_and_not_for_motions_that_do_not_travel():
    slower = model(0.10, 0.07)
    plain = sample_features(slower, COND, F, settings(), seed=2)
    assert np.array_equal(sample_features(slower, COND, F, settings(speed_cap=1.0, root_norm=NORM), seed=2), plain)
    still = model(CAP_MIN_SPEED * 0.5, 0.05)                          # the first x̂0 stands: no reference
    plain = sample_features(still, COND, F, settings(), seed=2)
    assert np.array_equal(sample_features(still, COND, F, settings(speed_cap=1.0, root_norm=NORM), seed=2), plain)


def test_off_is_the_sampler_as_before():
    fast = model(0.10, 0.14)
    a = sample_features(fast, COND, F, settings(), seed=3)
    b = sample_features(fast, COND, F, settings(speed_cap=0.0, root_norm=NORM), seed=3)
    assert np.array_equal(a, b)


def test_the_reference_is_the_conditional_row_not_the_guided_one():
    # guided x̂0 at t = 1: 0.02 + 2 × (0.10 − 0.02) = 0.18; the conditional row alone: 0.10
    guided = model(0.10, 0.14, uncond=0.02)
    x = sample_features(guided, COND, F, settings(guidance=2.0, guidance_min_time=0.55, speed_cap=1.0, root_norm=NORM),
                        seed=4)
    assert speed(x)[0] == pytest.approx(0.10, rel=1e-5)


def test_rows_of_several_lengths_and_kept_entries():
    fast = model(0.10, 0.14)
    lengths = np.array([F, 20])
    x = sample_features(fast, COND, F, settings(speed_cap=1.0, root_norm=NORM), seed=5, num=lengths)
    assert speed(x[:, :20]) == pytest.approx([0.10, 0.10], rel=1e-5)
    keep = np.zeros((F, D), np.float32)
    keep[:10] = 1                                                      # a window's context: its first 10 frames
    known = np.zeros((F, D), np.float32)
    known[:, 1], known[:, 2] = (0.3 - NORM[0]) / NORM[2], (0.4 - NORM[1]) / NORM[3]
    x = sample_features(fast, COND, F, settings(speed_cap=1.0, root_norm=NORM, known=known, keep=keep), seed=5)
    v = np.hypot(x[0, :, 1] * NORM[2] + NORM[0], x[0, :, 2] * NORM[3] + NORM[1])
    assert np.allclose(v[:10], 0.5, rtol=1e-5)                         # the kept frames as given
    assert np.all(v[10:] < 0.14 - 1e-6)                                # the rest slowed


@pytest.mark.parametrize("cap, norm, msg", [(-1.0, NORM, "speed_cap must be"), (float("nan"), NORM, "speed_cap must be"),
                                            (1.0, None, "speed_cap needs root_norm"),
                                            (1.0, (0, 0, 0, 1), "speed_cap needs root_norm")])
def test_bad_settings_are_named(cap, norm, msg):
    with pytest.raises(SampleError, match=msg):
        sample_features(model(0.1, 0.1), COND, F, settings(speed_cap=cap, root_norm=norm), seed=0)


def test_a_manifest_entry_gives_the_cap_and_the_models_normalisation_its_root():
    from emdm import manifest as mf
    entry = {"objective": "ddgan", "defaultSteps": 10, "guidance": 1.5, "speedCap": 1.0, "zDim": 64, "featureDim": 263}
    mean, std = np.arange(263, dtype=np.float32) / 100, np.full(263, 0.5, np.float32)
    s = SamplingSettings.from_entry(entry, mean=mean, std=std)
    assert s.speed_cap == 1.0 and s.root_norm == pytest.approx((0.01, 0.02, 0.5, 0.5))
    with pytest.raises(SampleError, match="speed_cap needs root_norm"):       # a caller that forgot the mean/std
        sample_features(model(0.1, 0.1), COND, F, dataclasses.replace(SamplingSettings.from_entry(entry), z_dim=Z,
                                                                       feature_dim=D), seed=0)
    assert SamplingSettings.from_entry({k: v for k, v in entry.items() if k != "speedCap"}).speed_cap == 0.0
    with pytest.raises(mf.ManifestError, match="speedCap"):
        shipped = mf.load()["models"]["emdm-t2m-web"]
        mf.check_model_entry({**shipped, "speedCap": -1}, "m", "manifest.json")
