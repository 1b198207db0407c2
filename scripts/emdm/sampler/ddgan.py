"""One DDGAN update (docs/ARCHITECTURE.md "Sampling"; the TypeScript twin is src/sampler/ddgan.ts): a sample of the
posterior q(x_k | x_{k+1}, x̂0) of the variance-preserving schedule,

    x_k = coef1[k]·x̂0 + coef2[k]·x_{k+1} + sigma[k]·ε        (sigma[0] = 0: the last step draws no ε)

in float32, operation by operation, as the browser computes it."""

from __future__ import annotations

from typing import Callable

import numpy as np

from emdm.sampler.schedule import Schedule


def ddgan_update(x: np.ndarray, x0: np.ndarray, k: int, schedule: Schedule, noise: Callable[[], np.ndarray]) -> np.ndarray:
    """x_k from x = x_{k+1} and the model's x̂0 (same shape); ``noise()`` draws ε of that shape (only when
    sigma[k] > 0, so the random draws are x_T, then per step z, then ε)."""
    xn = np.float32(schedule.coef1[k]) * x0 + np.float32(schedule.coef2[k]) * x
    if schedule.sigma[k] > 0:
        xn = xn + np.float32(schedule.sigma[k]) * noise()
    return xn
