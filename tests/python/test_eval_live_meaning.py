"""emdm.eval.live_meaning (run by ``python -m emdm.eval.seams``): a live session cut into its prompts' segments, the
judges on segments whose answer is known (real clips: a segment of a walk passes as a walk, of a wave does not), the
blends' statistic (the Node benchmark's) and the paired verdict, and the command's bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from emdm import paths
from emdm.eval import live_meaning as LM
from emdm.eval import seams as S
from emdm.motion import edit as E
from emdm.motion import live as L
from emdm.motion.edit_fixture import LABELS, tiny_editor
from emdm.motion.synthetic import synthetic_walk

from test_eval_kinematics import WALK, WAVE, needs_bandai, real_clip

CLASSIFIER = paths.RUNS_DIR / "eval" / "classifier.pt"
needs_judges = pytest.mark.skipif(not (CLASSIFIER.is_file() and (paths.DATASET_DIR / "test.txt").is_file()),
                                  reason=f"the action classifier ({CLASSIFIER}) or the prepared dataset "
                                         f"({paths.DATASET_DIR}) is missing")


# ----------------------------------------------------------------------------------------------- the session

def test_schedule_gives_every_action_as_often_never_twice_in_a_row():
    sched = LM.schedule(["a", "b", "c"], 30, np.random.default_rng(0), gap=(4, 8))
    assert sched[0][0] == 0 and len(sched) == 31
    acts = [a for _, a in sched]
    assert all(x != y for x, y in zip(acts, acts[1:]))
    assert max(acts.count(a) for a in "abc") - min(acts.count(a) for a in "abc") <= 1
    gaps = np.diff([p for p, _ in sched])
    assert gaps.min() >= 80 and gaps.max() <= 160


def test_each_prompt_segment_runs_from_its_blend_end_to_the_next_prompt():
    model = tiny_editor()
    prompts = {a: a for a in LABELS[:3]}
    sched = [(0, "a"), (100, "b"), (190, "c"), (200, "a")]     # c is replaced by a before its window is ready
    sim, feats, blends, _ = LM.session(model, sched, prompts, seed=1, cost=30, tail=120)
    assert len(feats) == len(sim.joints) == 320
    joined = {w[0].start: w[2] for w in sim.windows if w[0].prompted and not w[3] and w[2] is not None}
    assert blends == [0, joined[100], None, joined[200]] and joined[100] >= 100 + L.PROMPT_LEAD
    cuts = LM.segments(sched, blends, len(feats))
    assert cuts == [(LM.SPAN, 100), (joined[100] + LM.SPAN, 190), None, (joined[200] + LM.SPAN, 320)]


def test_a_session_runs_windows_of_the_length_asked_for():
    model, prompts = tiny_editor(), {a: a for a in LABELS[:2]}
    sim, *_ = LM.session(model, [(0, "a"), (60, "b")], prompts, seed=1, cost=3, tail=80, window=24)
    assert {w[0].frames for w in sim.windows} == {E.OVERLAP + 24}
    sim, *_ = LM.session(model, [(0, "a"), (60, "b")], prompts, seed=1, cost=3, tail=80)
    assert {w[0].frames for w in sim.windows} == {E.OVERLAP + L.WINDOW}


# ----------------------------------------------------------------------------------------------- the judges

@needs_bandai
def test_the_kinematic_judge_passes_a_segment_of_a_real_walk_as_a_walk_and_fails_one_of_a_wave():
    walk, wave = real_clip(WALK, 160)[40:140], real_clip(WAVE, 160)[40:140]      # mid-clip, as a live segment
    got = LM.judge(list(LABELS), ["walk", "walk", "wave-right-hand"], [np.zeros((100, 263))] * 3, [walk, wave, wave],
                   lambda f: np.zeros(len(f), int), judged=["walk", "wave-right-hand"])
    assert got["kinematic"] == [True, False, True]
    unjudged = LM.judge(list(LABELS), ["walk"], [np.zeros((100, 263))], [walk], lambda f: np.zeros(1, int), judged=[])
    assert unjudged["kinematic"] == [None]


@needs_judges
def test_the_classifier_recognises_a_segment_of_a_real_clip_as_its_action_and_not_as_another():
    from emdm.eval import coverage as C

    bench = C.Benchmark(paths.DATASET_DIR, "test", CLASSIFIER, C.PROMPTS_FILE, seeds=1, log=lambda *a: None)
    labels, acts, motions = bench.labels, bench.test.actions, bench.test.motions
    pick = lambda a: next(m for m, k in zip(motions, acts) if labels[k] == a and len(m) >= 80)  # noqa: E731
    walk, raise_both = pick("walk")[20:], pick("raise-both-hands")[20:]       # after their first second, as live segments
    got = LM.judge(labels, ["walk", "raise-both-hands", "walk"], [walk, raise_both, raise_both],
                   [np.zeros((60, 22, 3))] * 3, bench.predict, judged=[])
    assert got["classifier"] == [True, True, False] and got["predicted"][2] == "raise-both-hands"


def test_the_classifier_judge_reads_a_segment_mid_motion_as_its_action_and_not_as_another():
    """The test above on any fresh clone (no prepared dataset, no trained evaluator): a small action classifier
    trained here on synthetic actions whose content is known (tests/python/test_eval_evaluators.py's motions),
    judging segments cut from the middle of longer motions, as live segments are."""
    from emdm.eval import evaluators as E

    rng = np.random.default_rng(0)
    centres = np.eye(4)

    def motion(k: int, frames: int) -> np.ndarray:
        t = np.arange(frames)[:, None]
        m = rng.normal(scale=0.05, size=(frames, 263)).astype(np.float32)
        amp = centres[k] + rng.normal(scale=0.1, size=4)
        m[:, 0:4] += amp[None] * np.sin(2 * np.pi * t / 20.0)
        m[:, 4:8] += amp[None] * np.cos(2 * np.pi * t / 20.0)
        return m

    labels = rng.integers(0, 4, size=256)
    model = E.train_classifier([motion(k, int(rng.integers(40, 80))) for k in labels], labels, 4,
                               np.zeros(263, np.float32), np.ones(263, np.float32),
                               E.TrainConfig(epochs=8, batch_size=32, lr=3e-3, hidden=32, emb_dim=32, dropout=0.0, seed=0))
    predict = lambda feats: np.argmax(E.classify(model, feats)[0], axis=1)  # noqa: E731
    names = ["a", "b", "c", "d"]
    seg_b, seg_c = motion(1, 140)[30:110], motion(2, 140)[30:110]
    got = LM.judge(names, ["b", "c", "b"], [seg_b, seg_c, seg_c], [np.zeros((80, 22, 3))] * 3, predict, judged=[])
    assert got["classifier"] == [True, True, False] and got["predicted"][2] == "c"


def test_rates_pair_each_segment_with_its_alone_motion():
    live = {"classifier": [True, False, False, True], "kinematic": [True, None, True, None]}
    alone = {"classifier": [True, True, True, False], "kinematic": [False, None, True, None]}
    r = LM.rates(["walk", "walk", "bow", "bow"], live, alone)
    c, k = r["all"]["classifier"], r["all"]["kinematic"]
    assert (c["live"], c["alone"], c["only_live_fails"], c["only_alone_fails"]) == (0.5, 0.75, 2, 1)
    assert c["ratio"] == pytest.approx(2 / 3)
    assert (k["n"], k["live"], k["alone"], k["ratio"]) == (2, 1.0, 0.5, 2.0)
    assert r["per_action"]["walk"]["classifier"]["live"] == 0.5 and "kinematic" in r["per_action"]["bow"]


def test_the_verdict_is_a_paired_sign_test():
    assert LM.worse_p(0, 0) == 1.0
    assert LM.worse_p(5, 0) == pytest.approx(1 / 32)
    assert LM.worse_p(3, 3) > 0.5
    row = lambda a, b: {"only_live_fails": a, "only_alone_fails": b}  # noqa: E731
    assert LM.verdict({"classifier": row(25, 8), "kinematic": row(7, 13)}) == {
        "p_worse": {"classifier": pytest.approx(0.0023, abs=1e-4), "kinematic": pytest.approx(0.94, abs=0.01)},
        "met": False}
    assert LM.verdict({"classifier": row(12, 8), "kinematic": row(0, 3)})["met"]


# ----------------------------------------------------------------------------------------------- the blends

def test_a_pop_at_a_blend_is_seen_and_a_smooth_blend_is_not():
    j = synthetic_walk(200, turn_per_frame=0.0)
    popped = j.copy()
    popped[108:, 20] += [0.3, 0, 0]                                    # the right wrist jumps 0.3 m inside the span
    (smooth,), p95 = LM.blend_ratios(j, [100])
    (pop,), p95_pop = LM.blend_ratios(popped, [100])
    assert smooth < 1.5 < pop and p95_pop == pytest.approx(p95)        # the span is not "elsewhere"
    assert LM.blend_ratios(j, [190])[0] == [None]                      # its span runs past the motion's end
    # the same statistic in a segment's middle: the pop is at the blend, not there
    assert max(LM.placebo_ratios(popped, [(114, 200)], p95_pop)) < 1.5


# ----------------------------------------------------------------------------------------------- the command

def test_bad_capabilities_is_one_line_and_exit_2_before_anything_is_measured(tmp_path, capsys):
    bad = tmp_path / "capabilities.json"
    bad.write_text(json.dumps({"actions": [{"label": "walk", "covered": True, "prompt": "a person walks"}]}))
    assert S.main(["--capabilities", str(bad), "--out", str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(bad) in err and "at least 2" in err
    bad.write_text("[]")
    assert S.main(["--capabilities", str(bad), "--out", str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(bad) in err and "capabilities file" in err
    assert not (tmp_path / "out.json").exists()
    with pytest.raises(SystemExit):
        S.parse_args(["--live-changes", "-1"])
    with pytest.raises(SystemExit):
        S.parse_args(["--live-window", "0"])


def _session(file, seed, live_fails, alone_fails, n=100, train_steps=42104, keep=0.15, window=None):
    row = {"n": n, "live": (n - live_fails) / n, "alone": (n - alone_fails) / n, "ratio": None,
           "only_live_fails": live_fails, "only_alone_fails": alone_fails}
    live = {"seed": seed, "prompt_keep_from": keep, "cost_frames": 3, "gap_seconds": [4.0, 8.0],
            "rates": {"all": {"classifier": row}}}
    return {"_file": file, "name": "emdm-t2m-web", "train_steps": train_steps,
            "live": live if window is None else {**live, "window": window}}


def test_sessions_of_one_stream_and_weights_are_pooled_and_judged_together():
    a, b = _session("a.json", 0, 15, 6), _session("b.json", 1, 6, 11)
    other_weights, other_stream = _session("c.json", 2, 30, 0, train_steps=35000), _session("d.json", 3, 30, 0, keep=0.55)
    (g,) = LM.pooled([a, b, other_weights, other_stream])
    assert g["files"] == ["a.json", "b.json"]
    c = g["rates"]["classifier"]
    assert (c["n"], c["only_live_fails"], c["only_alone_fails"]) == (200, 21, 17)
    assert abs(c["live"] - 179 / 200) < 1e-9 and abs(c["alone"] - 183 / 200) < 1e-9
    assert g["verdict"]["met"] and abs(g["verdict"]["p_worse"]["classifier"] - LM.worse_p(21, 17)) < 1e-12
    assert not LM.verdict(a["live"]["rates"]["all"])["met"]          # seed 0 alone: 15 vs 6 pairs, p 0.039
    assert LM.pooled([a]) == [] and LM.pooled([a, {**a, "_file": "a2.json"}]) == []   # one seed is no pool
    bad = LM.pooled([a, _session("e.json", 1, 40, 2)])[0]
    assert not bad["verdict"]["met"]                                 # pooling does not hide a stream that is worse
    # another window length is another stream; a session without the field ran with windows of 40 new frames
    w60 = _session("f.json", 1, 6, 11, window=60)
    assert LM.pooled([a, w60]) == []
    assert LM.pooled([a, _session("g.json", 1, 6, 11, window=40)])[0]["files"] == ["a.json", "g.json"]


def test_sessions_judged_by_another_classifier_are_not_pooled():
    """A session records its judge (``live.classifier``, emdm.eval.judge): another judge's verdicts on the same stream
    are not summed with these; sessions of one judge are, and so are the older ones that recorded none."""
    a, b = _session("a.json", 0, 15, 6), _session("b.json", 1, 6, 11)
    three = lambda s: {**s, "live": {**s["live"], "classifier": {"sha256": "43392407131229e9"}}}  # noqa: E731
    assert LM.pooled([a, three(b)]) == []
    assert LM.pooled([three(a), three(b)])[0]["files"] == ["a.json", "b.json"]
    assert LM.pooled([a, b])[0]["files"] == ["a.json", "b.json"]
