"""The evaluators learn what they should on synthetic motions whose content is known, and behave
as a measuring instrument must (independent of batching, same after save/load, clear errors); the command line
refuses a dataset, --out or count it cannot use in one line (exit 2) before it writes anything."""

import json
import shutil

import numpy as np
import pytest
import torch

from emdm.eval import evaluators as E
from emdm.eval import metrics as M

torch.set_num_threads(1)
MEAN, STD = np.zeros(263, np.float32), np.ones(263, np.float32)
SMALL = E.TrainConfig(epochs=12, batch_size=32, lr=3e-3, hidden=32, emb_dim=32, dropout=0.0, seed=0)


def _motion(params, frames, rng):
    """Raw features whose channels 0..7 oscillate with amplitudes given by params (4,)."""
    t = np.arange(frames)[:, None]
    m = rng.normal(scale=0.05, size=(frames, 263)).astype(np.float32)
    m[:, 0:4] += params[None, :] * np.sin(2 * np.pi * t / 20.0)
    m[:, 4:8] += params[None, :] * np.cos(2 * np.pi * t / 20.0)
    return m


def _pairs(n, seed):
    rng = np.random.default_rng(seed)
    proj = np.random.default_rng(99).normal(size=(4, 16))
    params = rng.uniform(-1, 1, size=(n, 4))
    motions = [_motion(p, int(rng.integers(40, 80)), rng) for p in params]
    text = params @ proj
    text /= np.linalg.norm(text, axis=1, keepdims=True)
    return motions, text.astype(np.float32)


def test_matcher_learns_to_retrieve_the_described_motion():
    motions, text = _pairs(384, seed=0)
    model = E.train_matcher(motions, [t[None] for t in text], MEAN, STD, SMALL)
    vm, vt = _pairs(320, seed=1)                        # held out
    rp, mm = M.r_precision_and_matching(E.embed_texts(model, vt), E.embed_motions(model, vm), rng=0)
    assert rp[0] > 0.8, f"R-precision {rp} (chance top-1 is 1/32)"
    # a shuffled pairing must score far worse: the instrument sees the content
    rp_shuffled = M.r_precision(E.embed_texts(model, vt), E.embed_motions(model, vm[::-1]), rng=0)
    assert rp_shuffled[2] < 0.25


def test_classifier_recognises_actions():
    rng = np.random.default_rng(0)
    centres = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])
    labels = rng.integers(0, 4, size=256)
    motions = [_motion(centres[k] + rng.normal(scale=0.1, size=4), int(rng.integers(40, 80)), rng) for k in labels]
    model = E.train_classifier(motions, labels, 4, MEAN, STD, E.TrainConfig(**{**SMALL.__dict__, "epochs": 8}))
    vl = rng.integers(0, 4, size=128)
    vm = [_motion(centres[k] + rng.normal(scale=0.1, size=4), int(rng.integers(40, 80)), rng) for k in vl]
    logits, feats = E.classify(model, vm)
    assert M.accuracy(logits, vl) > 0.9
    assert feats.shape == (128, 32)


def test_embedding_does_not_depend_on_batch_or_padding():
    motions, _ = _pairs(6, seed=3)
    model = E.MatchingModel(MEAN, STD, text_dim=16, hidden=16, emb_dim=8).eval()
    together = E.embed_motions(model, motions)
    alone = np.concatenate([E.embed_motions(model, [m]) for m in motions])
    np.testing.assert_allclose(together, alone, atol=1e-5)


def test_normalisation_uses_the_stored_stats_and_ignores_contacts():
    motions, _ = _pairs(4, seed=4)
    mean = np.random.default_rng(0).normal(size=263).astype(np.float32)
    std = np.full(263, 2.0, np.float32)
    model = E.MatchingModel(mean, std, text_dim=16, hidden=16, emb_dim=8).eval()
    base = E.embed_motions(model, motions)
    changed = [m.copy() for m in motions]
    for m in changed:
        m[:, 259:263] = 1.0 - m[:, 259:263]            # foot contacts are not read
    np.testing.assert_allclose(E.embed_motions(model, changed), base, atol=1e-6)
    shifted = [m + 0.5 for m in motions]                # other channels are
    assert np.abs(E.embed_motions(model, shifted) - base).max() > 1e-3


def test_save_and_load_give_the_same_instrument(tmp_path):
    motions, text = _pairs(8, seed=5)
    m = E.MatchingModel(MEAN + 1, STD * 3, text_dim=16, hidden=16, emb_dim=8).eval()
    path = E.save(m, tmp_path / "m.pt", {"note": "x"})
    back = E.load(path, "matcher")
    np.testing.assert_allclose(E.embed_motions(back, motions), E.embed_motions(m, motions), atol=1e-6)
    np.testing.assert_allclose(E.embed_texts(back, text), E.embed_texts(m, text), atol=1e-6)
    assert back.meta == {"note": "x"}
    with pytest.raises(ValueError, match="holds a matcher, expected a classifier"):
        E.load(path, "classifier")
    with pytest.raises(FileNotFoundError, match="python -m emdm.eval.evaluators classifier"):
        E.load(tmp_path / "none.pt", "classifier")


def test_bad_motion_input_is_named():
    good = np.zeros((50, 263), np.float32)
    with pytest.raises(ValueError, match=r"motion 1: expected shape \(frames, 263\)"):
        E.pad_motions([good, np.zeros((50, 262), np.float32)])
    bad = good.copy()
    bad[17, 5] = np.inf
    with pytest.raises(ValueError, match="motion 0: non-finite feature at frame 17"):
        E.pad_motions([bad])


def test_length_batches_cover_each_clip_once_with_little_padding():
    rng = np.random.default_rng(0)
    lengths = rng.integers(40, 197, size=1000)
    batches = E.length_batches(lengths, 64, np.random.default_rng(1))
    flat = np.concatenate(batches)
    assert len(flat) == len(set(flat.tolist())) and len(flat) >= 1000 - 64
    assert all(len(b) == 64 for b in batches)
    waste = np.mean([1 - lengths[b].mean() / lengths[b].max() for b in batches])
    assert waste < 0.1                                   # random batches waste ~35 %


@pytest.mark.parametrize("kind", ["matcher", "classifier"])
def test_every_epoch_trains_with_dropout_after_a_validation(kind, monkeypatch):
    # the per-epoch validation runs in eval mode (embed_*/classify); every later epoch must still train with dropout
    seen = []
    cls = E.MatchingModel if kind == "matcher" else E.ActionClassifier
    method = "encode_motion" if kind == "matcher" else "forward"
    orig = getattr(cls, method)

    def spy(self, *a, **k):
        if torch.is_grad_enabled():        # a training batch (validation runs under no_grad)
            seen.append(self.training)
        return orig(self, *a, **k)

    monkeypatch.setattr(cls, method, spy)
    cfg = E.TrainConfig(**{**SMALL.__dict__, "epochs": 3, "dropout": 0.2})
    if kind == "matcher":
        motions, text = _pairs(64, seed=2)
        vm, vt = _pairs(M.R_PRECISION_POOL, seed=3)
        E.train_matcher(motions, [t[None] for t in text], MEAN, STD, cfg, val=(vm, vt))
    else:
        rng = np.random.default_rng(1)
        labels = rng.integers(0, 2, size=64)
        motions = [_motion(np.eye(4)[k], 48, rng) for k in labels]
        E.train_classifier(motions, labels, 2, MEAN, STD, cfg, val=(motions[:8], labels[:8]))
    assert len(seen) >= 3 and all(seen), seen


# ----------------------------------------------------------------------------- the command line

SMALL_CLI = ["--epochs", "1", "--hidden", "8", "--emb-dim", "8", "--batch-size", "4"]


@pytest.fixture(scope="module")
def synth(tmp_path_factory):
    from model_synth_data import write_synthetic_dataset

    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def _refusal(capsys) -> str:
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and "Traceback" not in cap.err, cap.err
    return lines[0]


def test_cli_refuses_a_missing_dataset_in_one_line_and_writes_nothing(tmp_path, capsys):
    for kind in ("matcher", "classifier"):
        rc = E._main([kind, "--dataset", str(tmp_path / "nope"), "--out", str(tmp_path / "o" / "m.pt"), *SMALL_CLI])
        line = _refusal(capsys)
        assert rc == 2 and f"{tmp_path / 'nope' / 'train.txt'}: split file not found" in line, line
    assert list(tmp_path.iterdir()) == []


def test_cli_refuses_an_unusable_out_or_dataset_in_one_line(synth, tmp_path, capsys):
    blocker = tmp_path / "blocker"
    blocker.write_text("a file where a folder should be")
    for out, says in ((tmp_path, f"--out {tmp_path}: is a folder; give a file path"),
                      (blocker / "m.pt", f"--out {blocker / 'm.pt'}: {blocker} is a file, not a folder")):
        assert E._main(["classifier", "--dataset", str(synth), "--out", str(out), *SMALL_CLI]) == 2
        line = _refusal(capsys)
        assert line.startswith(f"error: {says}"), line
    no_actions = tmp_path / "ds"
    shutil.copytree(synth, no_actions)
    (no_actions / "actions.json").unlink()
    (no_actions / "metadata.csv").unlink()
    assert E._main(["classifier", "--dataset", str(no_actions), "--out", str(tmp_path / "o" / "c.pt"), *SMALL_CLI]) == 2
    assert "train.txt: no usable clips" in _refusal(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker", "ds"]


@pytest.mark.parametrize("flag", ["--threads", "--epochs", "--batch-size"])
def test_cli_refuses_a_count_below_one(synth, tmp_path, capsys, flag):
    with pytest.raises(SystemExit) as e:
        E._main(["matcher", "--dataset", str(synth), "--out", str(tmp_path / "m.pt"), *SMALL_CLI, flag, "0"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and f"{flag}: expected ≥ 1, got 0" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kind", ["matcher", "classifier"])
def test_cli_trains_and_writes_the_checkpoint_and_its_log(synth, tmp_path, capsys, monkeypatch, kind):
    from model_synth_data import fake_text_encoder

    fake_text_encoder(monkeypatch)
    monkeypatch.setenv("EMDM_EVAL_CACHE", str(tmp_path / "cache"))
    out = tmp_path / "eval" / f"{kind}.pt"
    assert E._main([kind, "--dataset", str(synth), "--out", str(out), *SMALL_CLI]) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1].startswith(f"wrote {out} (")
    model = E.load(out, kind)
    rows = [json.loads(line) for line in out.with_suffix(".log.jsonl").read_text().splitlines()]
    assert model.meta["epochs_run"] == len(rows) == 1 and model.meta["train_items"] == 12
    assert model.meta.get("labels", ["walk", "wave", "turn"]) == ["walk", "wave", "turn"]
