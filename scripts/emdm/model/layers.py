"""Small building blocks shared by G and D, written so the ONNX export is plain ops.

SELU is written as scale·Elu(x, alpha) because ORT-web's WebGPU backend has an Elu kernel and no Selu.
Attention is written out (matmul, softmax) with an additive key-padding bias so the exported graph has
a dynamic length and no fused kernels that differ between runtimes.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

SELU_SCALE = 1.0507009873554805
SELU_ALPHA = 1.6732632423543772
MASK_BIAS = -1e9


class EluSELU(nn.Module):
    """SELU(x) = 1.0507009873554805 · Elu(x, 1.6732632423543772)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return SELU_SCALE * F.elu(x, alpha=SELU_ALPHA)


def sinusoid(positions: torch.Tensor, dim: int) -> torch.Tensor:
    """Transformer sinusoidal embedding of (any-shape) float positions → (..., dim)."""
    half = dim // 2
    freqs = torch.exp(torch.arange(half, dtype=torch.float32, device=positions.device) * (-math.log(10000.0) / half))
    ang = positions.float().unsqueeze(-1) * freqs
    emb = torch.stack([torch.sin(ang), torch.cos(ang)], dim=-1).flatten(-2)   # interleaved sin/cos
    if dim % 2:
        emb = F.pad(emb, (0, 1))
    return emb


class MaskedSelfAttention(nn.Module):
    def __init__(self, d: int, heads: int, dropout: float):
        super().__init__()
        if d % heads:
            raise ValueError(f"attention: model width {d} is not divisible by heads {heads}")
        self.heads = heads
        self.qkv = nn.Linear(d, 3 * d)
        self.out = nn.Linear(d, d)
        self.drop = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, key_bias: torch.Tensor) -> torch.Tensor:
        # x (B, S, d); key_bias (B, S) = 0 for real tokens, MASK_BIAS for padding
        b, s, d = x.shape
        dh = d // self.heads
        qkv = self.qkv(x).reshape(b, s, 3, self.heads, dh).permute(2, 0, 3, 1, 4)
        q, k, v = qkv[0], qkv[1], qkv[2]                                    # (B, h, S, dh)
        scores = torch.matmul(q, k.transpose(-1, -2)) * (1.0 / math.sqrt(dh))
        scores = scores + key_bias[:, None, None, :]
        attn = self.drop(torch.softmax(scores, dim=-1))
        y = torch.matmul(attn, v).transpose(1, 2).reshape(b, s, d)
        return self.out(y)


class EncoderLayer(nn.Module):
    """Post-LN transformer encoder layer (as nn.TransformerEncoderLayer, norm_first=False) with SELU FF."""

    def __init__(self, d: int, heads: int, ff: int, dropout: float):
        super().__init__()
        self.attn = MaskedSelfAttention(d, heads, dropout)
        self.norm1 = nn.LayerNorm(d)
        self.norm2 = nn.LayerNorm(d)
        self.ff = nn.Sequential(nn.Linear(d, ff), EluSELU(), nn.Dropout(dropout), nn.Linear(ff, d))
        self.drop1 = nn.Dropout(dropout)
        self.drop2 = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, key_bias: torch.Tensor) -> torch.Tensor:
        x = self.norm1(x + self.drop1(self.attn(x, key_bias)))
        return self.norm2(x + self.drop2(self.ff(x)))
