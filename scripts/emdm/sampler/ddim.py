"""One deterministic DDIM update (η = 0) for models trained with the plain x0 objective (``python -m emdm.train
--objective diffusion``), docs/ARCHITECTURE.md "DDIM sampling"; the TypeScript twin is src/sampler/ddim.ts:

    ε̂ = (x_{k+1} − a_cum[k+1]·x̂0) / s_cum[k+1]
    x_k = a_cum[k]·x̂0 + s_cum[k]·ε̂          (k > 0)
    x_0 = x̂0                                (k = 0: the last step returns the prediction)

in float32, operation by operation, as the browser computes it. It draws no noise (the loop zeroes z for it)."""

from __future__ import annotations

from typing import Callable

import numpy as np

from emdm.sampler.schedule import Schedule


def ddim_update(x: np.ndarray, x0: np.ndarray, k: int, schedule: Schedule, noise: Callable[[], np.ndarray]) -> np.ndarray:
    """x_k from x = x_{k+1} and the model's x̂0 (same shape); ``noise`` is not called."""
    if k == 0:
        return x0
    eps = (x - np.float32(schedule.a_cum[k + 1]) * x0) / np.float32(schedule.s_cum[k + 1])
    return np.float32(schedule.a_cum[k]) * x0 + np.float32(schedule.s_cum[k]) * eps
