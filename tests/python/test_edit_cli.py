"""`python -m emdm.sample` beyond one prompt: --timeline / --timeline-json, --inbetween, --edit-upper/--edit-lower,
--loop [--in-place] on the shipped action model (few steps), and their bad arguments (one line, exit 2, nothing
written)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from emdm import paths
from emdm.mocap.bvh import read_bvh
from emdm.motion.features import recover_joints
from emdm.sample import main as sample_main

BASE = ["--model", "emdm-a2m-web", "--steps", "2"]


@pytest.fixture(scope="module")
def shipped():
    man = paths.MODELS_DIR / "manifest.json"
    if not man.is_file() or "emdm-a2m-web" not in json.loads(man.read_text())["models"]:
        pytest.skip("emdm-a2m-web is not shipped in public/models")


@pytest.fixture(scope="module")
def long(shipped, tmp_path_factory):
    """A 3-segment timeline (2 + 1.5 + 2.5 s) written by the CLI."""
    out = tmp_path_factory.mktemp("tl") / "long"
    assert sample_main([*BASE, "--timeline", "walk:2", "--timeline", "wave-both-hands:1.5", "--timeline", "run:2.5",
                        "--seed", "4", "--out", str(out)]) == 0
    return out


def test_a_timeline_is_one_motion_with_every_segments_frames(long):
    joints, feats = np.load(long.with_suffix(".npy")), np.load(long.with_suffix(".features.npy"))
    assert joints.shape == (120, 22, 3) and feats.shape == (120, 263)
    assert read_bvh(long.with_suffix(".metres.bvh")).num_frames == 120
    assert np.abs(joints - recover_joints(feats)).max() < 1e-4                  # stitched = decoded whole: no seam jump


def test_a_30_s_timeline_of_10_s_segments_is_one_bvh_of_600_frames(shipped, tmp_path):
    out = tmp_path / "thirty"
    assert sample_main(["--model", "emdm-a2m-web", "--steps", "1", "--timeline", "walk:10", "--timeline", "run:10",
                        "--timeline", "wave-both-hands:10", "--out", str(out)]) == 0
    assert np.load(out.with_suffix(".npy")).shape == (600, 22, 3)
    assert read_bvh(out.with_suffix(".metres.bvh")).num_frames == 600


def test_the_same_timeline_from_json_with_explicit_seeds(long, tmp_path):
    spec = tmp_path / "t.json"
    spec.write_text(json.dumps([{"prompt": "walk", "seconds": 2, "seed": 4}, {"prompt": "wave-both-hands", "seconds": 1.5, "seed": 5},
                                {"prompt": "run", "seconds": 2.5, "seed": 6}]))
    assert sample_main([*BASE, "--timeline-json", str(spec), "--no-bvh", "--out", str(tmp_path / "j")]) == 0
    assert np.array_equal(np.load(tmp_path / "j.features.npy"), np.load(long.with_suffix(".features.npy")))


def test_inbetween_and_body_edits_of_a_written_motion(long, tmp_path):
    feats = np.load(long.with_suffix(".features.npy"))[:100]
    np.save(tmp_path / "k.features.npy", feats)
    want = recover_joints(feats)
    known = ["--known", str(tmp_path / "k.features.npy"), "--no-bvh", "--seed", "8"]
    assert sample_main([*BASE, *known, "--inbetween", "--action", "jump", "--out", str(tmp_path / "mid")]) == 0
    mid = np.load(tmp_path / "mid.npy")
    assert mid.shape == (100, 22, 3)
    assert np.abs(mid[:20] - want[:20]).max() < 1e-3 and np.abs(mid[80:] - want[80:]).max() < 1e-3   # ≤ 1 mm
    assert np.abs(mid[20:80] - want[20:80]).max() > 1e-2
    assert sample_main([*BASE, *known, "--inbetween", "30-59", "--action", "jump", "--out", str(tmp_path / "mid2")]) == 0
    mid2 = np.load(tmp_path / "mid2.npy")
    assert np.abs(mid2[:30] - want[:30]).max() < 1e-3 and np.abs(mid2[60:] - want[60:]).max() < 1e-3
    assert sample_main([*BASE, *known, "--edit-upper", "--action", "wave-both-hands", "--out", str(tmp_path / "up")]) == 0
    legs = [0, 1, 2, 4, 5, 7, 8, 10, 11]
    up = np.load(tmp_path / "up.npy")
    assert np.abs(up[:, legs] - want[:, legs]).max() < 1e-3 and np.abs(up - want).max() > 1e-2
    assert sample_main([*BASE, *known, "--edit-lower", "--action", "run", "--out", str(tmp_path / "low")]) == 0
    low = np.load(tmp_path / "low.features.npy")
    np.testing.assert_allclose(low[:, 67 + 6 * 8: 67 + 6 * 9], feats[:, 67 + 6 * 8: 67 + 6 * 9], rtol=1e-5, atol=1e-5)  # spine3


def test_loops_from_a_prompt_and_from_a_known_motion(shipped, tmp_path):
    assert sample_main([*BASE, "--action", "walk", "--frames", "60", "--loop", "--in-place", "--out", str(tmp_path / "c")]) == 0
    clip = np.load(tmp_path / "c.npy")
    assert clip.shape == (50, 22, 3) and np.abs(clip[:, 0, [0, 2]]).max() == 0          # in place: no travel
    assert read_bvh(tmp_path / "c.metres.bvh").num_frames == 50
    feats = np.load(tmp_path / "c.features.npy")
    assert sample_main([*BASE, "--known", str(tmp_path / "c.features.npy"), "--action", "walk", "--loop", "--no-bvh",
                        "--out", str(tmp_path / "c2")]) == 0
    assert np.load(tmp_path / "c2.npy").shape == (40, 22, 3)
    assert np.abs(np.load(tmp_path / "c2.features.npy")[:10, 3:67] - feats[:10, 3:67]).max() < 1e-4


@pytest.mark.parametrize("args, says", [
    (["--timeline", "walk:2", "--timeline", "run:0"], r"--timeline: segment 2 \('run'\): 0 s is too short"),
    (["--timeline", "walk:8.8"] * 6 + ["--timeline", "run:8.2"], r"--timeline: the timeline lasts 61 s in all; at most 60 s"),
    (["--timeline", "walk:2", "--timeline", " :2"], r"--timeline: segment 2: the prompt is empty"),
    (["--timeline", "walk"], r"--timeline: segment 'walk': expected PROMPT:SECONDS"),
    (["--timeline", "fly:2"], r"--timeline: segment 1 \('fly'\): unknown action 'fly'"),
    (["--timeline", "walk:2", "--action", "run"], r"--timeline gives each segment its prompt and seconds; leave out --action"),
    (["--timeline", "walk:2", "--timeline-json", "{known}"], r"--timeline or with --timeline-json, not both"),
    (["--timeline-json", "{known}"], r"--timeline-json: .*k.features.npy: not a JSON text file"),
    (["--timeline", "walk:2", "--loop"], r"--timeline and --loop cannot be combined"),
    (["--action", "walk", "--in-place"], r"--in-place needs --loop"),
    (["--action", "walk", "--inbetween"], r"--inbetween needs --known PATH.features.npy"),
    (["--known", "{known}", "--inbetween", "--uncond"], r"--inbetween regenerates from a prompt: give exactly one of --text or --action"),
    (["--known", "{known}", "--inbetween", "0-10", "--action", "run"], r"--inbetween '0-10': give the frames to regenerate as A-B with 1 ≤ A ≤ B"),
    (["--known", "{known}", "--inbetween", "10-39", "--action", "run"], r"--inbetween 10-39: frame 39 is not before --known's last frame 39"),
    (["--known", "{known}", "--inbetween", "--action", "run"], r"--inbetween: in-betweening: kept frames 0..19 and 20..39 leave no frame"),
    (["--known", "{known}", "--edit-upper", "--action", "run", "--keep", "group:legs"], r"--edit-upper builds its own keep mask"),
    (["--known", "{known}", "--edit-upper", "--action", "run", "--frames", "30"], r"--edit-upper keeps --known's length; leave out --frames"),
    (["--known", "{known}", "--edit-lower", "--action", "run", "--num", "2"], r"--edit-lower makes one motion; --num must be 1, got 2"),
    (["--known", "{known}", "--loop", "--action", "run", "--edit-upper"], r"--edit-upper and --loop cannot be combined"),
])
def test_bad_edit_arguments_exit_2_with_one_line_and_write_nothing(shipped, tmp_path, capsys, args, says):
    np.save(tmp_path / "k.features.npy", np.zeros((40, 263), np.float32))
    args = [a.format(known=tmp_path / "k.features.npy") for a in args]
    rc = sample_main([*BASE, "--out", str(tmp_path / "o" / "x"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("error: "), err
    assert re.search(says, err[0]), err[0]
    assert not (tmp_path / "o").exists()
