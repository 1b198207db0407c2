"""Train / val / test split by take, stratified by action (no window of a test take in training)."""

from __future__ import annotations

import random
from collections import defaultdict


def split_takes(take_actions: dict[str, str], val: float = 0.05, test: float = 0.15, seed: int = 0) -> dict[str, str]:
    """{take: action} -> {take: 'train'|'val'|'test'}. Per action, takes are shuffled (seeded) and
    round(n*test) go to test (at least 1 when the action has >= 3 takes) and round(n*val) to val
    (at least 1 when it has >= 8 takes); the rest train."""
    by_action: dict[str, list[str]] = defaultdict(list)
    for take, action in take_actions.items():
        by_action[action].append(take)
    out: dict[str, str] = {}
    for action in sorted(by_action):
        takes = sorted(by_action[action])
        random.Random(f"{seed}/{action}").shuffle(takes)
        n = len(takes)
        n_test = max(1, round(n * test)) if n >= 3 else 0
        n_val = max(1, round(n * val)) if n >= 8 else 0
        for i, t in enumerate(takes):
            out[t] = "test" if i < n_test else ("val" if i < n_test + n_val else "train")
    return out
