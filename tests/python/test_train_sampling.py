"""Balanced sampling (train --balance-alpha): clips drawn by action with P(action) ∝ n_action^α, exactly resumable
and sharded over DDP ranks like the plain epoch; the effective distribution is printed and kept in meta."""

import csv

import numpy as np
import pytest
import torch

from emdm.data.dataset import BucketBatcher, action_shares, balanced_weights, crop_plan
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

COUNTS = (60, 30, 9, 1)                  # a 60:1 imbalance, like walk vs jump


def groups_and_lengths():
    groups = np.concatenate([np.full(n, a) for a, n in enumerate(COUNTS)])
    lengths = np.random.default_rng(1).integers(40, 197, len(groups))
    return groups, lengths


@pytest.mark.parametrize("alpha", [0.0, 0.5, 1.0])
def test_action_frequencies_follow_n_to_the_alpha(alpha):
    groups, lengths = groups_and_lengths()
    b = BucketBatcher(lengths, batch=5, seed=3, bucket=4, groups=groups, alpha=alpha)
    drawn = np.concatenate([b.next() for _ in range(6000)])            # 30,000 clips, 300 epochs
    freq = np.bincount(groups[drawn], minlength=len(COUNTS)) / len(drawn)
    want = np.array(COUNTS, float) ** alpha
    want /= want.sum()
    assert np.allclose(freq, want, atol=0.012), (alpha, freq.round(4), want.round(4))
    if alpha == 1.0:                       # the plain epoch: every clip exactly once per epoch, as before
        assert all(sorted(np.concatenate([b.next() for _ in range(20)])) == list(range(100)) for _ in range(3))
    else:                                  # clips uniform within their action
        within = np.bincount(drawn[groups[drawn] == 0], minlength=60)[:60]
        assert within.min() > 0.6 * within.mean()


def test_batches_stay_bucketed_by_length_when_balanced():
    groups, lengths = groups_and_lengths()
    b = BucketBatcher(lengths, batch=5, seed=0, bucket=20, groups=groups, alpha=0.0)
    spread = np.mean([np.ptp(lengths[b.next()]) for _ in range(200)])
    assert spread < 0.25 * np.ptp(lengths), spread                  # similar lengths in a batch: little padding


def test_resume_continues_the_same_sequence():
    groups, lengths = groups_and_lengths()
    a = BucketBatcher(lengths, batch=5, seed=7, groups=groups, alpha=0.5)
    for _ in range(53):                                             # into the third epoch
        a.next()
    st = a.state()
    b = BucketBatcher(lengths, batch=5, seed=7, groups=groups, alpha=0.5)
    b.load_state(st)
    assert all(np.array_equal(a.next(), b.next()) for _ in range(60))
    other = BucketBatcher(lengths, batch=5, seed=7, groups=groups, alpha=1.0)
    with pytest.raises(ValueError, match="balance alpha 0.5"):
        other.load_state(st)


def test_ddp_ranks_split_each_global_batch():
    groups, lengths = groups_and_lengths()
    whole = BucketBatcher(lengths, batch=10, seed=2, groups=groups, alpha=0.0)
    ranks = [BucketBatcher(lengths, batch=5, seed=2, rank=r, world=2, groups=groups, alpha=0.0) for r in (0, 1)]
    for _ in range(25):
        assert np.array_equal(whole.next(), np.concatenate([r.next() for r in ranks]))


def test_weights_and_shares():
    groups, _ = groups_and_lengths()
    w = balanced_weights(groups, 0.0)
    assert np.isclose(w.sum(), 1.0) and np.allclose([w[groups == a].sum() for a in range(4)], 0.25)
    rows = action_shares(groups, 0.5, ["walk", "wave", "bow", "jump"])
    assert [r["action"] for r in rows] == ["walk", "wave", "bow", "jump"]
    assert rows[-1]["clips"] == 1 and np.isclose(rows[-1]["share_clips"], 0.01)
    assert np.isclose(rows[-1]["share"], 1 / sum(np.sqrt(COUNTS)))
    with pytest.raises(ValueError, match="alpha"):
        balanced_weights(groups, -1.0)


def test_crop_plan_keeps_windows_inside_clips():
    lengths = np.random.default_rng(0).integers(10, 197, (50, 8))
    s, n = crop_plan(lengths, 0.5, 40, np.random.default_rng(1))
    assert (s >= 0).all() and (s + n <= lengths).all()
    cropped = n < lengths
    assert 0.3 < cropped[lengths > 45].mean() < 0.7 and (n[cropped] >= 40).all()
    assert (n[lengths <= 40] == lengths[lengths <= 40]).all()


def test_train_prints_and_records_the_distribution_and_resumes_exactly(tmp_path, capsys):
    data = write_synthetic_dataset(tmp_path / "ds", n_clips=15)
    with open(data / "metadata.csv", newline="") as f:                  # make it 11:3:1 (walk, wave, turn)
        rows = list(csv.DictReader(f))
    for i, r in enumerate(rows):
        r["action"], r["action_id"] = ("wave", 1) if i in (1, 4, 7) else ("turn", 2) if i == 2 else ("walk", 0)
    with open(data / "metadata.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    common = ["--data", str(data), "--task", "action", "--preset", "tiny", "--d-width", "32", "--batch", "4",
              "--threads", "1", "--log-every", "1", "--no-progress", "--steps", "5", "--balance-alpha", "0"]
    straight, split = tmp_path / "a", tmp_path / "b"
    assert train_main([*common, "--out", str(straight)]) == 0
    err = capsys.readouterr().err
    assert "sampling: --balance-alpha 0.0 over 3 actions: turn 33.3% (1 clips; α=1: 6.7%)" in err, err
    st = torch.load(straight / "ckpt.pt", weights_only=True)
    assert st["meta"]["args"]["balance_alpha"] == 0.0 and st["meta"]["sampling"]["balance_alpha"] == 0.0
    assert {r["action"]: r["clips"] for r in st["meta"]["sampling"]["actions"]} == {"walk": 11, "wave": 3, "turn": 1}
    assert train_main([*common, "--out", str(split), "--stop-at", "2"]) == 0
    assert train_main([*common, "--out", str(split)]) == 0
    b = torch.load(split / "ckpt.pt", weights_only=True)
    for name in st["G"]:
        assert torch.equal(st["G"][name], b["G"][name]), name
    assert b["batcher"] == st["batcher"]
