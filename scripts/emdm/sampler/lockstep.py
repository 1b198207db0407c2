"""Several sampling runs, one model call per step (the TypeScript twin is src/sampler/lockstep.ts): a timeline's
windows sampled together up to the step where each needs the motion it continues (``emdm.motion.edit``). One call
costs less than its parts where ORT has threads to spare."""

from __future__ import annotations

import numpy as np

from emdm.sampler.sampler import STOP, StepFn, drive
from emdm.sampler.settings import SampleError


def run_together(runs: list, step: StepFn) -> None:
    """Advance several ``sampling`` generators (each with ``stop_at``) with one model call per step for all of them,
    until every one has stopped (``STOP``): their inputs are stacked, frames padded to the longest with mask 0 (the
    model's attention ignores them), and each gets its own rows of x̂0 back. Then ``finish`` each."""
    reqs = [next(r) for r in runs]
    while True:
        live = [i for i, q in enumerate(reqs) if not isinstance(q, str)]
        if not live:
            return
        parts = [reqs[i] for i in live]
        x0 = call(step, parts)
        row = 0
        for i, p in zip(live, parts):
            b, n = p[0].shape[:2]
            try:
                reqs[i] = runs[i].send(x0[row:row + b, :n])
            except StopIteration:
                raise SampleError("run_together: a run ended without stopping; give every run stop_at") from None
            row += b


def call(step: StepFn, parts: list) -> np.ndarray:
    """One model call for several runs' inputs (x, z, c, t, mask): frames padded to the longest, mask 0 there."""
    length = max(p[0].shape[1] for p in parts)

    def pad(a: np.ndarray) -> np.ndarray:
        return np.pad(a, [(0, 0), (0, length - a.shape[1])] + [(0, 0)] * (a.ndim - 2), constant_values=0)

    return np.asarray(step(np.concatenate([pad(p[0]) for p in parts]), np.concatenate([p[1] for p in parts]),
                           np.concatenate([p[2] for p in parts]), np.concatenate([p[3] for p in parts]),
                           np.concatenate([pad(p[4]) for p in parts])), np.float32)


def finish(run, step: StepFn, known: np.ndarray | None = None) -> np.ndarray:
    """Go on with a run stopped by ``run_together`` (or ``stop_at``): send it ``known`` and drive it to its result."""
    return drive(run, step, known, first=STOP)
