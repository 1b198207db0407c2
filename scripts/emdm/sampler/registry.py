"""The update rules the sampling loop can run, by ``SamplingSettings.method`` (the TypeScript sampler keeps the same
names: src/sampler/). A new sampler is one module with one update function, in the manner of a diffusers
scheduler's ``step()``, plus one line here:

    SAMPLERS["x0"] = Sampler(x0_update)

An update is ``update(x, x0, k, schedule, noise) -> x_k``: x = x_{k+1} (the rows and frames the model saw), x0 the
model's x̂0 (guided, smoothed and inpainted), k the step index (T−1 down to 0), ``schedule`` an
``emdm.sampler.schedule.Schedule`` and ``noise()`` a draw of ε of x's shape from the run's generator (draw only what
you use: the draws of a run are x_T, then per step z, then what the update draws)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from emdm.sampler.ddgan import ddgan_update
from emdm.sampler.ddim import ddim_update
from emdm.sampler.schedule import Schedule

Update = Callable[[np.ndarray, np.ndarray, int, Schedule, Callable[[], np.ndarray]], np.ndarray]


@dataclass(frozen=True)
class Sampler:
    """An update rule; ``uses_z`` False: the model is given z = 0 (z is still drawn, so every rule draws alike)."""
    update: Update
    uses_z: bool = True


SAMPLERS: dict[str, Sampler] = {
    "ddgan": Sampler(ddgan_update),
    "ddim": Sampler(ddim_update, uses_z=False),
}
