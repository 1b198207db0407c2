"""Split by take, stratified by action: no take in two splits, every common action is tested."""

from collections import Counter

from emdm.data.split import split_takes


def test_split_is_by_take_stratified_and_deterministic():
    takes = {f"src/{a}_{i}": a for a in ("walk", "run", "wave") for i in range(20)}
    takes.update({"src/rare_0": "rare", "src/rare_1": "rare"})
    s = split_takes(takes, seed=3)
    assert s == split_takes(takes, seed=3)
    assert set(s) == set(takes) and set(s.values()) == {"train", "val", "test"}
    for a in ("walk", "run", "wave"):
        c = Counter(v for t, v in s.items() if takes[t] == a)
        assert c == {"train": 16, "test": 3, "val": 1}
    assert {s["src/rare_0"], s["src/rare_1"]} == {"train"}, "actions with < 3 takes stay in training"
    assert split_takes(takes, seed=4) != s
