"""The evaluation protocols: one motion source (real data or a generator) against the test split,
measured with a trained evaluator, repeated with fresh randomness. Returns plain dicts (JSON-ready);
``emdm.eval.evaluate`` is the CLI that writes them and ``emdm.eval.report`` turns them into tables.

Text-to-motion (Guo et al.), per repeat r (seed + r):
  one random caption per test clip → the source makes one motion per clip with the clip's length →
  R-precision top-1/2/3 (pools of 32, shuffled), MM-Dist, FID against the real test clips' embeddings,
  Diversity (300 pairs, fewer when the split is smaller); MultiModality: ``mm_texts`` captions ×
  ``mm_repeats`` generations each, 10 pairs per caption.
Action-to-motion (ACTOR): one motion per test clip with the clip's label and length → accuracy of the
  classifier, FID against the real test clips, Diversity (200 pairs), Multimodality (20 pairs per label).
Real-vs-real row: the real test clips themselves, with FID between two random halves of the test set
  (a noise floor of the FID estimate; with identical sets it would be exactly 0) and no MultiModality.
Plausibility: ``plaus_n`` motions (default 200) of the first repeat, for a seeded random choice of test
  clips that is the same for every source (so real and generated rows measure the same conditions);
  joints from ``recover_joints``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Protocol, Sequence

import numpy as np

from emdm.eval import evaluators as E
from emdm.eval import metrics as M
from emdm.eval.data import EvalSplit
from emdm.eval.plausibility import batch_plausibility
from emdm.motion.features import recover_joints

FPS = 20


@dataclass
class Conditions:
    """What a source may condition on, one entry per motion to make."""
    lengths: np.ndarray                      # (B,) frames of raw features
    texts: list[str] | None = None
    text_emb: np.ndarray | None = None       # (B, 384) sentence embeddings of ``texts``
    labels: np.ndarray | None = None         # (B,) action ids
    index: np.ndarray | None = None          # (B,) the test clips these come from (for the real source)

    def take(self, idx: np.ndarray) -> "Conditions":
        pick = lambda a: None if a is None else (a[idx] if isinstance(a, np.ndarray) else [a[i] for i in idx])  # noqa: E731
        return Conditions(self.lengths[idx], pick(self.texts), pick(self.text_emb), pick(self.labels), pick(self.index))


class Source(Protocol):
    name: str
    kind: str                                # "real" | "model"
    info: dict

    def generate(self, cond: Conditions, seed: int) -> list[np.ndarray]: ...


@dataclass
class RealSource:
    """The test clips themselves (the real-vs-real row)."""
    split: EvalSplit
    name: str = "Real motion"
    kind: str = "real"
    info: dict = field(default_factory=dict)

    def generate(self, cond: Conditions, seed: int) -> list[np.ndarray]:
        if cond.index is None:
            raise ValueError("RealSource: conditions carry no test-clip index")
        return [self.split.motions[i] for i in cond.index]


def _check_generated(motions: Sequence[np.ndarray], cond: Conditions, who: str) -> list[np.ndarray]:
    if len(motions) != len(cond.lengths):
        raise ValueError(f"{who}: made {len(motions)} motions for {len(cond.lengths)} conditions")
    out = []
    for i, m in enumerate(motions):
        m = np.asarray(m, np.float32)
        if m.ndim != 2 or m.shape[1] != E.FEATURE_DIM:
            raise ValueError(f"{who}: motion {i} has shape {m.shape}, expected (frames, {E.FEATURE_DIM})")
        if not np.all(np.isfinite(m)):
            raise ValueError(f"{who}: motion {i} contains NaN/inf")
        out.append(m)
    return out


def joints_of(motions: Sequence[np.ndarray]) -> list[np.ndarray]:
    return [recover_joints(m) for m in motions]


def plausibility_rows(motions: Sequence[np.ndarray]) -> dict[str, list[float]]:
    return {k: v.tolist() for k, v in batch_plausibility(joints_of(motions), FPS).items()}


def plausibility_subset(n: int, plaus_n: int, seed: int) -> np.ndarray:
    """The clips whose motions are checked for plausibility: a seeded random subset, in order."""
    if plaus_n >= n:
        return np.arange(n)
    return np.sort(np.random.default_rng([seed, 7]).choice(n, plaus_n, replace=False))


def sample_lengths(test: EvalSplit, n: int, rng: np.random.Generator, action: int | None = None) -> np.ndarray:
    """``n`` motion lengths drawn like the test split: with replacement from the lengths of its clips of
    ``action`` (all its clips when ``action`` is None or has no clip), so that a generated bow is as long
    as a real one. The protocols above use each clip's own length; this is that rule for conditions that
    are not test clips (the coverage benchmark's prompts)."""
    lengths = test.lengths
    if action is not None and np.any(test.actions == action):
        lengths = lengths[test.actions == action]
    if lengths.size == 0:
        raise ValueError(f"{test.root}/{test.split}.txt: no clips to draw lengths from")
    return rng.choice(lengths, n, replace=True).astype(np.int64)


def _fid_real_halves(real_emb: np.ndarray, rng: np.random.Generator) -> float:
    perm = rng.permutation(len(real_emb))
    h = len(perm) // 2
    return M.fid(real_emb[perm[:h]], real_emb[perm[h:2 * h]])


def evaluate_text(matcher: E.MatchingModel, test: EvalSplit, caption_emb: Sequence[np.ndarray], source: Source, *,
                  repeats: int = 20, seed: int = 0, mm_texts: int = 100, mm_repeats: int = 30,
                  plaus_n: int = 200, log: Callable[[str], None] = print) -> dict:
    n = len(test)
    if n < M.R_PRECISION_POOL:
        raise ValueError(f"{test.root}/{test.split}.txt: {n} clips; R-precision needs at least {M.R_PRECISION_POOL}")
    if len(caption_emb) != n:
        raise ValueError(f"evaluate_text: {len(caption_emb)} caption sets for {n} test clips")
    real_emb = E.embed_motions(matcher, test.motions)
    div_pairs = min(M.DIVERSITY_PAIRS_T2M, n)
    out: dict[str, list[float]] = {k: [] for k in ("top1", "top2", "top3", "mm_dist", "fid", "diversity")}
    if source.kind != "real":
        out["multimodality"] = []
    plaus: dict[str, list[float]] = {}
    gen_seconds = 0.0
    for r in range(repeats):
        rng = np.random.default_rng([seed, r])
        pick = [int(rng.integers(len(caption_emb[i]))) for i in range(n)]
        cond = Conditions(lengths=test.lengths, texts=[test.captions[i][k] for i, k in enumerate(pick)],
                          text_emb=np.stack([caption_emb[i][k] for i, k in enumerate(pick)]),
                          index=np.arange(n))
        t0 = time.perf_counter()
        motions = _check_generated(source.generate(cond, seed * 1000 + r), cond, source.name)
        gen_seconds += time.perf_counter() - t0
        m_emb = E.embed_motions(matcher, motions)
        t_emb = E.embed_texts(matcher, cond.text_emb)
        rp, mm = M.r_precision_and_matching(t_emb, m_emb, rng=rng)
        out["top1"].append(rp[0]); out["top2"].append(rp[1]); out["top3"].append(rp[2])  # noqa: E702
        out["mm_dist"].append(mm)
        out["fid"].append(_fid_real_halves(real_emb, rng) if source.kind == "real" else M.fid(m_emb, real_emb))
        out["diversity"].append(M.diversity(m_emb, div_pairs, rng=rng))
        if source.kind != "real" and mm_texts > 0:
            sel = rng.choice(n, min(mm_texts, n), replace=False)
            rep = np.repeat(sel, mm_repeats)
            mm_cond = cond.take(rep)
            mm_motions = _check_generated(source.generate(mm_cond, seed * 1000 + r + 500), mm_cond, source.name)
            mm_emb = E.embed_motions(matcher, mm_motions).reshape(len(sel), mm_repeats, -1)
            out["multimodality"].append(M.multimodality(mm_emb, min(M.MULTIMODALITY_PAIRS_T2M, mm_repeats), rng=rng))
        if r == 0 and plaus_n > 0:
            plaus = plausibility_rows([motions[i] for i in plausibility_subset(n, plaus_n, seed)])
        log(f"[{source.name}] repeat {r + 1}/{repeats}: " +
            " ".join(f"{k}={v[-1]:.4f}" for k, v in out.items() if v))
    return {"task": "text", "n": n, "repeats": repeats, "seed": seed, "metrics": out, "plausibility": plaus,
            "diversity_pairs": div_pairs, "mm_texts": min(mm_texts, n) if source.kind != "real" else 0,
            "mm_repeats": mm_repeats if source.kind != "real" else 0, "generate_seconds": gen_seconds}


def evaluate_action(classifier: E.ActionClassifier, test: EvalSplit, source: Source, *, repeats: int = 20,
                    seed: int = 0, plaus_n: int = 200, log: Callable[[str], None] = print) -> dict:
    keep = np.flatnonzero(test.actions >= 0)
    if keep.size < 2:
        raise ValueError(f"{test.root}/{test.split}.txt: {keep.size} clips with an action label; need more")
    motions_real = [test.motions[i] for i in keep]
    labels = test.actions[keep]
    _, real_feats = E.classify(classifier, motions_real)
    div_pairs = min(M.DIVERSITY_PAIRS_A2M, keep.size)
    counts = np.bincount(labels)
    mm_rows = counts[labels] >= 2            # multimodality needs two clips of a label
    out: dict[str, list[float]] = {k: [] for k in ("accuracy", "fid", "diversity", "multimodality")}
    plaus: dict[str, list[float]] = {}
    gen_seconds = 0.0
    for r in range(repeats):
        rng = np.random.default_rng([seed, r])
        cond = Conditions(lengths=test.lengths[keep], labels=labels, index=keep)
        t0 = time.perf_counter()
        motions = _check_generated(source.generate(cond, seed * 1000 + r), cond, source.name)
        gen_seconds += time.perf_counter() - t0
        logits, feats = E.classify(classifier, motions)
        out["accuracy"].append(M.accuracy(logits, labels))
        out["fid"].append(_fid_real_halves(real_feats, rng) if source.kind == "real" else M.fid(feats, real_feats))
        out["diversity"].append(M.diversity(feats, div_pairs, rng=rng))
        out["multimodality"].append(M.multimodality_by_label(feats[mm_rows], labels[mm_rows],
                                                             M.MULTIMODALITY_PAIRS_A2M, rng=rng))
        if r == 0 and plaus_n > 0:
            plaus = plausibility_rows([motions[i] for i in plausibility_subset(len(motions), plaus_n, seed)])
        log(f"[{source.name}] repeat {r + 1}/{repeats}: " + " ".join(f"{k}={v[-1]:.4f}" for k, v in out.items()))
    return {"task": "action", "n": int(keep.size), "repeats": repeats, "seed": seed, "metrics": out,
            "plausibility": plaus, "diversity_pairs": div_pairs, "generate_seconds": gen_seconds}
