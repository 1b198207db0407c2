"""Train / val / test split by take, stratified by action (no window of a test take in training)."""

from __future__ import annotations

import random
from collections import defaultdict

# At most this share of an action's windows is held out of training (val + test), where its takes' window counts are
# known: CMU's one long boxing take (12 of punch's 16 windows) went to test, and the model learnt punch from two short
# takes (4 windows): a held guard that never throws a fist (docs/MODELS.md "Known failures").
HELD_MAX = 1 / 3


def split_takes(take_actions: dict[str, str], val: float = 0.05, test: float = 0.15, seed: int = 0,
                windows: dict[str, int] | None = None, held_max: float = HELD_MAX) -> dict[str, str]:
    """{take: action} -> {take: 'train'|'val'|'test'}. Per action, takes are shuffled (seeded) and
    round(n*test) go to test (at least 1 when the action has >= 3 takes) and round(n*val) to val
    (at least 1 when it has >= 8 takes); the rest train. With ``windows`` ({take: windows it made}), a take that
    made no window, or whose windows would bring the action's held-out windows over ``held_max`` of its windows,
    stays in training and the next take in the shuffled order is held out instead (fewer held-out takes where none
    fits)."""
    by_action: dict[str, list[str]] = defaultdict(list)
    for take, action in take_actions.items():
        by_action[action].append(take)
    out: dict[str, str] = {}
    for action in sorted(by_action):
        takes = sorted(by_action[action])
        random.Random(f"{seed}/{action}").shuffle(takes)
        n = len(takes)
        want = {"test": max(1, round(n * test)) if n >= 3 else 0, "val": max(1, round(n * val)) if n >= 8 else 0}
        total = sum(windows.get(t, 0) for t in takes) if windows is not None else 0
        held = 0
        for t in takes:
            split = "test" if want["test"] > 0 else "val" if want["val"] > 0 else "train"
            w = windows.get(t, 0) if windows is not None else 0
            # a take that made no window would hold a slot out of nothing
            if windows is not None and (w == 0 or held + w > held_max * total):
                split = "train"
            out[t] = split
            if split != "train":
                want[split] -= 1
                held += w
    return out
