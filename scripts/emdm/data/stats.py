"""Mean / Std of the 263-d features over the training windows, HumanML3D style.

Within each feature group the std is replaced by the group's mean std (so normalisation keeps the
geometry within a group), and the foot contacts' std is divided by ``FEET_BIAS`` (5, as HumanML3D),
which up-weights them in the normalised space. Stds below ``EPS`` are set to 1 (constant channels).
"""

from __future__ import annotations

import numpy as np

GROUPS = [slice(0, 1), slice(1, 3), slice(3, 4), slice(4, 67), slice(67, 193), slice(193, 259), slice(259, 263)]
FEET_BIAS = 5.0
EPS = 1e-8


def mean_std(total: np.ndarray, total_sq: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    if count <= 1:
        raise ValueError("mean_std: need at least 2 training frames")
    mean = total / count
    var = np.maximum(total_sq / count - mean ** 2, 0.0) * count / (count - 1)
    raw = np.sqrt(var)
    std = raw.copy()
    for g in GROUPS:
        std[g] = raw[g].mean()
    std[259:263] /= FEET_BIAS
    std[std < EPS] = 1.0
    return mean.astype(np.float32), std.astype(np.float32)


def mean_std_of(arrays: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    x = np.concatenate([np.asarray(a, dtype=np.float64) for a in arrays], axis=0)
    return mean_std(x.sum(0), (x ** 2).sum(0), x.shape[0])
