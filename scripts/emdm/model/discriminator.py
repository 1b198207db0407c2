"""The conditional DDGAN discriminator D(x_{k}, x_{k+1}, c, t) → logit.

An MLP over [flatten x_k, flatten x_{k+1} (both over 196 frames, zero in padding), time embedding (128),
condition embedding (128)] with SELU and GroupNorm after the second and fourth layer; widths
w, w, w/2, w/2, w/4, w/16, 1 (w = 1024 as released). Because one model is trained for several step counts
(a pair at time t_{k+1} can come from different gaps), the time embedding reads both t_{k+1} and t_k.
``cond_dim = 0`` gives an unconditional D (the `--no-d-cond` ablation).
"""

from __future__ import annotations

import torch
from torch import nn

from emdm.model.layers import EluSELU, sinusoid

T_EMB = 128


class Discriminator(nn.Module):
    def __init__(self, cond_dim: int, feature_dim: int = 263, max_frames: int = 196, width: int = 1024,
                 groups: int = 32):
        super().__init__()
        self.cond_dim, self.feature_dim, self.max_frames, self.width = cond_dim, feature_dim, max_frames, width
        self.time_mlp = nn.Sequential(nn.Linear(2 * T_EMB, T_EMB), nn.SiLU(), nn.Linear(T_EMB, T_EMB))
        self.cond_proj = nn.Linear(cond_dim, T_EMB) if cond_dim > 0 else None
        in_dim = 2 * max_frames * feature_dim + T_EMB + (T_EMB if cond_dim > 0 else 0)
        w = width
        dims = [in_dim, w, w, w // 2, w // 2, w // 4, max(w // 16, 8)]
        layers: list[nn.Module] = []
        for i in range(len(dims) - 1):
            layers.append(nn.Linear(dims[i], dims[i + 1]))
            if i in (1, 3):
                # ≥ 4 channels per group: a group of one channel normalises to 0 and D would ignore its input
                layers.append(nn.GroupNorm(max(1, min(groups, dims[i + 1] // 4)), dims[i + 1]))
            layers.append(EluSELU())
        layers.append(nn.Linear(dims[-1], 1))
        self.net = nn.Sequential(*layers)

    def config(self) -> dict:
        return {"cond_dim": self.cond_dim, "feature_dim": self.feature_dim, "max_frames": self.max_frames,
                "width": self.width}

    def _flat(self, x: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        b, length, f = x.shape
        if length > self.max_frames:
            raise ValueError(f"discriminator: sequence of {length} frames exceeds max_frames={self.max_frames}")
        x = x * mask.unsqueeze(-1)
        x = torch.nn.functional.pad(x, (0, 0, 0, self.max_frames - length))
        return x.reshape(b, self.max_frames * f)

    def forward(self, x_prev: torch.Tensor, x_t: torch.Tensor, cond: torch.Tensor, t: torch.Tensor,
                t_prev: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """x_prev, x_t (B, L, 263); cond (B, C); t, t_prev (B,); mask (B, L) → logits (B,)."""
        temb = self.time_mlp(torch.cat([sinusoid(t * 1000.0, T_EMB), sinusoid(t_prev * 1000.0, T_EMB)], dim=-1))
        parts = [self._flat(x_prev, mask), self._flat(x_t, mask), temb]
        if self.cond_proj is not None:
            parts.append(self.cond_proj(cond))
        return self.net(torch.cat(parts, dim=-1)).squeeze(-1)
