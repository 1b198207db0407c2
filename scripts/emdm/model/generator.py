"""The EMDM generator G(x_t, z, c, t, mask) → x̂_0 (one denoising step).

Token sequence [t, c, z, frames...] + sinusoidal positions → post-LN transformer encoder with SELU →
drop the first 3 outputs → Linear(d→263). t is the continuous diffusion time (ARCHITECTURE.md) embedded
as sinusoid(1000·t) → Linear-SiLU-Linear; z ∈ R^64 → 5 Linear layers (LeakyReLU 0.2); the condition
(text embedding, or one-hot action; the zero vector = unconditional) → Linear. ``mask`` (B, L) marks real
frames (1) and padding (0): padded keys are never attended and padded outputs are zero.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn

from emdm.model.layers import EncoderLayer, MASK_BIAS, sinusoid

FEATURE_DIM = 263
Z_DIM = 64
MAX_FRAMES = 196
N_PREFIX = 3            # t, c, z tokens
TIME_SCALE = 1000.0     # continuous t ∈ (0, 1] → sinusoid positions in (0, 1000]


@dataclass(frozen=True)
class Preset:
    d: int
    layers: int
    heads: int
    ff: int
    dropout: float = 0.1

    def as_dict(self) -> dict:
        return asdict(self)


PRESETS: dict[str, Preset] = {
    "paper": Preset(d=1024, layers=12, heads=32, ff=1024, dropout=0.1),
    # chosen from ORT CPU measurements (see docs in the manifest entry / the issue note)
    "web": Preset(d=256, layers=4, heads=4, ff=1024, dropout=0.1),
    "tiny": Preset(d=64, layers=2, heads=4, ff=128, dropout=0.1),       # tests only
}


def get_preset(name_or_preset: str | Preset | dict) -> Preset:
    if isinstance(name_or_preset, Preset):
        return name_or_preset
    if isinstance(name_or_preset, dict):
        return Preset(**name_or_preset)
    if name_or_preset not in PRESETS:
        raise ValueError(f"unknown model preset {name_or_preset!r}; choose one of {sorted(PRESETS)}")
    return PRESETS[name_or_preset]


class Generator(nn.Module):
    def __init__(self, cond_dim: int, preset: str | Preset | dict = "web", feature_dim: int = FEATURE_DIM,
                 z_dim: int = Z_DIM, max_frames: int = MAX_FRAMES):
        super().__init__()
        p = get_preset(preset)
        self.preset, self.cond_dim, self.feature_dim, self.z_dim, self.max_frames = p, cond_dim, feature_dim, z_dim, max_frames
        d = p.d
        self.time_mlp = nn.Sequential(nn.Linear(d, d), nn.SiLU(), nn.Linear(d, d))
        z_layers: list[nn.Module] = [nn.Linear(z_dim, d), nn.LeakyReLU(0.2)]
        for _ in range(3):
            z_layers += [nn.Linear(d, d), nn.LeakyReLU(0.2)]
        z_layers.append(nn.Linear(d, d))
        self.z_mlp = nn.Sequential(*z_layers)                # 5 Linear layers
        self.cond_proj = nn.Linear(cond_dim, d)
        self.frame_in = nn.Linear(feature_dim, d)
        self.pos_drop = nn.Dropout(p.dropout)
        self.layers = nn.ModuleList(EncoderLayer(d, p.heads, p.ff, p.dropout) for _ in range(p.layers))
        self.frame_out = nn.Linear(d, feature_dim)
        self.register_buffer("pos_table", sinusoid(torch.arange(max_frames + N_PREFIX, dtype=torch.float32), d),
                             persistent=False)

    def config(self) -> dict:
        return {"cond_dim": self.cond_dim, "preset": self.preset.as_dict(), "feature_dim": self.feature_dim,
                "z_dim": self.z_dim, "max_frames": self.max_frames}

    def forward(self, x_t: torch.Tensor, z: torch.Tensor, cond: torch.Tensor, t: torch.Tensor,
                mask: torch.Tensor) -> torch.Tensor:
        """x_t (B, L, 263), z (B, 64), cond (B, C), t (B,) continuous, mask (B, L) → x̂_0 (B, L, 263)."""
        b, length, _ = x_t.shape
        d = self.preset.d
        t_tok = self.time_mlp(sinusoid(t * TIME_SCALE, d))
        prefix = torch.stack([t_tok, self.cond_proj(cond), self.z_mlp(z)], dim=1)    # (B, 3, d)
        h = torch.cat([prefix, self.frame_in(x_t)], dim=1)
        h = self.pos_drop(h + self.pos_table[: length + N_PREFIX])
        key_mask = torch.cat([torch.ones_like(mask[:, :1]).expand(-1, N_PREFIX), mask], dim=1)
        key_bias = (1.0 - key_mask) * MASK_BIAS
        for layer in self.layers:
            h = layer(h, key_bias)
        return self.frame_out(h[:, N_PREFIX:]) * mask.unsqueeze(-1)


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())
