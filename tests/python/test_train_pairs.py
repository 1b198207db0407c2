"""The (t, x_{k+1}, x_k) transitions the trainer learns are exactly those the sampler takes, for every supported
step count: same time values, posterior coefficients and σ (the sampler's update replayed through the
trainer's ``posterior`` gives the sampler's x bit for bit), the trainer's forward-process pairs follow that same
posterior, the top step's input is the sampler's N(0, I) start, and guidance uses one z for both halves."""

import numpy as np
import pytest
import torch

from emdm.model import objectives as O
from emdm.sampler.schedule import SUPPORTED_STEPS, make_schedule
from emdm.sampler import SamplingSettings, sample_features

F_DIM, FRAMES = 5, 7


def x0_of(x, c, t):
    return (np.tanh(x) * 0.5 + c[:, :1, None] + t[:, None, None]).astype(np.float32)


def fake_model(calls: list):
    """A step model that records its inputs; x̂_0 = a fixed nonlinear function of (x, c, t)."""
    def step(x, z, c, t, mask):
        calls.append({"x": x.copy(), "z": z.copy(), "c": c.copy(), "t": t.copy()})
        return x0_of(x, c, t)
    return step


@pytest.mark.parametrize("T", SUPPORTED_STEPS)
def test_tables_hold_the_samplers_float32_schedule(T):
    tab = O.ScheduleTables([T], torch.device("cpu"))
    sch = make_schedule(T)
    slot, k = torch.zeros(T, dtype=torch.long), torch.arange(T)
    for name in ("time", "time_prev", "coef1", "coef2", "sigma"):
        assert np.array_equal(tab.get(name, slot, k).numpy(), getattr(sch, name).astype(np.float32)), name


@pytest.mark.parametrize("T", SUPPORTED_STEPS)
def test_sampler_steps_replayed_through_the_trainer_posterior(T):
    calls: list = []
    cond = np.array([0.3, -1.0], np.float32)
    settings = SamplingSettings(steps=T, z_dim=3, feature_dim=F_DIM)
    out = sample_features(fake_model(calls), cond, FRAMES, settings, seed=5, num=2)
    assert len(calls) == T
    tab = O.ScheduleTables(list(SUPPORTED_STEPS), torch.device("cpu"))
    slot = torch.full((2,), list(SUPPORTED_STEPS).index(T))
    rng = np.random.default_rng(5)                       # the sampler's draws: x_T, then per step z, then ε
    x = rng.standard_normal((2, FRAMES, F_DIM), dtype=np.float32)
    mask = torch.ones(2, FRAMES)
    for i, k in enumerate(range(T - 1, -1, -1)):
        kk = torch.full((2,), k)
        assert np.array_equal(calls[i]["x"], x)
        assert np.array_equal(calls[i]["t"], tab.get("time", slot, kk).numpy())        # G sees t_{k+1}
        rng.standard_normal((2, 3), dtype=np.float32)                                      # z
        x0 = x0_of(x, np.repeat(cond[None], 2, 0), calls[i]["t"])
        noise = rng.standard_normal(x.shape, dtype=np.float32) if make_schedule(T).sigma[k] > 0 else np.zeros_like(x)
        x = O.posterior(tab, torch.from_numpy(x0), torch.from_numpy(x), slot, kk, mask, torch.from_numpy(noise)).numpy()
    np.testing.assert_allclose(out, x, rtol=0, atol=2e-6)


@pytest.mark.parametrize("T", SUPPORTED_STEPS)
def test_forward_pairs_follow_the_samplers_posterior(T):
    """x_k − coef1·x_0 − coef2·x_{k+1} over the trainer's pairs: mean 0, std σ[k], uncorrelated with x_{k+1}."""
    torch.manual_seed(0)
    tab = O.ScheduleTables([T], torch.device("cpu"))
    sch = make_schedule(T)
    n = 4096
    x0 = torch.linspace(-2, 2, n)[:, None, None].expand(n, 1, 8).contiguous()
    for k in range(T):
        tab.draw = lambda b, dev, k=k: (torch.zeros(b, dtype=torch.long), torch.full((b,), k))
        x_k, x_k1, slot, kk = O.pairs(tab, x0, torch.ones(n, 1))
        r = (x_k - sch.coef1[k] * x0 - sch.coef2[k] * x_k1).flatten().double()
        assert abs(float(r.mean())) < 0.01 + 0.02 * sch.sigma[k]
        # (k = 0: the real x_0 keeps the β_0 = 1e-8 convention's noise, std s_cum[0] = 1e-4; the sampler's σ is 0)
        assert abs(float(r.std()) - sch.sigma[k]) < 0.02 * sch.sigma[k] + 1.5e-4, (k, float(r.std()), sch.sigma[k])
        c = np.corrcoef(r.numpy(), x_k1.flatten().double().numpy())[0, 1] if sch.sigma[k] > 0 else 0.0
        assert abs(c) < 0.03, (k, c)
        # and the marginal of x_{k+1} is N(a_cum[k+1] x_0, s_cum[k+1]²): the time G is told is its true noise level
        e = (x_k1 - sch.a_cum[k + 1] * x0).flatten()
        assert abs(float(e.std()) - sch.s_cum[k + 1]) < 0.02


def test_top_step_input_is_the_samplers_pure_noise_start():
    """x_T = a·x_0 + s·ε at t = 1 for every T; with unit-variance (normalised) data its marginal has mean 0 and
    variance a² + s² = 1, the sampler's N(0, I). Numbers in the issue note: a = 0.00657, s = 0.99998."""
    vals = {T: (make_schedule(T).a_cum[T], make_schedule(T).s_cum[T]) for T in SUPPORTED_STEPS}
    a, s = vals[10]
    assert all(np.isclose(v[0], a, rtol=1e-9) and np.isclose(v[1], s, rtol=1e-12) for v in vals.values())
    assert 0.0065 < a < 0.0066 and abs(a * a + s * s - 1.0) < 1e-7
    assert make_schedule(10).time[-1] == 1.0


def test_guidance_uses_one_z_and_the_zero_condition_the_trainer_drops_to():
    calls: list = []
    cond = np.array([0.3, -1.0], np.float32)
    settings = SamplingSettings(steps=4, guidance=2.5, z_dim=3, feature_dim=F_DIM)
    sample_features(fake_model(calls), cond, FRAMES, settings, seed=1, num=3)
    for c in calls:
        assert np.array_equal(c["z"][:3], c["z"][3:]) and np.array_equal(c["x"][:3], c["x"][3:])
        assert np.array_equal(c["c"][:3], np.repeat(cond[None], 3, 0)) and not c["c"][3:].any()


@pytest.mark.parametrize("mode", ["steps", "pairs"])
def test_time_draw_shares(mode):
    """--time-draw: the share of training samples at each (T, k)."""
    torch.manual_seed(0)
    tab = O.ScheduleTables(list(SUPPORTED_STEPS), torch.device("cpu"), mode)
    slot, k = tab.draw(200_000, torch.device("cpu"))
    T = tab.steps_t[slot]
    assert (k >= 0).all() and (k < T).all()
    top10 = float(((T == 10) & (k == 8)).float().mean())            # 10 steps' t = 0.9
    want = 1 / 60 if mode == "steps" else 1 / 30
    assert abs(top10 - want) < 0.002, top10
    t1 = float((k == T - 1).float().mean())                          # t = 1, every T's first sampler step
    assert abs(t1 - (0.3625 if mode == "steps" else 0.2)) < 0.005, t1
