import numpy as np
import pytest

from emdm.sampler.schedule import SUPPORTED_STEPS, make_schedule, marginal_coeffs

# GUIDE.md §2, the released EMDM schedule for T = 10
COEF1 = [1, .733296, .533459, .395428, .285253, .192545, .118440, .065528, .032485, .014439]
COEF2 = [0, .262413, .440360, .527752, .555806, .544621, .511321, .469410, .426843, .386898]
SIGMA = [0, .285732, .475748, .617243, .721643, .795265, .845178, .879156, .903482, .921970]


def test_t10_matches_the_released_vector():
    s = make_schedule(10)
    np.testing.assert_allclose(s.coef1, COEF1, atol=1e-6)
    np.testing.assert_allclose(s.coef2, COEF2, atol=1e-6)
    np.testing.assert_allclose(s.sigma, SIGMA, atol=1e-6)
    np.testing.assert_allclose(s.time, (np.arange(1, 11) / 10) * 0.999 + 0.001)


@pytest.mark.parametrize("T", SUPPORTED_STEPS)
def test_every_step_count_ends_in_a_clean_sample(T):
    s = make_schedule(T)
    assert s.coef1[0] == pytest.approx(1.0) and s.coef2[0] == pytest.approx(0.0) and s.sigma[0] == 0.0
    assert s.time[-1] == pytest.approx(1.0)
    assert s.s_cum[-1] > 0.99            # x_T is (almost) pure noise
    assert np.all(np.diff(s.time) > 0)


@pytest.mark.parametrize("T", SUPPORTED_STEPS)
def test_marginal_depends_only_on_continuous_time(T):
    s = make_schedule(T)
    a, sd = marginal_coeffs(s.time)
    np.testing.assert_allclose(a, s.a_cum[1:], atol=1e-12)
    np.testing.assert_allclose(sd, s.s_cum[1:], atol=1e-12)


def test_posterior_is_consistent_with_the_forward_process():
    # E[x_k | x_{k+1}, x0] averaged over x_{k+1} must equal E[x_k | x0] = a_cum[k] x0
    s = make_schedule(10)
    for k in range(10):
        assert s.coef1[k] + s.coef2[k] * s.a_cum[k + 1] == pytest.approx(s.a_cum[k], abs=1e-7)


def test_bad_step_count_is_rejected():
    with pytest.raises(ValueError, match="steps"):
        make_schedule(0)
