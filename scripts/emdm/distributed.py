"""One training process among ``torchrun``'s (DDP: gloo on CPU, nccl on GPU), or the only one: its rank, the
gradient averaging and the reductions the trainer needs, all no-ops when it runs alone."""

from __future__ import annotations

import os

import torch


class Dist:
    """torchrun environment (rank/world) and a gradient all-reduce (average) for plain modules."""

    def __init__(self, device: torch.device):
        self.device = device                  # collectives on this device's tensors (gloo: CPU, nccl: CUDA)
        self.world = int(os.environ.get("WORLD_SIZE", "1"))
        self.rank = int(os.environ.get("RANK", "0"))
        if self.world > 1 and not torch.distributed.is_initialized():
            backend = "nccl" if device.type == "cuda" else "gloo"
            torch.distributed.init_process_group(backend)

    @property
    def main(self) -> bool:
        return self.rank == 0

    def average_grads(self, module: torch.nn.Module) -> None:
        if self.world == 1:
            return
        grads = [p.grad for p in module.parameters() if p.grad is not None]
        flat = torch.cat([g.reshape(-1) for g in grads])
        torch.distributed.all_reduce(flat)
        flat /= self.world
        off = 0
        for g in grads:
            n = g.numel()
            g.copy_(flat[off:off + n].view_as(g))
            off += n

    def all_reduce(self, t: torch.Tensor, op=None) -> torch.Tensor:
        if self.world > 1:
            torch.distributed.all_reduce(t, op=op or torch.distributed.ReduceOp.SUM)
        return t

    def mean_scalars(self, values: dict[str, float]) -> dict[str, float]:
        if self.world == 1:
            return values
        keys = sorted(values)
        t = self.all_reduce(torch.tensor([values[k] for k in keys], dtype=torch.float64, device=self.device)).tolist()
        return {k: float(v) / self.world for k, v in zip(keys, t)}

    def gather(self, obj):
        if self.world == 1:
            return [obj]
        out = [None] * self.world
        torch.distributed.all_gather_object(out, obj)
        return out

    def barrier(self) -> None:
        if self.world > 1:
            torch.distributed.barrier()

    def close(self) -> None:
        if self.world > 1 and torch.distributed.is_initialized():
            torch.distributed.destroy_process_group()
