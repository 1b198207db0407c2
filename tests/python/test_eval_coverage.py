"""The coverage benchmark (python -m emdm.eval.coverage): its summary math on hand-made predictions, the
CLI end to end on a tiny synthetic dataset with tiny text/action models and a tiny classifier, the report
section it feeds, and the shipped prompts file (every label of the vocabulary, paraphrases unseen in
training)."""

import itertools
import json
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

sys.path.insert(0, str(Path(__file__).parent))
from model_synth_data import ACTIONS, fake_text_encoder, write_synthetic_dataset  # noqa: E402

from emdm import paths  # noqa: E402
from emdm.eval import coverage as C  # noqa: E402

torch.set_num_threads(1)


# ----------------------------------------------------------------------------- summary math

def test_real_summary_reference_set_and_too_few():
    labels = ["bow", "kick", "walk", "jump", "call"]
    #          bow: 3 clips, 2 right; kick: 4 clips, 1 right; walk: 3 clips, 3 right; jump: 2 clips; call: none
    actions = np.array([0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 3, 3])
    pred = np.array([0, 0, 2, 1, 2, 2, 2, 2, 2, 2, 3, 3])
    real = C.real_summary(labels, actions, pred, min_clips=3)
    assert real["per_action"]["bow"] == {"n": 3, "recognised": 2, "rate": pytest.approx(2 / 3)}
    assert real["per_action"]["kick"]["rate"] == 0.25
    assert real["per_action"]["call"] == {"n": 0, "recognised": 0, "rate": None}
    assert real["reference"] == ["bow", "walk"]                 # kick 0.25 < 0.5; jump recognised but 2 clips
    assert real["too_few"] == {"jump": 2, "call": 0}            # listed with their counts, not dropped
    assert real["macro_accuracy"] == pytest.approx(np.mean([2 / 3, 0.25, 1.0]))


def test_run_summary_covered_and_macro():
    labels = ["bow", "kick", "walk", "jump"]
    target = np.repeat(np.arange(4), 4)                          # 4 motions per action
    pred = np.array([0, 0, 1, 2,    # bow 2/4 = 0.5: covered (the bar is inclusive)
                     1, 2, 2, 2,    # kick 1/4
                     2, 2, 2, 2,    # walk 4/4
                     3, 3, 3, 0])   # jump 3/4
    per = C.rates(labels, target, pred)
    s = C.run_summary(per, reference=["bow", "kick", "walk"])
    assert s["covered"] == ["bow", "walk", "jump"]
    assert s["covered_reference"] == ["bow", "walk"] and s["reference_size"] == 3
    assert s["macro_accuracy"] == pytest.approx((0.5 + 0.25 + 1 + 0.75) / 4)
    assert s["macro_reference"] == pytest.approx((0.5 + 0.25 + 1) / 3)


def test_prompt_rates_and_chips():
    labels = ["bow", "walk"]
    prompts = ["a person bows"] * 4 + ["someone takes a deep bow"] * 4 + ["a person is walking"] * 4
    target = np.array([0] * 8 + [1] * 4)
    pred = np.array([0, 0, 0, 1,  0, 1, 1, 1,  1, 1, 1, 1])
    pr = C.prompt_rates(prompts, target, pred, labels)
    assert pr["a person bows"] == {"action": "bow", "n": 4, "recognised": 3, "rate": 0.75, "predicted": {"bow": 3, "walk": 1}}
    assert pr["someone takes a deep bow"]["rate"] == 0.25
    result = {"runs": [{"steps": 10, "prompts": pr}]}
    assert C.chips(result, 10) == ["a person is walking", "a person bows"]     # ≥ 0.75, best first
    with pytest.raises(C.CoverageError, match="no run at 4 steps .*--steps 4"):
        C.chips(result, 4)


def test_load_prompts_names_what_is_wrong(tmp_path):
    f = tmp_path / "p.json"
    f.write_text(json.dumps({"actions": {"walk": {"plain": "a person walks", "paraphrases": ["x", "y", "z"]}}}))
    assert C.load_prompts(f, ["walk"]) == {"walk": ["a person walks", "x", "y", "z"]}
    with pytest.raises(C.CoverageError, match=r"no prompts for 1 action\(s\) of the vocabulary: kick"):
        C.load_prompts(f, ["walk", "kick"])
    f.write_text(json.dumps({"actions": {"walk": {"plain": "a person walks", "paraphrases": ["x", "y"]}}}))
    with pytest.raises(C.CoverageError, match="'walk' needs .* at least 3 'paraphrases'"):
        C.load_prompts(f, ["walk"])


# ----------------------------------------------------------------------------- the shipped prompts

def _shipped_labels() -> list[str]:
    man = json.loads((paths.MODELS_DIR / "manifest.json").read_text())
    return man["models"]["emdm-a2m-web"]["condition"]["labels"]


def _template_captions() -> set[str]:
    """Every sentence the caption templates of Bandai and HDM05 can make (any subject × phrase × style
    adverb), and their mirrored copies: a superset of those sources' training captions."""
    from emdm.data import captions as cap

    subjects = cap.SUBJECTS + [s for ss in cap.STYLE_SUBJECTS.values() for s in ss]
    adverbs = sorted({a for ss in cap.STYLE_PHRASES.values() for a in ss})
    out = set()
    for s, p, a in itertools.product(subjects, [p for ps in cap.BANDAI_PHRASES.values() for p in ps], adverbs):
        out.add(f"{s} {p}" + (f" {a}" if a else ""))
    for s, p in itertools.product(subjects, [p for ps in cap.HDM05_PHRASES.values() for p in ps]):
        out.add(f"{s} {p}")
    return {C.normalise(x) for x in out | {cap.mirror_caption(x) for x in out}}


def test_prompts_cover_the_shipped_vocabulary():
    labels = _shipped_labels()
    prompts = C.load_prompts(C.PROMPTS_FILE, labels)              # raises naming any missing label
    assert len(prompts) == len(labels) == 38
    every = [C.normalise(p) for ps in prompts.values() for p in ps]
    assert len(every) == len(set(every)), "a prompt is used for two actions"


def test_paraphrases_are_not_training_captions():
    templates = _template_captions()
    assert C.normalise("A person bows politely.") in templates         # the enumeration does reach real captions
    prompts = C.load_prompts(C.PROMPTS_FILE, _shipped_labels())
    seen = [p for ps in prompts.values() for p in ps[1:] if C.normalise(p) in templates]
    assert not seen, f"paraphrases that are training captions: {seen}"


CMU_ARCHIVE = paths.shared_data_dir() / "cmu-mocap-subset.tar.xz"


@pytest.mark.skipif(not CMU_ARCHIVE.is_file(), reason=f"{CMU_ARCHIVE} not found (put ../shared/data beside the "
                    "checkout or set EMDM_SHARED_DATA)")
def test_paraphrases_are_not_cmu_captions():
    """CMU captions are made from the trials' free-text descriptions: every phrasing the caption code can
    make of any of the 2,435 descriptions (more than the subset's trials) is checked."""
    import csv
    import io
    import tarfile

    from emdm.data import captions as cap

    with tarfile.open(CMU_ARCHIVE, "r:xz") as tar:
        member = next(m for m in tar if m.name.endswith("cmu-descriptions.csv"))
        text = tar.extractfile(member).read().decode("utf-8", errors="replace")
    descs = {row["Motion Description"].strip() for row in csv.DictReader(io.StringIO(text)) if row.get("Motion Description")}
    assert len(descs) > 1000
    made = {C.normalise(f"{s} {p}") for d in descs for p in cap.cmu_phrases(d) for s in cap.SUBJECTS}
    made |= {C.normalise(cap.mirror_caption(x)) for x in made}
    prompts = C.load_prompts(C.PROMPTS_FILE, _shipped_labels())
    seen = [p for ps in prompts.values() for p in ps[1:] if C.normalise(p) in made]
    assert not seen, f"paraphrases that CMU captions can be: {seen}"


# ----------------------------------------------------------------------------- the CLI end to end

@pytest.fixture(scope="module")
def world(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    fake_text_encoder(mp)
    root = tmp_path_factory.mktemp("coverage")
    ds = write_synthetic_dataset(root / "ds", n_clips=30, seed=2)
    ids = (ds / "train.txt").read_text().split()
    (ds / "test.txt").write_text("\n".join(ids[:13]) + "\n")          # walk 5, wave 4, turn 4 clips
    mp.setenv("EMDM_EVAL_CACHE", str(root / "cache"))
    from emdm import train
    from emdm.eval import evaluators

    tiny = ["--data", str(ds), "--preset", "tiny", "--steps", "2", "--batch", "8", "--d-width", "16", "--threads", "1",
            "--no-progress", "--supported-steps", "1,2,10"]
    train.main([*tiny, "--out", str(root / "t2m")])
    train.main([*tiny, "--task", "action", "--out", str(root / "a2m")])
    assert evaluators._main(["classifier", "--out", str(root / "c.pt"), "--epochs", "2", "--hidden", "16",
                             "--emb-dim", "16", "--batch-size", "8", "--dataset", str(ds)]) == 0
    prompts = {"walk": {"plain": "a person walks", "paraphrases": ["someone strolls", "a human is walking", "walking ahead"]},
               "wave": {"plain": "a person waves", "paraphrases": ["someone says hello with a hand", "a hand waving", "waving"]},
               "turn": {"plain": "a person turns", "paraphrases": ["someone walks in a bend", "turning", "a curved walk"]}}
    (root / "prompts.json").write_text(json.dumps({"actions": prompts}))
    yield root, ds
    mp.undo()


def _args(root, ds, out, *extra):
    return ["--dataset", str(ds), "--classifier", str(root / "c.pt"), "--prompts", str(root / "prompts.json"),
            "--seeds", "2", "--out", str(out), *extra]


def test_cli_measures_text_model_and_report_shows_it(world, capsys):
    from emdm.eval import report

    root, ds = world
    out = root / "results" / "json" / "coverage-t2m.json"
    assert C.main(_args(root, ds, out, "--ckpt", str(root / "t2m" / "ckpt.pt"), "--steps", "1,10")) == 0
    r = json.loads(out.read_text())
    assert r["task"] == "coverage" and r["condition"] == "text" and r["labels"] == ACTIONS
    assert [x["steps"] for x in r["runs"]] == [1, 10] and r["key"]["guidance"] == 2.5
    assert r["real"]["n"] == 13 and sum(v["n"] for v in r["real"]["per_action"].values()) == 13
    for x in r["runs"]:
        assert x["motions"] == 3 * 4 * 2                                   # actions × prompts × seeds
        assert all(v["n"] == 8 and 0 <= v["recognised"] <= 8 for v in x["per_action"].values())
        assert set(x["prompts"]) == {p for e in json.loads((root / "prompts.json").read_text())["actions"].values()
                                     for p in [e["plain"], *e["paraphrases"]]}
        assert x["macro_accuracy"] == pytest.approx(np.mean([v["rate"] for v in x["per_action"].values()]))
    assert r["chips"]["steps"] == 10 and r["chips"]["prompts"] == C.chips(r, 10)
    # another step count later: merged into the same file, earlier runs kept
    assert C.main(_args(root, ds, out, "--ckpt", str(root / "t2m" / "ckpt.pt"), "--steps", "2")) == 0
    merged = json.loads(out.read_text())
    assert [x["steps"] for x in merged["runs"]] == [1, 2, 10] and len(merged["classifier"]["sha256"]) == 16
    # ... but not beside runs another classifier judged (a retrained one moves single actions a lot): they are dropped
    from emdm.eval import evaluators
    other = root / "c-other.pt"
    assert evaluators._main(["classifier", "--out", str(other), "--epochs", "1", "--hidden", "16", "--emb-dim", "16",
                             "--batch-size", "8", "--dataset", str(ds), "--seed", "5"]) == 0
    capsys.readouterr()
    elsewhere = out.with_name("coverage-t2m-other.json")
    out.with_name(elsewhere.name).write_text(out.read_text())
    args = _args(root, ds, elsewhere, "--ckpt", str(root / "t2m" / "ckpt.pt"), "--steps", "2")
    assert C.main([*args[:2], "--classifier", str(other), *args[4:]]) == 0
    judged = json.loads(elsewhere.read_text())
    assert [x["steps"] for x in judged["runs"]] == [2] and judged["classifier"]["sha256"] != merged["classifier"]["sha256"]
    assert "its runs at 1, 10 step(s) were judged by another classifier; dropped" in capsys.readouterr().err
    elsewhere.unlink()
    capsys.readouterr()
    assert C.main(_args(root, ds, out, "--ckpt", str(root / "t2m" / "ckpt.pt"), "--chips")) == 0
    printed = capsys.readouterr().out
    assert "at 10 steps" in printed and all(p in printed for p in r["chips"]["prompts"])
    md = root / "RESULTS.md"
    assert report.main(["--results", str(root / "results"), "--out", str(md)]) == 0
    text = md.read_text()
    assert "## Coverage per action (issue 12)" in text and "| Action | Ref. | Real (clips) | 1 step | 2 steps | 10 steps |" in text
    assert "**covered of the reference set**" in text and (root / "results" / "coverage-t2m.png").is_file()


def test_cli_measures_action_model(world):
    root, ds = world
    out = root / "a2m.json"
    assert C.main(_args(root, ds, out, "--ckpt", str(root / "a2m" / "ckpt.pt"), "--steps", "1")) == 0
    r = json.loads(out.read_text())
    assert r["condition"] == "action" and "chips" not in r
    (run,) = r["runs"]
    assert run["motions"] == 3 * 2 and "prompts" not in run                # one-hot: the label is the prompt
    assert {a: v["n"] for a, v in run["per_action"].items()} == {a: 2 for a in ACTIONS}


def test_cli_refuses_paraphrases_seen_in_training(world, capsys):
    root, ds = world
    bad = json.loads((root / "prompts.json").read_text())
    bad["actions"]["walk"]["paraphrases"][0] = "Someone walks ahead."       # a caption of the synthetic data
    (root / "bad.json").write_text(json.dumps(bad))
    args = _args(root, ds, root / "x.json", "--ckpt", str(root / "t2m" / "ckpt.pt"), "--steps", "1")
    args[args.index("--prompts") + 1] = str(root / "bad.json")
    assert C.main(args) == 2
    err = capsys.readouterr().err
    assert "bad.json: 1 paraphrase(s) are captions of the dataset" in err and "'Someone walks ahead.'" in err
    assert not (root / "x.json").exists()
