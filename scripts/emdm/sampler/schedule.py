"""The variance-preserving DDGAN schedule for a step count T (docs/ARCHITECTURE.md, "Diffusion schedule").

Pure functions of (T, β_min, β_max, ε), computed in float64. Step index k = 0..T-1 denotes the
transition x_{k+1} → x_k; the generator sees the continuous time ``time[k] = t_{k+1}``.

Forward process (as in DDGAN's ``get_sigma_schedule``): t_i = (i/T)(1−ε)+ε, var(t) = 1 − exp(2(−¼t²(β_max−β_min)
− ½tβ_min)), ᾱ(t) = 1 − var(t), β_i = 1 − ᾱ(t_i)/ᾱ(t_{i−1}) for i ≥ 1 (β_0 = 1e-8). The marginal of x_i given
x_0 is N(a_i x_0, s_i² I) with a_i = Π_{j≤i} sqrt(1−β_j), so it depends only on the continuous time t_i,
which is what lets one network serve every T in ``supportedSteps``.

Posterior q(x_k | x_{k+1}, x_0) = N(coef1[k] x_0 + coef2[k] x_{k+1}, sigma[k]²); sigma[0] = 0 (the last step
draws no noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

BETA_MIN = 0.1
BETA_MAX = 20.0
EPS_SMALL = 1e-3
DEFAULT_STEPS = 10
SUPPORTED_STEPS = (1, 2, 4, 5, 8, 10)


@dataclass(frozen=True)
class Schedule:
    steps: int
    time: np.ndarray        # (T,)   continuous time fed to G at step index k (= t_{k+1})
    time_prev: np.ndarray   # (T,)   t_k (the time of the posterior sample; fed to D)
    coef1: np.ndarray       # (T,)   posterior mean coefficient of x0
    coef2: np.ndarray       # (T,)   posterior mean coefficient of x_{k+1}
    sigma: np.ndarray       # (T,)   posterior std (sigma[0] = 0)
    a_cum: np.ndarray       # (T+1,) sqrt(ᾱ) of x_i relative to x_0 (i = 0..T)
    s_cum: np.ndarray       # (T+1,) std of x_i given x_0
    a_step: np.ndarray      # (T+1,) sqrt(1−β_i): x_i = a_step[i] x_{i−1} + s_step[i] ε
    s_step: np.ndarray      # (T+1,) sqrt(β_i)

    def as_manifest(self, digits: int = 9) -> dict[str, list[float]]:
        r = lambda a: [round(float(v), digits) for v in a]  # noqa: E731
        return {"time": r(self.time), "coef1": r(self.coef1), "coef2": r(self.coef2), "sigma": r(self.sigma)}


def continuous_times(steps: int, eps: float = EPS_SMALL) -> np.ndarray:
    """t_i for i = 0..T (float64)."""
    if not isinstance(steps, (int, np.integer)) or steps < 1:
        raise ValueError(f"schedule: steps must be a positive integer, got {steps!r}")
    return np.arange(steps + 1, dtype=np.float64) / steps * (1.0 - eps) + eps


def vp_variance(t: np.ndarray, beta_min: float = BETA_MIN, beta_max: float = BETA_MAX) -> np.ndarray:
    log_mean_coeff = -0.25 * t**2 * (beta_max - beta_min) - 0.5 * t * beta_min
    return 1.0 - np.exp(2.0 * log_mean_coeff)


def make_schedule(steps: int = DEFAULT_STEPS, beta_min: float = BETA_MIN, beta_max: float = BETA_MAX,
                  eps: float = EPS_SMALL) -> Schedule:
    t = continuous_times(steps, eps)
    alpha_bar = 1.0 - vp_variance(t, beta_min, beta_max)
    betas = np.concatenate([[1e-8], 1.0 - alpha_bar[1:] / alpha_bar[:-1]])
    a_step = np.sqrt(1.0 - betas)
    s_step = np.sqrt(betas)
    a_cum = np.cumprod(a_step)
    s_cum = np.sqrt(1.0 - a_cum**2)

    b = betas[1:]                                   # posterior over k = 0..T-1 ("we don't need the zeros")
    alphas = 1.0 - b
    ac = np.cumprod(alphas)
    ac_prev = np.concatenate([[1.0], ac[:-1]])
    post_var = b * (1.0 - ac_prev) / (1.0 - ac)
    coef1 = b * np.sqrt(ac_prev) / (1.0 - ac)
    coef2 = (1.0 - ac_prev) * np.sqrt(alphas) / (1.0 - ac)
    sigma = np.sqrt(np.clip(post_var, 0.0, None))
    sigma[0] = 0.0
    return Schedule(steps=int(steps), time=t[1:].copy(), time_prev=t[:-1].copy(), coef1=coef1, coef2=coef2,
                    sigma=sigma, a_cum=a_cum, s_cum=s_cum, a_step=a_step, s_step=s_step)


def marginal_coeffs(t, beta_min: float = BETA_MIN, beta_max: float = BETA_MAX, eps: float = EPS_SMALL):
    """(a(t), s(t)) of x_t = a x_0 + s ε at continuous time t (numpy or torch), relative to t = ε exactly as
    ``make_schedule``'s a_cum/s_cum (so a(time[k]) == a_cum[k+1] for every T). Works on torch tensors."""
    lib = np if isinstance(t, (np.ndarray, float, int)) else __import__("torch")
    def log_ab(x):
        return 2.0 * (-0.25 * x**2 * (beta_max - beta_min) - 0.5 * x * beta_min)
    ratio = lib.exp(log_ab(t) - log_ab(eps)) * (1.0 - 1e-8)
    a = lib.sqrt(ratio)
    return a, lib.sqrt(1.0 - ratio)
