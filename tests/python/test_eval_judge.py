"""The judge of meaning (emdm.eval.judge): one classifier names what its argmax names; several name the argmax of
their mean softmax probability, record each member and one digest for them all; a missing, foreign or doubled file
is refused by name; coverage with an ensemble keeps its earlier step counts only under the same ensemble."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

sys.path.insert(0, str(Path(__file__).parent))
from test_eval_coverage import _args, world  # noqa: E402,F401 - the coverage tests' tiny models and classifier

from emdm.eval import coverage as C  # noqa: E402
from emdm.eval import data as evdata  # noqa: E402
from emdm.eval import evaluators as E  # noqa: E402
from emdm.eval import judge as J  # noqa: E402
from emdm.eval.results import evaluator_info  # noqa: E402
from emdm import paths  # noqa: E402

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def seeds(world):
    """Two more tiny classifiers on the coverage world's dataset, seeds 1 and 2 (c.pt is seed 0)."""
    root, ds = world
    for s in (1, 2):
        if not (root / f"c{s}.pt").exists():
            assert E._main(["classifier", "--out", str(root / f"c{s}.pt"), "--epochs", "2", "--hidden", "16",
                            "--emb-dim", "16", "--batch-size", "8", "--dataset", str(ds), "--seed", str(s)]) == 0
    return [root / "c.pt", root / "c1.pt", root / "c2.pt"]


def _motions(ds):
    return evdata.load_split(ds, "test", require_action=True).motions


def _softmax(logits):
    return torch.softmax(torch.from_numpy(logits), dim=1).numpy()


def test_one_file_names_what_its_classifier_names(world, seeds):
    root, ds = world
    motions = _motions(ds)
    judge = J.Judge(seeds[0])
    logits = E.classify(E.load(seeds[0], "classifier"), motions)[0]
    assert np.array_equal(judge.predict(motions), np.argmax(logits, axis=1))
    assert np.allclose(judge.probs(motions), _softmax(logits))
    assert judge.info() == evaluator_info(judge.members[0], seeds[0])        # results of one file are as before


def test_several_files_name_the_argmax_of_their_mean_probability(world, seeds):
    root, ds = world
    motions = _motions(ds)
    probs = [_softmax(E.classify(E.load(p, "classifier"), motions)[0]) for p in seeds]
    judge = J.Judge(seeds)
    mean = np.mean(probs, axis=0)
    assert np.allclose(judge.probs(motions), mean) and np.allclose(mean.sum(axis=1), 1)
    assert np.array_equal(judge.predict(motions), np.argmax(mean, axis=1))
    singles = [np.argmax(p, axis=1) for p in probs]
    assert any(not np.array_equal(s, singles[0]) for s in singles[1:]), "the tiny seeds should disagree somewhere"
    info = judge.info()
    shas = [evaluator_info(m, p)["sha256"] for m, p in zip(judge.members, seeds)]
    assert [m["sha256"] for m in info["members"]] == shas and len(set(shas)) == 3
    assert len(info["sha256"]) == 16 and info["sha256"] not in shas
    assert info["sha256"] == J.Judge(seeds[::-1]).info()["sha256"]           # the mean does not depend on the order
    assert info["sha256"] != J.Judge(seeds[:2]).info()["sha256"]
    assert info["summary"].startswith("mean probability of 3 classifiers (seeds 0, 1, 2): ActionClassifier")


def test_files_it_cannot_use_are_named(world, seeds, tmp_path):
    root, ds = world
    with pytest.raises(J.JudgeError, match=r"not found: .*classifier-seed2\.pt \(train it: `python -m "
                                           r"emdm\.eval\.evaluators classifier --seed 2 --out .*classifier-seed2\.pt`\)"):
        J.Judge([seeds[0], tmp_path / "classifier-seed2.pt"])
    with pytest.raises(J.JudgeError, match="given twice"):
        J.Judge([seeds[0], seeds[1], seeds[0]])
    with pytest.raises(J.JudgeError, match="no classifier file"):
        J.Judge([])
    other = E.ActionClassifier(np.zeros(E.FEATURE_DIM, np.float32), np.ones(E.FEATURE_DIM, np.float32), num_classes=2,
                               hidden=16, emb_dim=16)
    E.save(other, tmp_path / "two.pt", {"labels": ["walk", "jump"]})
    with pytest.raises(J.JudgeError, match=r"two\.pt: trained on other labels than .*c\.pt \(2 against 3 classes\)"):
        J.Judge([seeds[0], tmp_path / "two.pt"])
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(J.JudgeError, match=r"junk\.pt: cannot read as an evaluator checkpoint"):
        J.Judge([seeds[0], tmp_path / "junk.pt"])


def test_default_is_the_three_seeds_files():
    assert [p.name for p in J.default_paths()] == ["classifier.pt", "classifier-seed1.pt", "classifier-seed2.pt"]
    assert C.build_parser().parse_args(["--model", "emdm-t2m-web"]).classifier == J.default_paths(paths.RUNS_DIR / "eval")


def test_coverage_with_an_ensemble_records_it_and_keeps_runs_only_under_it(world, seeds, capsys):
    root, ds = world
    out = root / "results" / "json" / "coverage-t2m-ensemble.json"
    args = _args(root, ds, out, "--ckpt", str(root / "t2m" / "ckpt.pt"))
    at = args.index("--classifier")
    ensemble = [*args[:at + 1], *map(str, seeds), *args[at + 2:]]
    assert C.main([*ensemble, "--steps", "1"]) == 0
    r = json.loads(out.read_text())
    assert [Path(m["path"]).name for m in r["classifier"]["members"]] == ["c.pt", "c1.pt", "c2.pt"]
    assert len(r["classifier"]["members"]) == 3 and r["classifier"]["summary"].startswith("mean probability of 3")
    reordered = [*args[:at + 1], *map(str, seeds[::-1]), *args[at + 2:]]
    assert C.main([*reordered, "--steps", "2"]) == 0                      # same judge: the 1-step run is kept
    assert [x["steps"] for x in json.loads(out.read_text())["runs"]] == [1, 2]
    capsys.readouterr()
    assert C.main([*args, "--steps", "10"]) == 0                          # one of them alone is another judge
    assert [x["steps"] for x in json.loads(out.read_text())["runs"]] == [10]
    assert "its runs at 1, 2 step(s) were judged by another classifier; dropped" in capsys.readouterr().err
    missing = [*args[:at + 1], str(seeds[0]), str(root / "gone.pt"), *args[at + 2:]]
    assert C.main([*missing, "--steps", "1"]) == 2
    assert "gone.pt" in capsys.readouterr().err
