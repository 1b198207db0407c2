"""The impossible-pose grid check (python -m emdm.eval.poses, issue 12): its three per-frame checks on the
reference skeleton, on bodies broken in each way, on real mocap (none flagged), the CLI's refusals, and the
grid of the page's settings on the shipped text model."""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from emdm import skeleton as sk
from emdm.eval import poses as P


def standing(frames: int = 4) -> np.ndarray:
    return np.repeat(sk.rest_pose()[None], frames, 0)


def test_the_reference_skeleton_is_possible():
    c = P.check_frames(standing())
    assert not c.impossible.any()
    assert c.worst_bone < 1e-9 and c.worst_leg <= 1.0 + 1e-9 and abs(c.lowest) < 1e-9


def test_a_stretched_bone_is_flagged_on_its_frame_only():
    j = standing()
    j[2, 20] = j[2, 18] + (j[2, 20] - j[2, 18]) * 1.5          # l_wrist: forearm 50 % longer on frame 2
    c = P.check_frames(j)
    assert c.bone.tolist() == [False, False, True, False] and not c.leg.any() and not c.floor.any()
    assert c.worst_bone == pytest.approx(0.5)


def test_an_ankle_no_straight_leg_reaches_is_flagged():
    # the left leg straight and 20 % longer (each bone 20 % off: under the bone bar), the body lifted so that
    # nothing is under the floor: only the leg check sees it (hip–ankle = 1.2 × thigh + shin)
    j = standing()
    hip = j[1, 1].copy()
    j[1, [4, 7, 10]] = hip + 1.2 * (j[1, [4, 7, 10]] - hip)
    j[1, :, 1] -= j[1, :, 1].min()
    c = P.check_frames(j)
    assert c.leg.tolist() == [False, True, False, False] and not c.bone.any() and not c.floor.any()
    assert c.worst_leg == pytest.approx(1.2, abs=0.01)      # the rest leg is 0.3 % short of straight


def test_a_body_below_the_floor_is_flagged():
    j = standing()
    j[3, :, 1] -= 0.2
    c = P.check_frames(j)
    assert c.floor.tolist() == [False, False, False, True] and c.lowest == pytest.approx(-0.2)
    j[3, :, 1] += 0.15                                        # 5 cm: within the tolerance
    assert not P.check_frames(j).floor.any()


@pytest.mark.parametrize("bad, msg", [(np.zeros((4, 21, 3)), "expected shape"),
                                      (np.full((4, 22, 3), np.nan), "non-finite position at frame 0")])
def test_bad_joints_are_refused(bad, msg):
    with pytest.raises(P.PosesError, match=msg):
        P.check_frames(bad)


def test_real_mocap_has_no_impossible_frame(real_dataset):
    files = sorted((real_dataset / "new_joints").glob("*.npy"))
    assert len(files) >= 10, f"{real_dataset}: only {len(files)} clips"
    row = P.setting_row(0, 1.0, 0.0, [np.load(f) for f in files])
    assert row.ok, f"real clips flagged: {row}"


def test_cli_writes_rows_and_exit_status(tmp_path, capsys):
    out = tmp_path / "grid.json"
    rc = P.main(["--steps", "10", "--guidance", "2.5", "--seconds", "2", "--seeds", "1",
                 "--prompts", "a person walks forward", "--json", str(out)])
    assert rc == 0, capsys.readouterr()
    data = json.loads(out.read_text())
    assert data["model"] == "emdm-t2m-web" and len(data["rows"]) == 1
    assert data["rows"][0]["motions"] == 1 and data["rows"][0]["ok"] is True
    assert not list(tmp_path.glob("*.tmp"))


@pytest.mark.parametrize("args, msg", [
    (["--steps", "3"], "--steps 3: the model supports"),
    (["--seconds", "12"], "--seconds 12.0: lengths must be in"),
    (["--guidance", "nan"], "finite and ≥ 1"),
    (["--seeds", "0"], "--seeds 0"),
    (["--model", "emdm-a2m-web", "--actions", "fly"], "unknown action 'fly'"),
    (["--model", "no-such-model"], "no-such-model"),
])
def test_cli_refuses_bad_requests_in_one_line(args, msg, capsys):
    assert P.main(args) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error:") and msg in err and "\n" not in err


@pytest.mark.xfail(strict=True, reason="issues 12, 27: since GPU slice 4 the shipped emdm-t2m-web passes every setting "
                   "of this grid but one step guided (1.5, the page's default, and 6), whose last x̂0 guidance "
                   "extrapolates past the conditional one (bones up to 1.8× and 8× their length; the joints 12-23 cm "
                   "under the floor at 10 steps are gone); sampling that step unguided stills 11 actions "
                   "(docs/MODELS.md, 'Slice 4'); once the model passes this, the marker goes")
def test_shipped_text_model_gives_no_impossible_pose_on_the_page_grid():
    from emdm.model.open import open_model

    opened = open_model("emdm-t2m-web")
    rows = P.run_grid(opened, [1, 2, 10], [1.0, 1.5, 6.0], [2.0, 9.8], 2, P.conditions(opened, P.PROMPTS, None),
                      log=lambda *_: None)
    bad = [r for r in rows if not r.ok]
    assert not bad, "; ".join(f"{r.steps} steps, guidance {r.guidance:g}, {r.seconds:g} s: {r.failed_motions}/"
                              f"{r.motions} motions" for r in bad)
