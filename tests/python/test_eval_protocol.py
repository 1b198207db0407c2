"""The protocols rank sources the way a user expects: real data beats mismatched or collapsed
generations, and each metric reacts to the failure it is meant to catch."""

import numpy as np
import pytest
import torch

from emdm.eval import evaluators as E
from emdm.eval.data import EvalSplit
from emdm.eval.protocol import RealSource, evaluate_action, evaluate_text

torch.set_num_threads(1)
MEAN, STD = np.zeros(263, np.float32), np.ones(263, np.float32)
CFG = E.TrainConfig(epochs=10, batch_size=32, lr=3e-3, hidden=32, emb_dim=32, dropout=0.0)
PROJ = np.random.default_rng(99).normal(size=(4, 16))


def _walk_motion(params, frames, rng):
    """Raw features of a plausible-ish clip: pelvis at 0.9 m, joints around it, content in 67..75."""
    t = np.arange(frames)[:, None]
    m = rng.normal(scale=0.02, size=(frames, 263)).astype(np.float32)
    m[:, 3] = 0.9
    m[:, 4:67] += np.tile([0.1, -0.5, 0.0], 21)          # joints 0.4 m up, around the pelvis
    m[:, 67:71] += params[None, :] * np.sin(2 * np.pi * t / 20.0)
    m[:, 71:75] += params[None, :] * np.cos(2 * np.pi * t / 20.0)
    return m


def _split(n, seed, labels=None):
    rng = np.random.default_rng(seed)
    params = rng.uniform(-1, 1, size=(n, 4)) if labels is None else np.eye(4)[labels] + rng.normal(scale=0.1, size=(n, 4))
    motions = [_walk_motion(p, int(rng.integers(40, 80)), rng) for p in params]
    text = params @ PROJ
    text /= np.linalg.norm(text, axis=1, keepdims=True)
    split = EvalSplit(root=None, split="test", names=[str(i) for i in range(n)], motions=motions,
                      captions=[[f"caption {i}"] for i in range(n)],
                      actions=np.asarray(labels if labels is not None else -np.ones(n), np.int64),
                      action_labels=["a", "b", "c", "d"], mean=MEAN, std=STD)
    return split, [t[None].astype(np.float32) for t in text]


class Shuffled:
    """Motions of the right kind for the wrong captions."""
    name, kind, info = "shuffled", "model", {}

    def __init__(self, split):
        self.split = split

    def generate(self, cond, seed):
        rng = np.random.default_rng(seed)
        return [self.split.motions[i] for i in rng.permutation(cond.index)]


class Collapsed:
    """The same motion whatever the condition (mode collapse)."""
    name, kind, info = "collapsed", "model", {}

    def __init__(self, split):
        self.split = split

    def generate(self, cond, seed):
        return [self.split.motions[0] for _ in cond.lengths]


@pytest.fixture(scope="module")
def matcher():
    train, cap = _split(384, 0)
    return E.train_matcher(train.motions, cap, MEAN, STD, CFG)


def test_text_protocol_ranks_real_above_mismatched_and_collapsed(matcher):
    test, cap = _split(128, 1)
    kw = dict(repeats=2, mm_texts=8, mm_repeats=10, plaus_n=20, log=lambda s: None)
    real = evaluate_text(matcher, test, cap, RealSource(test), **kw)
    shuf = evaluate_text(matcher, test, cap, Shuffled(test), **kw)
    coll = evaluate_text(matcher, test, cap, Collapsed(test), **kw)
    mean = lambda r, k: float(np.mean(r["metrics"][k]))  # noqa: E731
    assert mean(real, "top1") > 0.8 and mean(shuf, "top3") < 0.3          # alignment
    assert mean(shuf, "mm_dist") > mean(real, "mm_dist")
    # shuffled motions are real motions: their FID stays near the real-vs-real floor
    assert mean(shuf, "fid") < 5 * max(mean(real, "fid"), 1e-3) + 0.05
    assert mean(coll, "fid") > 10 * mean(shuf, "fid")                       # collapse is caught by FID …
    assert mean(coll, "diversity") == pytest.approx(0.0, abs=1e-6)         # … and by diversity
    assert mean(coll, "multimodality") == pytest.approx(0.0, abs=1e-6)
    assert "multimodality" not in real["metrics"]
    assert len(real["metrics"]["top1"]) == 2 and real["n"] == 128
    assert len(real["plausibility"]["penetration_mm"]) == 20


def test_action_protocol_accuracy_and_collapse():
    rng = np.random.default_rng(0)
    train, _ = _split(256, 2, labels=rng.integers(0, 4, 256))
    clf = E.train_classifier(train.motions, train.actions, 4, MEAN, STD, E.TrainConfig(**{**CFG.__dict__, "epochs": 10}))
    test, _ = _split(96, 3, labels=rng.integers(0, 4, 96))
    real = evaluate_action(clf, test, RealSource(test), repeats=2, plaus_n=0, log=lambda s: None)
    coll = evaluate_action(clf, test, Collapsed(test), repeats=2, plaus_n=0, log=lambda s: None)
    assert np.mean(real["metrics"]["accuracy"]) > 0.9
    assert np.mean(coll["metrics"]["accuracy"]) < 0.5
    assert np.mean(coll["metrics"]["multimodality"]) == pytest.approx(0.0, abs=1e-6)
    assert np.mean(coll["metrics"]["diversity"]) == pytest.approx(0.0, abs=1e-6)
    assert np.mean(coll["metrics"]["fid"]) > 10 * np.mean(real["metrics"]["fid"])


def test_text_protocol_rejects_a_source_that_returns_the_wrong_shape(matcher):
    test, cap = _split(40, 4)

    class Bad:
        name, kind, info = "bad", "model", {}

        def generate(self, cond, seed):
            return [np.zeros((n, 262), np.float32) for n in cond.lengths]

    with pytest.raises(ValueError, match=r"bad: motion 0 has shape \(\d+, 262\)"):
        evaluate_text(matcher, test, cap, Bad(), repeats=1, mm_texts=0, plaus_n=0, log=lambda s: None)
