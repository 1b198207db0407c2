"""Issue 28's bars per shipped generator (emdm.eval.realism_bars): the right results are picked (the shipped
weights at the page's settings, default and plain), and each bar's verdict is right on cases with a known answer."""

from emdm.eval import realism_bars as rb

ENTRY = {"defaultVariant": "int8", "defaultSteps": 10, "guidance": 1.5, "x0Smoothing": 1.0,
         "training": {"steps": 100, "continuedFrom": {"steps": 900}}}


def result(name, sigma=1.0, train_steps=1000, created="2026-11-27T08:00:00", walk=1.0, run=1.0, p99=0.2,
           over=0.0, cls=None, kin=None, seconds=90.0, variant="int8", guidance=1.5):
    cls = cls or {"walk": 1.0, "run": 1.0, "bow": 0.9}
    kin = kin or {"walk": 1.0, "run": 0.8}
    return {"task": "realism", "_file": f"realism-{name}.json", "name": name, "model": "m", "variant": variant,
            "steps": 10, "decode": "page", "x0_smoothing": sigma, "created": created, "hardware": "test CPU",
            "info": {"train_steps": train_steps, "guidance": guidance},
            "real": {"all": {"step_p99": 0.2}},
            "generated": {"per_action": {"walk": {"speed_ratio": walk}, "run": {"speed_ratio": run}},
                          "all": {"step_p99": p99, "over_all": over}, "classifier": cls, "kinematic": kin,
                          "seconds": seconds}}


def verdicts(default, plain):
    return [m for _, _, m in rb.bars(default, plain)]


def test_pick_takes_the_shipped_weights_at_the_page_settings_newest_first():
    old_weights = result("old", train_steps=500, created="2026-11-27T09:00:00")
    fp32 = result("fp32", variant="fp32", created="2026-11-27T09:00:00")
    other_guidance = result("g25", guidance=2.5, created="2026-11-27T09:00:00")
    older = result("older", created="2026-11-27T07:00:00")
    newest = result("newest", created="2026-11-27T08:30:00")
    plain = result("plain", sigma=0.0)
    default, p = rb.pick([old_weights, fp32, other_guidance, older, newest, plain], "m", ENTRY)
    assert default["name"] == "newest" and p["name"] == "plain"
    assert rb.pick([old_weights], "m", ENTRY) == (None, None)          # a retrained model: not measured yet
    # a model whose default is plain sampling: one file is both
    d, p = rb.pick([plain], "m", {**ENTRY, "x0Smoothing": None})
    assert d is p and d["name"] == "plain"
    # a speed cap is a page setting too: the default has the entry's, plain has neither smoothing nor cap
    capped = {**result("capped", created="2026-11-27T10:00:00"), "speed_cap": 1.0}
    capped_plain = {**result("capped-plain", sigma=0.0, created="2026-11-27T10:00:00"), "speed_cap": 1.0}
    d, p = rb.pick([newest, plain, capped, capped_plain], "m", {**ENTRY, "speedCap": 1.0})
    assert d["name"] == "capped" and p["name"] == "plain"
    d, p = rb.pick([newest, plain, capped, capped_plain], "m", ENTRY)        # no cap in the entry: as before
    assert d["name"] == "newest" and p["name"] == "plain"
    d, p = rb.pick([capped_plain, plain], "m", {**ENTRY, "x0Smoothing": None, "speedCap": 1.0})
    assert d["name"] == "capped-plain" and p["name"] == "plain"             # capped only: not plain any more


def test_speed_bars():
    assert verdicts(result("a"), result("p", sigma=0))[:2] == [True, True]
    assert verdicts(result("a", run=1.3), result("p", sigma=0))[:2] == [True, False]   # a run 1.3x too fast
    assert verdicts(result("a", walk=0.79), result("p", sigma=0))[:2] == [False, True]


def test_jitter_bars():
    assert verdicts(result("a", p99=0.31), None)[2] is False and verdicts(result("a", p99=0.29), None)[2] is True
    assert verdicts(result("a", over=0.002), None)[3] is False and verdicts(result("a", over=0.0005), None)[3] is True


def test_default_against_plain():
    default = result("a", cls={"walk": 1.0, "run": 0.75, "bow": 0.9})
    plain = result("p", sigma=0, cls={"walk": 1.0, "run": 1.0, "bow": 0.9})
    rows = rb.bars(default, plain)
    assert rows[4][2] is False and "0.25 (run)" in rows[4][1]                          # 2 motions in 8 worse
    ok = result("a", cls={"walk": 1.0, "run": 0.875, "bow": 0.9})
    assert rb.bars(ok, plain)[4][2] is True                                          # 1 in 8: within the bar
    assert rb.bars(default, None)[4][2] is None                                      # plain not measured
    assert rb.bars(plain, plain)[4][1] == "the default is plain sampling"
    assert rb.worst_drop(plain, default)["classifier"] == (0.0, None)                 # better is no drop


def test_time_bar_and_section():
    assert verdicts(result("a", seconds=660), None)[5] is False
    manifest = {"models": {"m": ENTRY, "n": {"defaultSteps": 10}}}
    text = "\n".join(rb.section([result("a", run=1.3), result("p", sigma=0.0)], manifest))
    assert "`realism-a.json` against `realism-p.json`" in text
    assert "| run: median speed within ±20 % of its real clips' | × 1.30 | **not met** |" in text
    assert "`n`: not measured on its current weights" in text
