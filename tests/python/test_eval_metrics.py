"""Metric code on cases whose answer is known (issue 7)."""

import numpy as np
import pytest

from emdm.eval import metrics as M


def _gauss(n=600, d=8, seed=0):
    return np.random.default_rng(seed).normal(size=(n, d))


def test_fid_of_identical_sets_is_zero():
    a = _gauss()
    assert M.fid(a, a) == pytest.approx(0.0, abs=1e-6)


def test_fid_of_a_shifted_set_is_the_squared_shift():
    # same covariance, means differ by s: FID = |s|^2 exactly
    a = _gauss()
    shift = np.array([1.0, -2.0, 0, 0, 0, 0, 0, 0.5])
    assert M.fid(a, a + shift) == pytest.approx(float(shift @ shift), rel=1e-6)


def test_fid_grows_when_the_distribution_differs():
    a, b, c = _gauss(seed=1), _gauss(seed=2), _gauss(seed=3) * 3.0
    assert M.fid(a, b) < 0.5          # two samples of one distribution
    assert M.fid(a, c) > 10 * M.fid(a, b)


def test_fid_rejects_mismatched_dims():
    with pytest.raises(ValueError, match="embedding sizes differ"):
        M.fid(_gauss(d=4), _gauss(d=5))


def test_perfect_matcher_has_r_precision_one_and_zero_matching_distance():
    t = _gauss(n=64 * 3, d=16)
    rp, mm = M.r_precision_and_matching(t, t.copy(), rng=0)
    np.testing.assert_allclose(rp, [1.0, 1.0, 1.0])
    assert mm == pytest.approx(0.0, abs=1e-6)


def test_random_matcher_has_chance_r_precision():
    # unrelated embeddings: the true motion's rank is uniform over 32 → top-k ≈ k/32
    t, m = _gauss(n=32 * 200, d=16, seed=4), _gauss(n=32 * 200, d=16, seed=5)
    rp = M.r_precision(t, m, rng=1)
    np.testing.assert_allclose(rp, np.array([1, 2, 3]) / 32, atol=0.01)


def test_r_precision_counts_rank_two_hits_only_from_top2():
    # pool of 32 where every text's own motion is its 2nd nearest
    d = 32
    motions = np.eye(d) * 10.0
    texts = np.empty_like(motions)
    for i in range(d):
        texts[i] = motions[i] * 0.45 + motions[(i + 1) % d] * 0.55   # closer to the next motion
    rp = M.r_precision(texts, motions)
    np.testing.assert_allclose(rp, [0.0, 1.0, 1.0])


def test_r_precision_needs_a_full_pool():
    with pytest.raises(ValueError, match="at least pool=32"):
        M.r_precision(_gauss(n=31), _gauss(n=31))


def test_diversity_of_identical_samples_is_zero():
    a = np.tile(np.arange(8.0), (400, 1))
    assert M.diversity(a, 300, rng=0) == 0.0


def test_diversity_of_unit_gaussians_is_near_sqrt_2d():
    d = 64
    a = _gauss(n=5000, d=d, seed=6)
    assert M.diversity(a, 300, rng=0) == pytest.approx(np.sqrt(2 * d), rel=0.05)


def test_multimodality_zero_for_identical_generations_and_positive_otherwise():
    base = _gauss(n=20, d=6)
    same = np.repeat(base[:, None, :], 30, axis=1)
    assert M.multimodality(same, 10, rng=0) == 0.0
    noisy = same + np.random.default_rng(1).normal(scale=0.1, size=same.shape)
    # two independent N(0, 0.01 I) perturbations: distance ≈ 0.1·sqrt(2·6)
    assert M.multimodality(noisy, 10, rng=0) == pytest.approx(0.1 * np.sqrt(12), rel=0.15)


def test_multimodality_by_label_measures_within_label_spread_only():
    labels = np.repeat(np.arange(4), 50)
    centres = np.eye(4) * 100.0
    acts = centres[labels]                  # far-apart labels, identical within a label
    assert M.multimodality_by_label(acts, labels, 20, rng=0) == 0.0
    with pytest.raises(ValueError, match="label 3 has 1 sample"):
        M.multimodality_by_label(acts[:151], labels[:151], 20, rng=0)


def test_accuracy_and_confusion():
    logits = np.array([[2, 0, 0], [0, 3, 1], [0, 5, 1], [1, 0, 0]], float)
    labels = np.array([0, 1, 2, 0])
    assert M.accuracy(logits, labels) == 0.75
    cm = M.confusion_matrix(logits.argmax(1), labels, 3)
    assert cm.tolist() == [[2, 0, 0], [0, 1, 0], [0, 1, 0]]
    with pytest.raises(ValueError, match="labels must lie"):
        M.accuracy(logits, np.array([0, 1, 3, 0]))


def test_mean_ci95():
    m, h = M.mean_ci95([1.0, 2.0, 3.0, 4.0])
    assert m == 2.5
    assert h == pytest.approx(1.96 * np.std([1, 2, 3, 4]) / 2)
    assert M.mean_ci95([5.0]) == (5.0, 0.0)


def test_non_finite_input_is_named():
    a = _gauss(n=40)
    a[7, 3] = np.nan
    with pytest.raises(ValueError, match=r"acts_a: non-finite value at index \(7, 3\)"):
        M.fid(a, _gauss(n=40))
