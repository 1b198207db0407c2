"""Sentence pooling: masked mean over tokens, then L2 normalisation (pure numpy)."""

from __future__ import annotations

import numpy as np


def mean_pool(hidden: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Average token vectors where ``mask`` is 1. hidden (N, T, D), mask (N, T) -> (N, D) float32."""
    if hidden.ndim != 3 or mask.shape != hidden.shape[:2]:
        raise ValueError(f"mean_pool: hidden {hidden.shape} and mask {mask.shape} do not match (N,T,D)/(N,T)")
    m = mask.astype(np.float32)[:, :, None]
    summed = (hidden.astype(np.float32) * m).sum(axis=1)
    count = np.clip(m.sum(axis=1), 1e-9, None)
    return (summed / count).astype(np.float32)


def l2_normalize(x: np.ndarray, eps: float = 1e-12) -> np.ndarray:
    """Rows scaled to unit length (a zero row stays zero)."""
    norm = np.linalg.norm(x, axis=-1, keepdims=True)
    return (x / np.maximum(norm, eps)).astype(np.float32)
