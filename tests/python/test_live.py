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


def _page_run(**summary):
    s = {"seconds": 160, "promptsSent": 32, "latencies": 32, "latencyMedianS": 0.39, "latencyP95S": 0.4, "underruns": 0,
         "displayed": 4000, "repeated": 0,
         "frameGapMs": {"idle": {"p95": 20.0}, "live": {"p95": 30.0}, "idleAfter": {"p95": 25.0}}} | summary
    return {"_file": "live-x-page.json", "task": "live-page", "name": "live-x-page", "runtime": "Chromium 1", "threads": 2,
            "hardware": "2 cores", "load": 2.0, "steps": 10, "summary": s}


def _soak_run(**summary):
    s = {"minutes": 10, "promptsSent": 120, "heapMB": {"first": 30.0, "last": 31.0, "max": 33.0, "firstMinuteMean": 30.2,
         "lastMinuteMean": 31.4}, "heapGrowthMB": 1.2, "nodes": {"first": 1800, "last": 1850, "max": 1900}, "pelvisM": {"min": 0.7, "max": 1.1},
         "realPelvisM": {"min": 0.05, "max": 1.78, "source": "clips"}, "rootDistanceMaxM": 0.9, "underruns": 0,
         "displayed": 12000, "repeated": 0} | summary
    return {"_file": "live-x-soak.json", "task": "live-soak", "name": "live-x-soak", "runtime": "Chromium 1", "threads": 2,
            "hardware": "2 cores", "load": 2.0, "steps": 10, "summary": s}


def test_page_and_soak_rows_say_which_bars_are_met():
    from emdm.eval import live_section
    text = "\n".join(live_section.section([_page_run(), _soak_run()]))
    assert "| 10; W 40 | **0.39 / 0.40 s** over 32 of 32 prompts (met)" in text    # no settings recorded: W 40
    with_settings = _page_run(windowMsMedian=300) | {"live": {"window": 60}}
    assert "| 10; W 60, 300 ms median |" in live_section.page_row(with_settings)
    assert "**0** in 160 s (met)" in text
    assert "30.0 / 20.0, after 25.0 ms (1.50× the smaller idle)" in text
    assert "**+1.2 MB** (30.2 → 31.4; met)" in text
    assert "**0.70–1.10 m** (real 0.05–1.78 m; met) | 1800 → 1850 (max 1900) | 0.90 m |" in text
    assert "not met" not in text
    assert "| Result | Runtime | Steps; frames |" not in text      # no Node run: no Node table
    late = live_section.page_row(_page_run(latencyP95S=1.3, underruns=3))
    assert "**0.39 / 1.30 s** over 32 of 32 prompts (not met)" in late and "**3** in 160 s (not met)" in late
    grown = live_section.soak_row(_soak_run(heapGrowthMB=20.5, pelvisM={"min": 0.01, "max": 1.1}))
    assert "**+20.5 MB** (30.2 → 31.4; not met)" in grown
    assert "**0.01–1.10 m** (real 0.05–1.78 m; not met)" in grown


def test_report_reads_page_results_and_names_a_missing_summary_field(tmp_path):
    import json

    from emdm.eval import report
    for r in (_page_run(), _soak_run()):
        (tmp_path / r["_file"]).write_text(json.dumps({"schema": 1} | {k: v for k, v in r.items() if k != "_file"}))
    assert [r["task"] for r in report.load_results(tmp_path)] == ["live-page", "live-soak"]
    bad = _soak_run()
    del bad["summary"]["heapGrowthMB"]
    (tmp_path / "live-x-soak.json").write_text(json.dumps({"schema": 1} | {k: v for k, v in bad.items() if k != "_file"}))
    with pytest.raises(report.ReportError, match=r"live-x-soak.json: field 'summary' lacks 'heapGrowthMB'"):
        report.load_results(tmp_path)


def test_a_prompts_window_leaves_more_of_its_steps_to_the_new_prompt():
    import dataclasses

    from emdm.motion.edit import TIMELINE_KEEP_FROM

    model, seen = tiny_editor(), []

    class Spy(type(model)):
        def sample(self, prompt, frames, seed, known=None, keep=None, keep_from_time=1.0):
            seen.append((prompt, known is not None, keep_from_time))
            return super().sample(prompt, frames, seed, known, keep, keep_from_time)

    spy = Spy(**{f.name: getattr(model, f.name) for f in dataclasses.fields(model)})
    L.simulate(L.LiveCore(spy, "b", seed=3), 3 * L.WINDOW, [(L.WINDOW + 15, "e")], [6])   # "b" continued once first
    later = lambda p: [s[2] for s in seen if s[0] == p][1:]             # noqa: E731
    assert seen[0] == ("b", False, 1.0)                                   # the first window: nothing kept
    assert later("b") and set(later("b")) == {TIMELINE_KEEP_FROM}        # the same prompt continued
    assert next(s for s in seen if s[0] == "e") == ("e", True, L.PROMPT_KEEP_FROM) < ("e", True, TIMELINE_KEEP_FROM)
    assert later("e") and set(later("e")) == {TIMELINE_KEEP_FROM}
