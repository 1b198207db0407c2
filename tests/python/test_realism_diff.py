"""python -m emdm.eval.realism_diff: two realism results per action on the three checks, a drop flagged."""

import json

from emdm.eval import realism_diff as D


def _result(cls: float, kin: float, moving: float, key=None) -> dict:
    return {"task": "realism", "key": key or {"seeds": 8}, "generated": {
        "classifier": {"punch": cls, "walk": 0.9}, "kinematic": {"walk": kin},
        "per_action": {"punch": {"moving": moving, "speed_ratio": 1.1}, "walk": {"moving": 1.0, "speed_ratio": 1.0}}}}


def test_a_classifier_gain_with_punches_that_stop_moving_is_flagged(tmp_path, capsys):
    old, new = _result(0.59, 0.8, 0.9), _result(0.75, 0.8, 0.0)
    rows = {r["action"]: r for r in D.diff(old, new)}
    assert rows["punch"]["worse"] == ["moving"] and rows["punch"]["better"] == ["classifier"]
    assert rows["walk"]["worse"] == [] and rows["walk"]["better"] == []
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    a.write_text(json.dumps(old))
    b.write_text(json.dumps(new))
    assert D.main([str(a), str(b)]) == 0
    assert D.main([str(a), str(b), "--fail-on-worse"]) == 1
    assert D.main([str(a), str(a), "--fail-on-worse"]) == 0
    out = capsys.readouterr().out
    assert "actions worse by more than 1 motion in 8 on a check: punch" in out
    assert "worse: moving; better: classifier" in out


def test_one_motion_in_eight_is_within_the_bar_and_other_benchmarks_are_named(tmp_path, capsys):
    rows = D.diff(_result(0.5, 0.8, 1.0), _result(0.375, 0.8, 1.0))       # exactly 1/8 lower: not worse
    assert all(not r["worse"] for r in rows)
    a, b, bad = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    a.write_text(json.dumps(_result(0.5, 0.8, 1.0)))
    b.write_text(json.dumps(_result(0.5, 0.8, 1.0, key={"seeds": 4})))
    bad.write_text(json.dumps({"task": "coverage"}))
    assert D.main([str(a), str(b)]) == 0
    assert "note: the two runs differ in seeds: 8 → 4" in capsys.readouterr().err
    listed = tmp_path / "list.json"
    listed.write_text("[]")
    half = tmp_path / "half.json"
    half.write_text(json.dumps({"task": "realism", "generated": {"classifier": {}}}))
    for f in (listed, half):
        assert D.main([str(a), str(f)]) == 2
    capsys.readouterr()
    assert D.main([str(a), str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "c.json" in err[0] and "not a realism result" in err[0]


def test_the_feet_lines_show_what_a_clean_up_trades_and_skip_what_a_result_lacks():
    old, new = _result(0.5, 0.8, 1.0), _result(0.5, 0.8, 1.0)
    old["generated"]["all"] = {"skate_cm_s": 23.28, "max_step": 0.45}                 # measured before foot_acc
    new["generated"]["all"] = {"skate_cm_s": 17.8, "foot_acc": 31.4, "max_step": 0.499}
    new["real"] = {"all": {"skate_cm_s": 19.26, "foot_acc": 27.0, "max_step": 0.55}}
    assert D.feet(old, new) == ["all motions' foot skate: 23.3 → 17.8 cm/s (real clips 19.3)",
                                "all motions' largest joint step: 0.450 → 0.499 m (real clips 0.550)"]
    new_b = json.loads(json.dumps(new))
    new_b["generated"]["all"]["foot_acc"] = 40.0
    assert "all motions' feet acceleration: 31 → 40 m/s² (real clips 27)" in D.feet(new, new_b)
    assert D.feet(_result(0.5, 0.8, 1.0), _result(0.5, 0.8, 1.0)) == []               # no "all" rows: nothing


def test_the_rules_lines_name_what_a_failing_rule_misses_against_the_real_clips():
    """A wave that raises the hand and holds it still: the rule's wrist-speed condition is named with the real
    clips' median; conditions the median motion meets, actions passing in most motions and results without the
    descriptor medians (measured before them) are left out."""
    old, new = _result(0.5, 0.8, 1.0), _result(0.5, 0.8, 1.0)
    new["generated"]["kinematic"] = {"wave-right-hand": 0.0, "walk": 1.0, "bow": 0.25}
    new["generated"]["per_action"]["wave-right-hand"] = {"desc": {"hand_up_r": 0.3, "hand_up_l": -0.5, "wave_r": 0.07,
                                                                 "leg_speed": 0.05}}
    new["generated"]["per_action"]["walk"]["desc"] = {"speed": 0.1, "forward": 1.0}       # passes in most: not named
    new["real"] = {"per_action": {"wave-right-hand": {"desc": {"wave_r": 1.9}}}}
    old["generated"]["per_action"]["wave-right-hand"] = {"desc": {"wave_r": 0.05}}
    assert D.rules(old, new) == ["wave-right-hand (rule passed by 0.00) misses wave_r >= 0.2: real 1.90, 0.05 → 0.07"]
    del old["generated"]["per_action"]["wave-right-hand"]["desc"]
    assert D.rules(old, new) == ["wave-right-hand (rule passed by 0.00) misses wave_r >= 0.2: real 1.90, – → 0.07"]
    assert D.rules(new, old) == []                       # bow fails but has no medians; old has no kinematic failures
