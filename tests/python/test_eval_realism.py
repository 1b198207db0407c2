"""The realism benchmark (python -m emdm.eval.realism): its speed and jitter checks on real walks where the answer
is known (the clip itself passes; played twice as fast it fails the speed check; with a one-frame flip it fails the
jitter check), the per-action figures against a real reference, and the CLI end to end on the coverage tests'
synthetic world with the RESULTS.md section it feeds."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_eval_coverage import _args, world  # noqa: E402,F401 - the coverage tests' tiny models and classifier
from test_eval_kinematics import needs_bandai, real_clip  # noqa: E402

from emdm import paths  # noqa: E402
from emdm.eval import kinematics as K  # noqa: E402
from emdm.eval import realism as R  # noqa: E402

# Real walking through prepare's pipeline: normal, tired and happy (1.0–1.4 m/s): the reference of the checks.
WALKS = ["dataset-1_walk_normal_001", "dataset-1_walk_tired_001", "dataset-1_walk_happy_001"]


def _flip(joints: np.ndarray, frame: int = 40, joint: int = 10, by: float = 0.4) -> np.ndarray:
    out = joints.copy()
    out[frame, joint, 2] += by                      # the left toe jumps 0.4 m ahead for one frame and comes back
    return out


@needs_bandai
def test_real_walk_passes_speed_and_jitter_and_the_broken_copies_fail():
    walks = [real_clip(s) for s in WALKS]
    speeds = [R.motion_row(w)["speed"] for w in walks]
    real_max = max(R.joint_steps(w).max() for w in walks)
    assert 1.0 < min(speeds) and max(speeds) < 1.5 and 0.15 < real_max < 0.3
    walk = walks[0]
    assert R.speed_in_range([R.motion_row(walk)["speed"]], speeds)[0]
    assert R.steps_ok(walk, real_max)
    fast = walk[::2]                                # every second frame: the same walk played 2× fast
    assert not R.speed_in_range([R.motion_row(fast)["speed"]], speeds)[0]
    assert not R.steps_ok(_flip(walk), real_max)
    assert R.speed_in_range([R.motion_row(_flip(walk))["speed"]], speeds)[0]   # a toe's flip leaves the root alone


@needs_bandai
def test_measure_sets_motions_against_the_real_reference():
    labels = ["walk", "wave-right-hand"]
    real_j = [real_clip(s) for s in WALKS] + [real_clip("dataset-2_wave-right-hand_active_001")]
    real = R.measure(labels, np.array([0, 0, 0, 1]), real_j)
    assert real["reference"]["max_step_all"] == pytest.approx(max(R.joint_steps(j).max() for j in real_j))
    assert real["per_action"]["walk"]["motions_over_all"] == 0.0 and real["per_action"]["walk"]["airborne"] == 0.0
    assert real["per_action"]["walk"]["speed_ratio"] == pytest.approx(1.0)
    walk = real_j[0]
    gen = R.measure(labels, np.array([0, 0, 0]), [walk[::2], _flip(walk), walk], real)
    g = gen["per_action"]["walk"]
    assert g["n"] == 3 and g["speed_in_range"] == pytest.approx(2 / 3)     # the 2× copy is out of range
    assert g["motions_over_all"] >= 1 / 3 and g["over_action"] > 0           # the flip (and perhaps the 2× copy)
    assert g["speed_ratio"] == pytest.approx(1.0)   # median of (2×, 1×, 1×) = the normal walk, the real median
    fast = R.measure(labels, np.array([0]), [walk[::2]], real)["per_action"]["walk"]
    assert fast["speed_ratio"] == pytest.approx(2 * R.motion_row(walk)["speed"] /
                                                real["per_action"]["walk"]["speed"], rel=0.05)
    assert "wave-right-hand" not in gen["per_action"]                        # no motions made for it: no row


@needs_bandai
def test_moving_tells_a_real_wave_from_the_same_figure_standing_still():
    """A wave whose hand never leaves its pose (its first frame held) is no wave, whatever a classifier reads from
    the pose: the real clip moves, the frozen copy and a copy moving 1/10 as much do not; a walk moves; a clip
    holding its first frame but for one second of the wave (one gesture in a few seconds: a throw) moves."""
    labels = ["walk", "wave-right-hand"]
    waves = [real_clip(s) for s in ("dataset-2_wave-right-hand_active_001", "dataset-2_wave-right-hand_normal_001")]
    walks = [real_clip(s) for s in WALKS]
    real = R.measure(labels, np.array([0, 0, 0, 1, 1]), walks + waves)
    wave = waves[0]
    frozen = np.repeat(wave[:1], len(wave), axis=0)
    tenth = wave[:1] + (wave - wave[:1]) * 0.1          # every joint's excursion from the first frame shrunk 10×
    once = frozen.copy()
    once[40:60] = wave[40:60]                           # the hand moves for one second, then snaps back to the pose
    once[60:] = wave[59]
    gen = R.measure(labels, np.array([1, 1, 1, 1, 0]), [wave, frozen, tenth, once, walks[1]], real)
    g = gen["per_action"]["wave-right-hand"]
    assert g["moving"] == pytest.approx(2 / 4)
    peak = lambda j: K.descriptors(j)["peak_speed"]    # noqa: E731
    ref = real["reference"]["peak_speed"]["wave-right-hand"]
    assert peak(frozen) == 0.0
    assert R.moving([peak(wave), peak(once)], ref).all() and not R.moving([peak(tenth)], ref)[0]
    assert gen["per_action"]["walk"]["moving"] == 1.0
    assert gen["per_action"]["walk"]["peak_ratio"] == pytest.approx(peak(walks[1]) / np.median([peak(w) for w in walks]))


@needs_bandai
def test_feet_acceleration_is_the_real_walks_own_and_grows_where_a_foot_is_held_and_then_thrown():
    """The feet's acceleration (95th percentile): a real walk against its own action is × 1; played 2× fast its
    feet accelerate 2.5–4.5× as hard (4× were the motion smooth, 3.2× measured); a foot held still for a stance and then thrown to where the walk has it (what
    pinning a skating stance does to the swing) accelerates harder than the real walk's."""
    labels = ["walk"]
    walks = [real_clip(s) for s in WALKS]
    real = R.measure(labels, np.array([0, 0, 0]), walks)
    assert real["per_action"]["walk"]["foot_acc_ratio"] == pytest.approx(1.0)
    walk = walks[0]
    own = R.foot_acceleration(walk)
    assert 10 < own < 60                                            # m/s²: a real walk's feet
    assert 2.5 * own < R.foot_acceleration(walk[::2]) < 4.5 * own       # 3.2× (4× were it smooth)
    held = walk.copy()
    for s in range(0, len(walk) - 12, 12):                          # every 12 frames: the left foot held 9 frames
        held[s:s + 9, [7, 10], :] = walk[s, [7, 10], :]
    assert R.foot_acceleration(held) > 1.5 * own
    g = R.measure(labels, np.array([0]), [held], real)["per_action"]["walk"]
    assert g["foot_acc_ratio"] > 1.5 and R.foot_acceleration(walk[:2]) == 0.0


def test_an_action_with_too_few_test_clips_takes_its_moving_floor_from_its_train_clips():
    ref = {"peak_speed": {"walk": [4.0, 4.2, 3.9], "punch": [2.0]}}
    desc = {"peak_speed": np.array([1.0, 2.5, 2.2, 2.4, 5.0, 0.9])}
    R.train_peaks(ref, ["walk", "punch", "jump"], np.array([0, 1, 1, 1, 0, 2]), desc)
    assert ref["peak_speed"]["walk"] == [4.0, 4.2, 3.9]                  # enough test clips: kept
    assert ref["peak_speed"]["punch"] == [2.5, 2.2, 2.4]                 # 1 test clip: its 3 train clips instead
    assert "jump" not in ref["peak_speed"] and ref["peak_from_train"] == ["punch"]   # 1 train clip: none


def test_cli_writes_the_json_and_the_report_renders_it(world, capsys):
    from emdm.eval import report

    root, ds = world
    out = root / "results" / "json" / "realism-t2m.json"
    assert R.main(_args(root, ds, out, "--ckpt", str(root / "t2m" / "ckpt.pt"), "--steps", "2")) == 0
    r = json.loads(out.read_text())
    assert r["task"] == "realism" and r["schema"] == 1 and r["steps"] == 2
    assert r["generated"]["n"] == 3 * 4 * 2 and r["real"]["n"] == 13                # actions × prompts × seeds; test clips
    assert set(r["generated"]["per_action"]) == set(r["labels"]) and "walk" in r["rules"]
    for a, g in r["generated"]["per_action"].items():
        assert g["n"] == 8 and 0 <= g["motions_over_all"] <= 1 and g["step_p99"] > 0
        assert 0 <= r["generated"]["classifier"][a] <= 1
    assert set(r["judged"]) <= set(r["rules"]) and set(r["generated"]["kinematic"]) == set(r["labels"]) & set(K.RULES)
    assert "motions" in capsys.readouterr().out
    # a second setting beside it, through the command line (the prompts' embeddings are in the run's cache): the
    # report shows both and the side-by-side table
    out0 = out.with_name("realism-t2m-x0s0.json")
    cmd = [sys.executable, "-m", "emdm.eval.realism", *_args(root, ds, out0, "--ckpt", str(root / "t2m" / "ckpt.pt"),
                                                             "--steps", "2", "--x0-smoothing", "0", "--name", "t2m-x0s0")]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=paths.REPO_ROOT,
                          env={**os.environ, "PYTHONPATH": str(paths.REPO_ROOT / "scripts")})
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads(out0.read_text())["x0_smoothing"] == 0 and "wrote" in done.stdout
    md = root / "RESULTS.md"
    assert report.main(["--results", str(root / "results"), "--out", str(md)]) == 0
    text = md.read_text()
    assert "## Realism per action" in text and "### Side by side" in text and "### Kinematic rules" in text
    assert "| Action | Real clips | Speed m/s (real) |" in text and "| walk |" in text
    assert (root / "results" / "realism-t2m.png").is_file() and (root / "results" / "realism-t2m-x0s0.png").is_file()
    assert "Each column's classifier" not in text, "one classifier judged both"
    # a result judged by another classifier (older weights, not measured again): the table says which judged which
    other = json.loads(out0.read_text())
    other["classifier"].update(summary="ActionClassifier trained before the relabel", sha256="0" * 16)
    lines = R.comparison([r, other])
    assert f"Each column's classifier is its own result's: {r['name']}: {r['classifier']['summary']}; t2m-x0s0: " \
           "ActionClassifier trained before the relabel." in lines[2]
    # judges are told apart by their files, not their words: two files of one summary are named by sha256
    twin = {**other, "classifier": {**r["classifier"], "sha256": "f" * 16}}
    lines = R.comparison([r, twin])
    assert f"{r['name']}: {r['classifier']['summary']} (sha256 {r['classifier']['sha256']}); t2m-x0s0: " \
           f"{r['classifier']['summary']} (sha256 {'f' * 16})." in lines[2]
    assert "Each column's classifier" not in R.comparison([r, {**other, "classifier": r["classifier"]}])[2]


def test_cli_names_a_missing_classifier(world, capsys):
    root, ds = world
    args = _args(root, ds, root / "none.json", "--ckpt", str(root / "t2m" / "ckpt.pt"))
    args[args.index("--classifier") + 1] = str(root / "missing.pt")
    assert R.main(args) == 2
    assert "missing.pt" in capsys.readouterr().err and not (root / "none.json").exists()
