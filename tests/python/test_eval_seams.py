"""emdm.eval.seams: the measures of seams and loops (pure functions on joints) and the command's bad input."""

import numpy as np
import pytest

from emdm.eval import seams as S
from emdm.eval.report import load_results
from emdm.motion.synthetic import synthetic_walk


def _walk() -> np.ndarray:
    return synthetic_walk(60, turn_per_frame=0.0)                     # a smooth walk, 3.5 m straight on


def test_a_pop_at_a_seam_is_seen_against_the_motion_elsewhere():
    j = _walk()
    smooth = S.seam_figures(j, [20])[0]
    popped = j.copy()
    popped[20:, 20] += [0.3, 0, 0]                                     # the right wrist jumps 0.3 m at frame 20
    pop = S.seam_figures(popped, [20])[0]
    assert pop["step_ratio"] > 1.5 > smooth["step_ratio"] and pop["acc_ratio"] > 1.5 * 3 > 3 * smooth["acc_ratio"]
    assert pop["acc_p95"] == pytest.approx(smooth["acc_p95"])         # frames near the seam are not "elsewhere"


def test_gait_is_measured_relative_to_the_pelvis_so_in_place_keeps_it_and_travel_goes():
    j = _walk()
    still = j.copy()
    still[..., [0, 2]] -= j[:, :1, [0, 2]]                             # every frame's pelvis x/z back to the origin
    g, h = S.gait(j), S.gait(still)
    assert g["travel"] > 1.5 and h["travel"] < 1e-6
    assert h["stride"] == pytest.approx(g["stride"], rel=1e-6) and h["lift"] == pytest.approx(g["lift"], rel=1e-6)
    assert g["stride"] > 0.1 and g["lift"] > 0.01


def test_the_wrap_of_a_loop_is_its_last_frame_to_its_first_carried_on():
    j = _walk()
    clip = np.concatenate([j[:10], j[9::-1]])                           # there and back: the wrap is a small step
    assert S.wrap_step(clip) <= S.joint_steps(clip).max()
    assert S.wrap_step(j) > 0.2                                         # a walk cut anywhere: a jump back


def test_bad_prompts_file_is_one_line_and_exit_2(tmp_path, capsys):
    bad = tmp_path / "prompts.json"
    bad.write_text("[1, 2]")
    assert S.main(["--prompts", str(bad), "--out", str(tmp_path / "out.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--prompts" in err and str(bad) in err
    assert not (tmp_path / "out.json").exists()


def test_the_committed_results_render_in_results_md():
    from emdm.eval.report import RESULTS_DIR
    rs = [r for r in load_results(RESULTS_DIR / "json") if r["task"] == "seams"]
    assert rs, "docs/results/json/seams-*.json: run python -m emdm.eval.seams"
    lines = S.section(rs)
    assert lines[1 + len(rs)].startswith("| `") and lines[2 + len(rs)] == ""
    assert all(r["_file"] in "".join(lines[:2 + len(rs)]) for r in rs)
    live = [r for r in rs if r.get("live")]
    assert live, "no committed seams result has a live session: run python -m emdm.eval.seams"
    text = "\n".join(lines[3 + len(rs):])
    assert all(f"| `{r['_file']}` |" in text for r in live) and "Per action, live / alone" in text
