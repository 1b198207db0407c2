"""The training run's loss log: terms accumulated on the device (no host sync per step), read back every
``--log-every`` steps into ``<out>/log.csv``; a non-finite term stops the run naming its step and term.

    log = StepLog(device); log.add(step, {"loss_d": t, ...}); means = log.means()
"""

from __future__ import annotations

import csv
import os
from pathlib import Path

import torch

from emdm.distributed import Dist

LOG_FIELDS = ["step", "epoch", "wall_s", "sec_per_step", "lr_g", "lr_d", "loss_d", "d_real", "d_fake", "r1",
              "loss_g", "g_adv", "recon", "pos", "vel", "foot", "bone"]
# loss terms in the order a step computes them (the first non-finite one is the cause; later ones follow from it)
LOSS_TERMS = ["d_real", "r1", "d_fake", "loss_d", "g_adv", "recon", "pos", "vel", "foot", "bone", "loss_g"]


class NonFiniteLoss(RuntimeError):
    """A loss term became NaN/inf; the message names the step and the term (one line)."""


def truncate_log(path: Path, step: int) -> int:
    """Drop the rows of log.csv written after ``step`` (a run killed after its last checkpoint logged them; the resumed
    run logs those steps again); returns how many. Rewritten atomically."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return 0

    def after(r: list[str]) -> bool:
        try:
            return int(float(r[0])) > step
        except (ValueError, IndexError):
            return False
    keep = [rows[0]] + [r for r in rows[1:] if not after(r)]
    dropped = len(rows) - len(keep)
    if dropped:
        tmp = path.with_name(path.name + ".tmp")
        with open(tmp, "w", newline="") as f:
            csv.writer(f).writerows(keep)
        os.replace(tmp, path)
    return dropped


class StepLog:
    """Loss terms summed on the device, read back once per log; plus, per term, the first step whose value was
    not finite (-1 = none so far), updated on the device every step without a host synchronisation."""

    def __init__(self, device: torch.device):
        self.keys = LOSS_TERMS
        self.device = device
        self.sums = torch.zeros(len(self.keys), dtype=torch.float64, device=device)
        self.counts = [0] * len(self.keys)
        self.first_bad = torch.full((len(self.keys),), -1, dtype=torch.int64, device=device)
        self._idx: dict[tuple[str, ...], torch.Tensor] = {}

    def add(self, step: int, logs: dict[str, torch.Tensor]) -> None:
        names = tuple(k for k in self.keys if k in logs)
        if names not in self._idx:
            self._idx[names] = torch.tensor([self.keys.index(k) for k in names], device=self.device)
        idx = self._idx[names]
        vals = torch.stack([logs[k].float() for k in names])
        self.sums.index_add_(0, idx, vals.double())
        fb = self.first_bad[idx]
        self.first_bad[idx] = torch.where(~torch.isfinite(vals) & (fb < 0), step, fb)
        for k in names:
            self.counts[self.keys.index(k)] += 1

    def means(self) -> dict[str, float]:
        sums = self.sums.tolist()                     # the one host sync of a log interval
        out = {k: s / c for k, s, c in zip(self.keys, sums, self.counts) if c}
        self.sums.zero_()
        self.counts = [0] * len(self.keys)
        return out

    def first_non_finite(self, dist: Dist) -> tuple[int, list[str]] | None:
        """(step, terms bad at that step in computation order) over all ranks, or None."""
        big = torch.iinfo(torch.int64).max
        fb = torch.where(self.first_bad < 0, big, self.first_bad)
        if dist.world > 1:                            # gloo on CPU tensors, nccl on CUDA ones: both match the device
            dist.all_reduce(fb, torch.distributed.ReduceOp.MIN)
        vals = fb.tolist()
        step = min(vals)
        if step == big:
            return None
        return int(step), [k for k, v in zip(self.keys, vals) if v == step]
