"""The judge of meaning: the action classifier, or several trained alike with other seeds (an ensemble).

A classifier retrained with another seed moves single actions' recognition rates by up to 0.35 and a coverage count by
1–2 actions (docs/MODELS.md "Between slices (2026-11-28)"): actions near the 0.5 line flip with the judge's seed. A
``Judge`` of several classifier files names each motion's action by the mean of their softmax probabilities, so a
verdict no longer hangs on one training run's seed. With one file it names exactly what that classifier's argmax
names (the results of a single-file judge are unchanged).

The default judge (``default_paths``) is three classifiers on the same data and config, seeds 0, 1 and 2::

    python -m emdm.eval.evaluators classifier --seed 0 --out runs/eval/classifier.pt
    python -m emdm.eval.evaluators classifier --seed 1 --out runs/eval/classifier-seed1.pt
    python -m emdm.eval.evaluators classifier --seed 2 --out runs/eval/classifier-seed2.pt

Coverage, realism, editing, seams and live meaning take ``--classifier FILE [FILE ...]``; a result records the judge
(``info``: each file's sha256 and, for several, one digest of them all), and coverage keeps earlier step counts only
when the same judge scored them. The paper's action metrics (``emdm.eval.evaluate``: FID, diversity and multimodality on
one classifier's penultimate features) keep one classifier file: features of different networks do not average.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Sequence

import numpy as np

from emdm.eval import evaluators as E
from emdm.eval.results import evaluator_info
from emdm.paths import RUNS_DIR, display_path

SEEDS = (0, 1, 2)


def file_name(seed: int) -> str:
    """The default judge's file of a seed: ``classifier.pt`` for seed 0 (the file every earlier result names)."""
    return "classifier.pt" if seed == 0 else f"classifier-seed{seed}.pt"


def default_paths(folder: Path = RUNS_DIR / "eval") -> list[Path]:
    return [Path(folder) / file_name(s) for s in SEEDS]


def _train_hint(path: Path) -> str:
    stem = path.stem
    seed = stem[len("classifier-seed"):] if stem.startswith("classifier-seed") else "0"
    seed = seed if seed.isdigit() else "0"
    return f"python -m emdm.eval.evaluators classifier --seed {seed} --out {display_path(path)}"


class JudgeError(ValueError):
    """A classifier file is missing, unreadable, or does not fit the others (the message names the file)."""


def add_argument(ap) -> None:
    """``--classifier FILE [FILE ...]`` (default: the three seeds' files) on an argparse parser."""
    ap.add_argument("--classifier", type=Path, nargs="+", default=default_paths(),
                    help="the action classifier file(s) that judge meaning; several: their mean probability names "
                         "the action (default: runs/eval/classifier.pt, classifier-seed1.pt, classifier-seed2.pt)")


class Judge:
    """Classifiers of one label vocabulary; ``probs`` is the mean of their softmax probabilities, ``predict`` its
    argmax. ``paths``: one file or several; each must exist, hold a classifier, and share the first's labels."""

    def __init__(self, paths: Path | str | Sequence[Path | str]):
        paths = [paths] if isinstance(paths, (str, Path)) else list(paths)
        if not paths:
            raise JudgeError("no classifier file given")
        self.paths = [Path(p) for p in paths]
        if len(set(self.paths)) != len(self.paths):
            raise JudgeError("a classifier file is given twice: " + ", ".join(str(p) for p in self.paths))
        missing = [p for p in self.paths if not p.is_file()]
        if missing:
            raise JudgeError("classifier file(s) not found: " + "; ".join(
                f"{display_path(p)} (train it: `{_train_hint(p)}`)" for p in missing))
        try:
            self.members = [E.load(p, "classifier") for p in self.paths]
        except ValueError as e:                 # unreadable or not a classifier: one line naming the file
            raise JudgeError(str(e)) from None
        first = self.members[0]
        for p, m in zip(self.paths[1:], self.members[1:]):
            if m.config["num_classes"] != first.config["num_classes"] or m.meta.get("labels") != first.meta.get("labels"):
                raise JudgeError(f"{display_path(p)}: trained on other labels than {display_path(self.paths[0])} "
                                 f"({m.config['num_classes']} against {first.config['num_classes']} classes); an "
                                 f"ensemble's classifiers must share one dataset's labels")

    @property
    def labels(self) -> list | None:
        return self.members[0].meta.get("labels")

    @property
    def num_classes(self) -> int:
        return int(self.members[0].config["num_classes"])

    def probs(self, motions) -> np.ndarray:
        """(N, classes): the members' softmax probabilities, averaged."""
        total = None
        for m in self.members:
            logits = E.classify(m, motions)[0]
            p = np.exp(logits - logits.max(axis=1, keepdims=True))
            p /= p.sum(axis=1, keepdims=True)
            total = p if total is None else total + p
        return total / len(self.members)

    def predict(self, motions) -> np.ndarray:
        """The label id each motion is named (argmax of ``probs``; with one member, its logits' argmax)."""
        return np.argmax(self.probs(motions), axis=1)

    def info(self) -> dict:
        """What a result records of its judge: one file's ``evaluator_info``; for several, ``members`` (each one's),
        ``sha256`` (16 hex digits over the members' own, in any order: the mean does not depend on it) and a summary
        naming the ensemble."""
        infos = [evaluator_info(m, p) for m, p in zip(self.members, self.paths)]
        if len(infos) == 1:
            return infos[0]
        digest = hashlib.sha256(" ".join(sorted(str(i["sha256"]) for i in infos)).encode()).hexdigest()[:16]
        seeds = [(i.get("config") or {}).get("seed", "?") for i in infos]
        first = self.members[0]
        val = [(i.get("final") or {}).get("val_accuracy") for i in infos]
        trained = ", ".join(f"{v:.3f}" for v in val if v is not None)
        return {"path": [i["path"] for i in infos], "sha256": digest, "members": infos,
                "summary": f"mean probability of {len(infos)} classifiers (seeds {', '.join(map(str, seeds))}): "
                           f"{type(first).__name__} (hidden {first.config['hidden']}) trained on "
                           f"{first.meta.get('train_items', '?')} train clips"
                           + (f"; val accuracy {trained}" if trained else "")}
