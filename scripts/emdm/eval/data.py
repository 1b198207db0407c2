"""What the evaluation reads from a dataset: raw (de-normalised) feature clips of a split with their
captions, caption embeddings and action ids. A thin shell over ``emdm.data.dataset`` (the one reader
of the HumanML3D layout) and ``emdm.text`` (the one sentence encoder); nothing is parsed twice."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from emdm.data import dataset as ds
from emdm.paths import RUNS_DIR

TEXT_ENCODER = "all-MiniLM-L6-v2"
CACHE_DIR = RUNS_DIR / "eval" / "cache"


@dataclass
class EvalSplit:
    root: Path
    split: str
    names: list[str]
    motions: list[np.ndarray]          # raw 263-d features (F, 263) float32, as recover_joints reads them
    captions: list[list[str]]
    actions: np.ndarray                # (N,) int64, -1 = no action label
    action_labels: list[str]
    mean: np.ndarray
    std: np.ndarray

    def __len__(self) -> int:
        return len(self.motions)

    @property
    def lengths(self) -> np.ndarray:
        return np.array([len(m) for m in self.motions], dtype=np.int64)


def load_split(root: Path | str, split: str, *, max_items: int | None = None, subset_seed: int = 0,
               require_action: bool = False) -> EvalSplit:
    """A split of the dataset with raw features (the dataset reader normalises; undone here).

    ``max_items`` keeps a seeded random subset (in split order), not the first clips: split files
    are sorted by id, so their head is one source and one action."""
    ms = ds.load_split(root, split, require_action=require_action)
    keep = np.arange(len(ms))
    if max_items is not None and max_items < len(ms):
        keep = np.sort(np.random.default_rng(subset_seed).choice(len(ms), max_items, replace=False))
    raw = [(ms.motions[i] * ms.std + ms.mean).astype(np.float32) for i in keep]
    return EvalSplit(root=Path(root), split=split, names=[ms.names[i] for i in keep], motions=raw,
                     captions=[ms.captions[i] for i in keep], actions=ms.actions[keep],
                     action_labels=list(ms.action_labels), mean=ms.mean, std=ms.std)


def load_mean_std(root: Path | str) -> tuple[np.ndarray, np.ndarray]:
    return ds.load_mean_std(root)


def caption_embeddings(split: EvalSplit, encoder_id: str = TEXT_ENCODER,
                       cache_dir: Path | str | None = None) -> list[np.ndarray]:
    """Per clip, an (n_captions, dim) array of its caption embeddings (cached on disk by content in
    ``cache_dir``, default ``$EMDM_EVAL_CACHE`` or runs/eval/cache)."""
    cache_dir = cache_dir or os.environ.get("EMDM_EVAL_CACHE") or CACHE_DIR
    uniq: dict[str, int] = {}
    per_clip = [np.array([uniq.setdefault(c, len(uniq)) for c in caps], dtype=np.int64) for caps in split.captions]
    if "" in uniq:
        bad = split.names[next(i for i, caps in enumerate(split.captions) if "" in caps)]
        raise ValueError(f"{split.root}/texts/{bad.split('#')[0]}.txt: clip {bad} of split {split.split} has no "
                         f"caption; the text–motion evaluator needs captions")
    emb = ds.cached_text_embeddings(list(uniq), encoder_id, cache_dir)
    return [emb[idx] for idx in per_clip]


def action_labels(split: EvalSplit) -> tuple[np.ndarray, list[str]]:
    """(action id per clip, -1 = none) and the vocabulary; an error when the dataset has no actions."""
    if not split.action_labels:
        raise ValueError(f"{split.root}: no actions.json/metadata.csv, so no action labels to classify")
    return split.actions, split.action_labels
