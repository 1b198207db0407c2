"""emdm.motion.live (the live stream's Python twin; its parity with src/live is tests/unit/liveParity.test.ts on the
tiny-live fixture): bad input is one EditError, a stalled generator plays the motion back (never a repeated frame)."""

import numpy as np
import pytest

from emdm.motion import live as L
from emdm.motion.edit import EditError
from emdm.motion.edit_fixture import tiny_editor


def test_bad_input_is_one_edit_error():
    model = tiny_editor()
    with pytest.raises(EditError, match="live: the prompt is empty"):
        L.LiveCore(model, "  ")
    core = L.LiveCore(model, "b")
    with pytest.raises(EditError, match="live: the prompt is empty"):
        core.new_prompt("", 0)
    with pytest.raises(EditError, match="exceeds the model's 196"):
        L.LiveCore(model, "b", window=180)


def test_a_stalled_generator_plays_the_motion_back_never_a_repeated_frame():
    core = L.LiveCore(tiny_editor(), "b", seed=3)
    sim = L.simulate(core, 200, [], [10_000])        # the second window never arrives in 200 frames
    assert core.underruns > 0
    steps = np.abs(np.diff(sim.joints, axis=0)).max(axis=(1, 2))
    assert (steps > 0).all(), f"frames {np.nonzero(steps == 0)[0] + 1} repeat the one before"
    assert [w[0].id for w in sim.windows] == [1]


def test_results_row_says_which_bars_are_met():
    from emdm.eval import live_section
    run = {"_file": "live-x.json", "name": "live-x", "runtime": "node", "hardware": "2 cores", "load": 2.0, "steps": 10,
           "variant": "int8", "live": {"window": 40, "lead": 30, "promptLead": 8}, "windowCost": {"40": [200, 250]},
           "random": {"latencies": [0.3, 0.4, 1.2]},
           "steady": {"seconds": 120, "prompts": 23, "stats": {"underruns": 2}},
           "seams": {"ratios": [0.5, 1.6], "p95": [60.0], "repeated": [0]}}
    row = live_section.row(run)
    assert "**0.40 / 1.12 s** over 3 prompts (not met)" in row     # p95 over 1 s
    assert "**2** in 120 s, 23 prompts (not met)" in row
    assert "**1/2** (max 1.60×" in row
    run["random"]["latencies"] = [0.3, 0.4, 0.45]
    run["steady"]["stats"]["underruns"] = 0
    assert "(met)" in live_section.row(run) and "not met" not in live_section.row(run)
