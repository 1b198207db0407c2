"""Batched generation for evaluation runs the project's own sampling loop (emdm.sample) with each
row's condition and length."""

import numpy as np
import torch

from emdm.eval.sources import batched_features, variant_of
from emdm.model.generator import Generator
from emdm.model.open import torch_step
from emdm.sampler import SamplingSettings, sample_features

torch.set_num_threads(1)


def _tiny(cond_dim=8):
    torch.manual_seed(0)
    return Generator(cond_dim, "tiny").eval()


def test_rows_with_one_condition_equal_sample_features_exactly():
    G = _tiny()
    c = np.random.default_rng(0).normal(size=8).astype(np.float32)
    ref = sample_features(torch_step(G), c, 30, SamplingSettings(steps=4, guidance=2.5), seed=7, num=3)
    got = batched_features(torch_step(G), np.stack([c] * 3), np.array([30, 30, 30]), SamplingSettings(steps=4, guidance=2.5), 7)
    np.testing.assert_array_equal(np.stack(got), ref)


def test_guidance_interval_rows_equal_sample_features_exactly():
    G = _tiny()
    c = np.random.default_rng(1).normal(size=8).astype(np.float32)
    interval = SamplingSettings(steps=4, guidance=2.5, guidance_min_time=0.6)
    ref = sample_features(torch_step(G), c, 30, interval, seed=7, num=2)
    got = batched_features(torch_step(G), np.stack([c] * 2), np.array([30, 30]), interval, 7)
    np.testing.assert_array_equal(np.stack(got), ref)
    full = sample_features(torch_step(G), c, 30, SamplingSettings(steps=4, guidance=2.5), seed=7, num=2)
    assert np.abs(full - ref).max() > 1e-6


def test_each_row_gets_its_condition_and_mask():
    calls = []

    def spy(x, z, c, t, mask):
        calls.append((c.copy(), mask.copy()))
        return np.zeros_like(x)

    conds = np.arange(3 * 4, dtype=np.float32).reshape(3, 4) + 1
    out = batched_features(spy, conds, np.array([5, 9, 7]), SamplingSettings(steps=2, guidance=2.5), 0)
    assert [o.shape for o in out] == [(5, 263), (9, 263), (7, 263)]
    assert len(calls) == 2
    for c, m in calls:
        np.testing.assert_array_equal(c, np.concatenate([conds, np.zeros_like(conds)]))   # [c, 0] for guidance
        np.testing.assert_array_equal(m.sum(1), [5, 9, 7, 5, 9, 7])


def test_unconditional_rows_skip_guidance():
    calls = []

    def spy(x, z, c, t, mask):
        calls.append(c.shape[0])
        return np.zeros_like(x)

    batched_features(spy, np.zeros((2, 4), np.float32), np.array([6, 6]), SamplingSettings(steps=3, guidance=2.5), 0)
    assert calls == [2, 2, 2]


def test_variant_from_training_flags():
    assert variant_of({"objective": "diffusion", "args": {}}) == "diffusion"
    assert variant_of({"objective": "ddgan", "args": {"geo_weight": 100.0, "d_cond": True}}) == "emdm"
    assert variant_of({"objective": "ddgan", "args": {"geo_weight": 0.0, "d_cond": False}}) == "ddgan-naive"
    assert variant_of({"objective": "ddgan", "args": {"geo_weight": 100.0, "d_cond": False}}) == "ddgan-nodcond"


def test_guidance_interval_runs_the_conditional_rows_alone_below_it():
    calls = []

    def spy(x, z, c, t, mask):
        calls.append((float(t[0]), c.copy(), mask.copy()))
        return np.zeros_like(x)

    conds = np.arange(2 * 4, dtype=np.float32).reshape(2, 4) + 1
    batched_features(spy, conds, np.array([5, 9]), SamplingSettings(steps=4, guidance=2.5, guidance_min_time=0.6), 0)
    assert [round(t, 3) for t, _, _ in calls] == [1.0, 0.75, 0.501, 0.251]
    for t, c, m in calls:
        want = np.concatenate([conds, np.zeros_like(conds)]) if t > 0.6 else conds
        np.testing.assert_array_equal(c, want)
        np.testing.assert_array_equal(m.sum(1), [5, 9] * (len(want) // 2))


def test_x0_smoothing_rows_equal_sample_features_and_stay_within_each_length():
    """batched_features with x0_smoothing: rows of one length equal sample_features exactly; a shorter row padded in
    the batch is smoothed over its own frames (equal to sampling it alone at its length, up to the model's batch
    numerics), not over the padding."""
    G = _tiny()
    c = np.random.default_rng(2).normal(size=8).astype(np.float32)
    smoothed = SamplingSettings(steps=4, guidance=2.5, x0_smoothing=1.0)
    ref = sample_features(torch_step(G), c, 30, smoothed, seed=7, num=2)
    got = batched_features(torch_step(G), np.stack([c] * 2), np.array([30, 30]), smoothed, 7)
    np.testing.assert_array_equal(np.stack(got), ref)
    plain = sample_features(torch_step(G), c, 30, SamplingSettings(steps=4, guidance=2.5), seed=7, num=2)
    assert np.abs(plain - ref).max() > 1e-6
    calls = []

    def spy(x, z, c, t, mask):
        calls.append(x.copy())
        return np.where(mask[..., None] > 0, 1.0, 50.0).astype(np.float32) * np.ones_like(x)

    batched_features(spy, np.ones((2, 4), np.float32), np.array([9, 5]), SamplingSettings(steps=2, guidance=1.0, x0_smoothing=1.0), 0)
    # the second call's x holds coef1·smooth(x̂0) + …: a row smoothed over its padding (50s) would carry them in
    from emdm.sampler.schedule import make_schedule

    sch = make_schedule(2)
    rng = np.random.default_rng(0)
    x_T = rng.standard_normal((2, 9, 263), dtype=np.float32)
    rng.standard_normal((2, 64), dtype=np.float32)
    eps = rng.standard_normal((2, 9, 263), dtype=np.float32)
    smooth_part = (calls[1] - np.float32(sch.coef2[1]) * x_T - np.float32(sch.sigma[1]) * eps) / np.float32(sch.coef1[1])
    np.testing.assert_allclose(smooth_part[1, :5], 1.0, atol=1e-4)
    np.testing.assert_allclose(smooth_part[0], 1.0, atol=1e-4)
