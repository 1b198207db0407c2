"""Distribution and retrieval metrics on evaluator embeddings (pure numpy; no models, no files).

The definitions follow the text-to-motion protocol of Guo et al. (CVPR 2022, "Generating diverse
and natural 3D human motions from text") and the action-to-motion protocol of ACTOR (Petrovich et
al., ICCV 2021):

* ``fid``: Fréchet distance between Gaussians fitted to two sets of embeddings.
* ``r_precision``: texts and motions are cut into pools of 32 pairs (1 true motion + 31
  distractors per text); the fraction of texts whose own motion is among the k nearest motions
  (Euclidean distance), for k = 1..top_k, averaged over pools.
* ``matching_distance`` (MM-Dist): mean Euclidean distance between a text and its own motion.
* ``diversity``: mean distance between two random draws (without replacement) of ``n_pairs``
  embeddings from the whole set.
* ``multimodality``: mean distance between pairs of motions generated for the *same* condition.
* ``multimodality_by_label``: the ACTOR variant, pairs drawn within each action label.
* ``accuracy``: action-recognition accuracy of a classifier on generated motions.
* ``mean_ci95``: mean and 95 % half-interval over repeats (1.96·std/√n, as in both protocols).

Every function validates its input and raises ``ValueError`` naming the argument and shape.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy import linalg

R_PRECISION_POOL = 32          # 1 true motion + 31 distractors
DIVERSITY_PAIRS_T2M = 300      # Guo et al.
DIVERSITY_PAIRS_A2M = 200      # ACTOR
MULTIMODALITY_PAIRS_T2M = 10   # Guo et al.: pairs among the generations of one text
MULTIMODALITY_PAIRS_A2M = 20   # ACTOR: pairs within one action label


def _as_2d(name: str, x) -> np.ndarray:
    a = np.asarray(x, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D array (samples, dim), got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise ValueError(f"{name}: non-finite value at index {tuple(int(i) for i in bad)}")
    return a


def _rng(rng) -> np.random.Generator:
    return rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)


# ----------------------------------------------------------------------------- FID

def gaussian_stats(acts) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance (unbiased, rows are samples) of a set of embeddings."""
    a = _as_2d("acts", acts)
    if a.shape[0] < 2:
        raise ValueError(f"acts: need at least 2 samples for a covariance, got {a.shape[0]}")
    return a.mean(axis=0), np.cov(a, rowvar=False)


def frechet_distance(mu1, sigma1, mu2, sigma2, eps: float = 1e-6) -> float:
    """‖μ1 − μ2‖² + Tr(Σ1 + Σ2 − 2(Σ1 Σ2)^½), robust to singular covariances."""
    mu1, mu2 = np.atleast_1d(np.asarray(mu1, np.float64)), np.atleast_1d(np.asarray(mu2, np.float64))
    s1, s2 = np.atleast_2d(np.asarray(sigma1, np.float64)), np.atleast_2d(np.asarray(sigma2, np.float64))
    if mu1.shape != mu2.shape or s1.shape != s2.shape or s1.shape != (mu1.shape[0],) * 2:
        raise ValueError(f"frechet_distance: shapes disagree: mu {mu1.shape} vs {mu2.shape}, "
                         f"sigma {s1.shape} vs {s2.shape}")
    diff = mu1 - mu2
    with warnings.catch_warnings():          # a singular product (e.g. a collapsed set) is expected
        warnings.simplefilter("ignore", linalg.LinAlgWarning)
        covmean = linalg.sqrtm(s1.dot(s2))
    if not np.isfinite(covmean).all():
        offset = np.eye(s1.shape[0]) * eps
        covmean = linalg.sqrtm((s1 + offset).dot(s2 + offset))
    if np.iscomplexobj(covmean):
        covmean = covmean.real
    value = float(diff.dot(diff) + np.trace(s1) + np.trace(s2) - 2.0 * np.trace(covmean))
    return max(value, 0.0)  # tiny negative values are round-off of an exact 0


def fid(acts_a, acts_b) -> float:
    """Fréchet distance between two sets of embeddings (rows are samples)."""
    a, b = _as_2d("acts_a", acts_a), _as_2d("acts_b", acts_b)
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"fid: embedding sizes differ: acts_a {a.shape} vs acts_b {b.shape}")
    return frechet_distance(*gaussian_stats(a), *gaussian_stats(b))


# ----------------------------------------------------------------------------- matching

def euclidean_distance_matrix(a, b) -> np.ndarray:
    """(N, M) matrix of Euclidean distances between the rows of ``a`` (N, D) and ``b`` (M, D)."""
    a, b = _as_2d("a", a), _as_2d("b", b)
    if a.shape[1] != b.shape[1]:
        raise ValueError(f"euclidean_distance_matrix: dims differ: {a.shape} vs {b.shape}")
    d2 = (a * a).sum(1)[:, None] - 2.0 * a @ b.T + (b * b).sum(1)[None, :]
    return np.sqrt(np.maximum(d2, 0.0))


def top_k_hits(dist: np.ndarray, top_k: int) -> np.ndarray:
    """(N, top_k) booleans: row i's own column (i) is among its k nearest, for k = 1..top_k.

    Ties are broken by column order (stable sort), as in Guo et al.'s evaluation code.
    """
    order = np.argsort(dist, axis=1, kind="stable")[:, :top_k]
    hit = order == np.arange(dist.shape[0])[:, None]
    return np.cumsum(hit, axis=1) > 0


def r_precision_and_matching(text_emb, motion_emb, *, top_k: int = 3,
                             pool: int = R_PRECISION_POOL, rng=None) -> tuple[np.ndarray, float]:
    """R-precision (top-1..top_k, each in [0, 1]) and MM-Dist for paired embeddings.

    Row i of ``text_emb`` describes row i of ``motion_emb``. The pairs are shuffled (when ``rng``
    is given) and cut into pools of ``pool``; a remainder smaller than a pool is dropped.
    """
    t, m = _as_2d("text_emb", text_emb), _as_2d("motion_emb", motion_emb)
    if t.shape != m.shape:
        raise ValueError(f"r_precision: text_emb {t.shape} and motion_emb {m.shape} must be paired")
    if not 1 <= top_k <= pool:
        raise ValueError(f"r_precision: top_k={top_k} must be in [1, pool={pool}]")
    n_pools = t.shape[0] // pool
    if n_pools == 0:
        raise ValueError(f"r_precision: need at least pool={pool} pairs, got {t.shape[0]}")
    idx = np.arange(t.shape[0]) if rng is None else _rng(rng).permutation(t.shape[0])
    hits = np.zeros(top_k)
    matching = 0.0
    for p in range(n_pools):
        sel = idx[p * pool:(p + 1) * pool]
        dist = euclidean_distance_matrix(t[sel], m[sel])
        hits += top_k_hits(dist, top_k).sum(axis=0)
        matching += np.trace(dist)
    n = n_pools * pool
    return hits / n, float(matching / n)


def r_precision(text_emb, motion_emb, *, top_k: int = 3, pool: int = R_PRECISION_POOL,
                rng=None) -> np.ndarray:
    return r_precision_and_matching(text_emb, motion_emb, top_k=top_k, pool=pool, rng=rng)[0]


def matching_distance(text_emb, motion_emb) -> float:
    """MM-Dist: mean distance between each text embedding and its own motion embedding."""
    t, m = _as_2d("text_emb", text_emb), _as_2d("motion_emb", motion_emb)
    if t.shape != m.shape:
        raise ValueError(f"matching_distance: text_emb {t.shape} vs motion_emb {m.shape}")
    return float(np.linalg.norm(t - m, axis=1).mean())


# ----------------------------------------------------------------------------- diversity

def diversity(acts, n_pairs: int = DIVERSITY_PAIRS_T2M, rng=None) -> float:
    """Mean distance between two independent random subsets of ``n_pairs`` embeddings."""
    a = _as_2d("acts", acts)
    if a.shape[0] < n_pairs:
        raise ValueError(f"diversity: need at least n_pairs={n_pairs} samples, got {a.shape[0]}")
    g = _rng(rng)
    i = g.choice(a.shape[0], n_pairs, replace=False)
    j = g.choice(a.shape[0], n_pairs, replace=False)
    return float(np.linalg.norm(a[i] - a[j], axis=1).mean())


def multimodality(acts, n_pairs: int = MULTIMODALITY_PAIRS_T2M, rng=None) -> float:
    """Guo et al.: ``acts`` is (conditions, generations per condition, dim); the mean distance
    between ``n_pairs`` random pairs of generations of the same condition."""
    a = np.asarray(acts, dtype=np.float64)
    if a.ndim != 3:
        raise ValueError(f"multimodality: expected (conditions, repeats, dim), got shape {a.shape}")
    if a.shape[1] < n_pairs:
        raise ValueError(f"multimodality: need at least n_pairs={n_pairs} generations per "
                         f"condition, got {a.shape[1]}")
    g = _rng(rng)
    i = g.choice(a.shape[1], n_pairs, replace=False)
    j = g.choice(a.shape[1], n_pairs, replace=False)
    return float(np.linalg.norm(a[:, i] - a[:, j], axis=2).mean())


def multimodality_by_label(acts, labels, n_pairs: int = MULTIMODALITY_PAIRS_A2M, rng=None) -> float:
    """ACTOR: for each label, ``n_pairs`` random pairs of samples carrying that label; the mean
    distance over all labels' pairs. Labels with fewer than 2 samples are an error."""
    a = _as_2d("acts", acts)
    lab = np.asarray(labels)
    if lab.shape != (a.shape[0],):
        raise ValueError(f"multimodality_by_label: labels shape {lab.shape} != ({a.shape[0]},)")
    g = _rng(rng)
    dists = []
    for label in np.unique(lab):
        rows = np.flatnonzero(lab == label)
        if rows.size < 2:
            raise ValueError(f"multimodality_by_label: label {label.item()!r} has {rows.size} sample(s); need ≥ 2")
        i = g.choice(rows, n_pairs, replace=True)
        # the partner of each pair is another sample of the same label
        j = np.array([g.choice(rows[rows != r]) for r in i])
        dists.append(np.linalg.norm(a[i] - a[j], axis=1))
    return float(np.concatenate(dists).mean())


# ----------------------------------------------------------------------------- classification

def accuracy(logits, labels) -> float:
    """Fraction of rows whose arg-max class equals the label."""
    lg = _as_2d("logits", logits)
    lab = np.asarray(labels)
    if lab.shape != (lg.shape[0],):
        raise ValueError(f"accuracy: labels shape {lab.shape} != ({lg.shape[0]},)")
    if lab.size and (lab.min() < 0 or lab.max() >= lg.shape[1]):
        raise ValueError(f"accuracy: labels must lie in [0, {lg.shape[1]}), got [{lab.min()}, {lab.max()}]")
    return float((lg.argmax(axis=1) == lab).mean())


def confusion_matrix(pred, labels, num_classes: int) -> np.ndarray:
    """(num_classes, num_classes) counts, rows = true label, columns = prediction."""
    pred, labels = np.asarray(pred, int), np.asarray(labels, int)
    if pred.shape != labels.shape:
        raise ValueError(f"confusion_matrix: pred {pred.shape} vs labels {labels.shape}")
    cm = np.zeros((num_classes, num_classes), dtype=np.int64)
    np.add.at(cm, (labels, pred), 1)
    return cm


# ----------------------------------------------------------------------------- repeats

def mean_ci95(values) -> tuple[float, float]:
    """Mean and 95 % half-interval 1.96·σ/√n over repeated measurements (σ: population std,
    as in Guo et al.'s and ACTOR's evaluation scripts). One value gives a half-interval of 0."""
    v = np.asarray(values, dtype=np.float64).ravel()
    if v.size == 0:
        raise ValueError("mean_ci95: no values")
    return float(v.mean()), float(1.96 * v.std() / np.sqrt(v.size))
