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


def test_a_take_holding_most_of_an_actions_windows_stays_in_training():
    """Punch had three takes: two short (2 windows each) and one long (12): holding the long one out left training 4 of
    16 windows. With window counts, at most a third of an action's windows are held out, for every seed."""
    takes = {f"src/{a}_{i}": a for a in ("walk", "run") for i in range(20)}
    takes.update({"bandai/punch_1": "punch", "bandai/punch_2": "punch", "cmu/02_05": "punch"})
    windows = {t: 2 for t in takes} | {"cmu/02_05": 12}
    for seed in range(8):
        s = split_takes(takes, seed=seed, windows=windows)
        assert s["cmu/02_05"] == "train", seed
        held = [t for t in ("bandai/punch_1", "bandai/punch_2") if s[t] != "train"]
        assert len(held) == 1 and s[held[0]] == "test", (seed, s)       # one test take still, a short one
        # equal takes: the same split as without window counts
        assert {t: v for t, v in s.items() if takes[t] != "punch"} == \
            {t: v for t, v in split_takes(takes, seed=seed).items() if takes[t] != "punch"}
    three = {"a/x": "jump", "a/y": "jump", "a/z": "jump"}
    assert sorted(split_takes(three, windows={"a/x": 10, "a/y": 10, "a/z": 10}).values()) == ["test", "train", "train"], \
        "three equal takes: one is a third of the windows, the most held out"
    assert set(split_takes(three, windows={"a/x": 10, "a/y": 10, "a/z": 11}).values()) >= {"test"}


def test_a_take_that_made_no_window_never_holds_a_slot():
    """HDM05's one-hop takes shorter than the minimum made no window; three of them held hop's test slots (and every
    one of rotate-arms'), leaving those actions without test clips."""
    takes = {f"hdm05/hop_{i:03d}": "hop" for i in range(20)}
    windows = {t: (0 if i % 3 == 0 else 1) for i, t in enumerate(sorted(takes))}
    for seed in range(8):
        s = split_takes(takes, seed=seed, windows=windows)
        held = [t for t, v in s.items() if v != "train"]
        assert held and all(windows[t] == 1 for t in held), (seed, held)
        assert sorted(v for v in s.values() if v != "train") == ["test", "test", "test", "val"]
