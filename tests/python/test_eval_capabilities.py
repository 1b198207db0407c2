"""The shipped capabilities file (emdm.eval.capabilities, issue 30): which prompts a model does well, the unknown-prompt
check the page, the library and the CLI share, and its calibration on prompts the file was not built from."""

import json
import shutil

import numpy as np
import pytest

from emdm import manifest as mf
from emdm.eval import capabilities as C
from emdm.eval.coverage import PROMPTS_FILE, load_prompts, normalise, read_result
from emdm.eval.results import RESULTS_DIR
from emdm.paths import REPO_ROOT
from emdm.sample import main as sample_main
from emdm.text import encode_texts

T2M, A2M = "emdm-t2m-web", "emdm-a2m-web"


@pytest.fixture(scope="module")
def caps():
    c = C.load(T2M)
    assert c is not None, f"public/models/{C.file_name(T2M)} missing or stale: python -m emdm.eval.capabilities --model {T2M}"
    return c


def test_far_prompts_are_unknown_and_get_three_working_suggestions(caps):
    chips = set(read_result(RESULTS_DIR / "json" / f"coverage-{T2M}.json")["chips"]["prompts"])
    for p in ["a person kicks", "dances", "swims", "a person does a cartwheel", "plays the guitar"]:
        r = C.check(caps, encode_texts([p])[0])
        assert not r["known"], (p, r)
        assert len(r["nearest"]) == 3 and set(r["nearest"]) <= chips, r
        assert C.notice(r).startswith("this prompt is far from what the model does well")


def test_covered_prompts_are_known(caps):
    for p in ["a person walks", "a person walks forward", "a person raises the left hand", "a person is running",
              "a person bows", "a person throws a ball"]:
        r = C.check(caps, encode_texts([p])[0])
        assert r["known"] and r["covered"] and C.notice(r) is None, (p, r)


def test_prompts_for_an_uncovered_action_find_it_and_are_warned(caps):
    """Schema 2: a prompt for an action the model does not do, close to a covered action's captions ("a person jumps"
    scored 0.79 against climb's under schema 1 and passed, when jump was not covered; "a person waves the right hand"
    is close to the covered raise-right-hand), finds its own action's anchors and is warned by name."""
    cover = {r["label"]: r["covered"] for r in caps["actions"]}
    assert cover["jump"] and cover["raise-right-hand"]                    # jump since GPU slice 5
    assert not cover["hop"] and not cover["kick"] and not cover["dance"] and not cover["punch"]
    assert not cover["wave-right-hand"]
    # punch: recognised by the classifier from a boxer's guard that never throws a fist (realism: no punch moves)
    for p, action in [("a person hops on one foot", "hop"), ("a person kicks", "kick"), ("dances", "dance"),
                      ("a person punches", "punch"), ("a person waves the right hand", "wave-right-hand")]:
        r = C.check(caps, encode_texts([p])[0])
        assert not r["known"] and r["action"] == action and not r["covered"], (p, r)
        assert f"it reads as {action.replace('-', ' ')}, which the model does not do well yet" in C.notice(r), C.notice(r)
        assert len(r["nearest"]) == 3 and all(cover[a] for a in
                                              (caps["anchors"]["actions"][caps["anchors"]["texts"].index(n)] for n in r["nearest"]))


def test_a_wave_is_offered_the_raised_hands_a_kick_its_nearest_prompts(caps):
    """A prompt read as an uncovered action with a close covered relative (RELATED) is led by it: "a person waves" was
    offered a bow, a walk and a run, "a person waves goodbye" three walks. A kick has no relative close enough
    (sneak's captions, 0.70) and keeps the prompt's own nearest."""
    raised = {"raise-both-hands", "raise-left-hand", "raise-right-hand"}
    of = dict(zip(caps["anchors"]["texts"], caps["anchors"]["actions"]))
    for p, lead in [("a person waves", 3), ("someone waves at a friend", 3), ("a person waves goodbye", 2)]:
        r = C.check(caps, encode_texts([p])[0])
        assert r["action"].startswith("wave") and not r["known"], (p, r)
        assert {of[n] for n in r["nearest"][:lead]} <= raised, (p, r)
    e = encode_texts(["a person kicks"])[0]
    r = C.check(caps, e)
    cos = C.dequantise(np.frombuffer(__import__("base64").b64decode(caps["anchors"]["embeddings"]), np.int8)
                       .reshape(len(caps["anchors"]["texts"]), -1)) @ e
    chips = [i for i in np.argsort(-cos, kind="stable") if caps["anchors"]["suggest"][i]]
    first = list(dict.fromkeys(caps["anchors"]["actions"][i] for i in chips))[:3]
    assert [of[n] for n in r["nearest"]] == first


def test_the_examples_cover_the_parity_cases(caps):
    """The file's examples (which tests/unit/capabilities.test.ts replays in TS) hold the cases both runtimes must agree
    on, with the answers this side gives now."""
    want = {"a person jumps": True, "someone jumps up and down": True, "a person walks": True,
            "a person raises the left hand": True, "a person bows": True, "a person punches": False,
            "a person kicks": False, "dances": False, "swims": False, "a person waves": False,
            "a person hops on one foot": False, "a person waves goodbye": False}
    ex = {e["prompt"]: e for e in caps["examples"]}
    assert {p: ex[p]["known"] for p in want} == want
    for e in caps["examples"]:
        assert C.check(caps, encode_texts([e["prompt"]])[0]) == {k: v for k, v in e.items() if k != "prompt"}, e


def test_held_apart_paraphrases_are_not_anchors_and_the_calibration_is_recorded(caps):
    prompts = load_prompts(PROMPTS_FILE, [r["label"] for r in caps["actions"]])
    _, held = C.build_split(prompts)
    anchors = {normalise(t) for t in caps["anchors"]["texts"]}
    assert not anchors & {normalise(p) for ps in held.values() for p in ps}
    covered = {r["label"] for r in caps["actions"] if r["covered"]}
    assert set(caps["anchors"]["actions"]) == {r["label"] for r in caps["actions"]}      # uncovered actions too
    assert all(a in covered for a, s in zip(caps["anchors"]["actions"], caps["anchors"]["suggest"]) if s)   # chips
    c = caps["check"]
    assert c["falseWarnings"]["n"] == sum(len(held[a]) for a in covered)
    assert c["misses"]["n"] == sum(len(held[a]) for a in prompts if a not in covered)
    # the recorded rates are what the threshold gives on the shipped (int8) anchors, under the nearest-action rule
    vecs = C.dequantise(np.frombuffer(__import__("base64").b64decode(caps["anchors"]["embeddings"]), np.int8)
                        .reshape(len(caps["anchors"]["texts"]), -1))
    of_covered = np.array([a in covered for a in caps["anchors"]["actions"]])
    s = C.scores(vecs, of_covered, encode_texts([p for a in sorted(covered) for p in held[a]]))
    assert int((s < c["threshold"]).sum()) == c["falseWarnings"]["warned"]
    s = C.scores(vecs, of_covered, encode_texts([p for a in sorted(prompts) if a not in covered for p in held[a]]))
    assert int((s >= c["threshold"]).sum()) == c["misses"]["notWarned"]


def test_everyday_prompts_outside_the_vocabulary_are_warned_and_counted(caps):
    """A visitor's "a person rides a bicycle" or "plays the piano" is no action of the dataset: the shipped check warns
    each of the 30 held-apart ones, and the file records it (a third of the threshold's calibration)."""
    outside = C.load_outside()
    assert len(outside) == caps["check"]["outside"]["n"] == 30
    anchors = {normalise(t) for t in caps["anchors"]["texts"]}
    assert not anchors & {normalise(p) for p in outside}
    said = [C.check(caps, e) for e in encode_texts(outside)]
    assert [p for p, r in zip(outside, said) if r["known"]] == [] and caps["check"]["outside"]["notWarned"] == 0
    assert all(len(r["nearest"]) == 3 for r in said)          # each offered three working prompts instead


def test_a_broken_outside_file_is_one_error_naming_it(tmp_path):
    for text in ("[[", '{"prompts": ["a", ""]}', '["a person swims"]'):
        (tmp_path / "o.json").write_text(text)
        with pytest.raises(C.CoverageError, match="o.json"):
            C.load_outside(tmp_path / "o.json")


def test_the_notice_names_an_uncovered_action_only_for_a_prompt_near_it_and_in_a_visitors_words(caps):
    """A visitor audit: gibberish read as "respond", French as "dance", "plays the guitar" as "swordplay" and "sits down
    on a chair" as "deposit floor", dataset shorthand named for a prompt merely landing nearest it. Now: named from
    NAMED up (the held-apart paraphrases of uncovered actions are all above it), in words ("putting something down on
    the floor"), and the file carries those words for the page."""
    from emdm.prompt_check import NAMED, action_name

    for p in ["asdf qwerty", "une personne marche en avant", "a person plays the guitar", "someone sits down on a chair"]:
        r = C.check(caps, encode_texts([p])[0])
        assert not r["known"] and not r["covered"] and r["score"] < NAMED, (p, r)
        assert "reads as" not in C.notice(r) and f"best match {r['score']:.2f}" in C.notice(r), C.notice(r)
    prompts = load_prompts(PROMPTS_FILE, [x["label"] for x in caps["actions"]])
    _, held = C.build_split(prompts)
    covered = {x["label"] for x in caps["actions"] if x["covered"]}
    said = [C.check(caps, e) for e in encode_texts([p for a in prompts if a not in covered for p in held[a]])]
    assert min(r["score"] for r in said if not r["covered"]) >= NAMED
    r = C.check(caps, encode_texts(["a person puts an item down on the floor"])[0])
    assert r["action"] == "deposit-floor" and "it reads as putting something down on the floor," in C.notice(r)
    assert {x["label"]: x["name"] for x in caps["actions"]} == {x["label"]: action_name(x["label"]) for x in caps["actions"]}
    assert action_name("grab-high") == "reaching up to grab something" and action_name("raise-left-hand") == "raise left hand"


def test_scores_warn_a_prompt_whose_nearest_anchor_is_uncovered():
    anchors = np.array([[1.0, 0.0], [0.0, 1.0]])
    s = C.scores(anchors, np.array([True, False]), np.array([[0.96, 0.28], [0.28, 0.96]]))
    assert s.tolist() == [0.96, -1.0]          # the second is closest to the uncovered anchor: warned at any threshold


def test_calibrate_separates_and_counts_errors():
    r = C.calibrate(np.array([0.9, 0.85, 0.6]), np.array([0.3, 0.5, 0.88]))
    assert r["threshold"] == 0.55                  # all known pass, 2 of 3 unknown warned: the best mean
    assert r["falseWarnings"] == {"n": 3, "warned": 0} and r["misses"] == {"n": 3, "notWarned": 1}
    assert C.calibrate(np.array([0.9]), np.array([0.2]))["falseWarnings"]["warned"] == 0
    assert "outside" not in r


def test_calibrate_weighs_prompts_outside_the_vocabulary_as_a_third():
    known, unknown = np.array([0.9, 0.85, 0.8, 0.7]), np.array([0.3, 0.5])
    assert C.calibrate(known, unknown)["threshold"] == 0.6            # every known passes, every unknown warned
    # four everyday prompts scoring 0.75–0.78 against covered anchors: warning them (one known prompt warned, 0.7)
    # beats passing them, (3/4 + 1 + 1) / 3 > (1 + 1 + 0) / 3
    r = C.calibrate(known, unknown, np.array([0.75, 0.76, 0.77, 0.78]))
    assert r["threshold"] == 0.79 and r["outside"] == {"n": 4, "notWarned": 0}
    assert r["falseWarnings"] == {"n": 4, "warned": 1} and r["misses"] == {"n": 2, "notWarned": 0}


def test_action_model_lists_weak_actions():
    c = json.loads((mf.DEFAULT_MODELS_DIR / C.file_name(A2M)).read_text())
    assert c["condition"] == "action" and "anchors" not in c
    rows = {r["label"]: r for r in c["actions"]}
    assert rows["walk"]["covered"] and not rows["kick"]["covered"]


def test_stale_encoder_means_no_check(tmp_path, caps):
    for f in ["manifest.json", C.file_name(T2M)]:
        (tmp_path / f).write_bytes((mf.DEFAULT_MODELS_DIR / f).read_bytes())
    assert C.load(T2M, tmp_path) is not None
    stale = dict(caps, encoder=dict(caps["encoder"], sha256="0" * 64))
    (tmp_path / C.file_name(T2M)).write_text(json.dumps(stale))
    assert C.load(T2M, tmp_path) is None


def test_sample_cli_says_one_line_for_a_far_prompt(tmp_path, capsys):
    assert sample_main(["--model", T2M, "--text", "a person kicks", "--frames", "20", "--steps", "1", "--out", str(tmp_path / "k")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("this prompt is far from"), err
    assert "it reads as kick, which the model does not do well yet" in err[0], err
    assert sample_main(["--model", T2M, "--text", "a person walks", "--frames", "20", "--steps", "1", "--out", str(tmp_path / "w")]) == 0
    assert capsys.readouterr().err == ""


def test_a_file_of_another_schema_is_one_line(tmp_path, capsys, caps):
    """A schema-1 file (built before uncovered anchors) is refused by name; the CLI says so in one line and generates."""
    models = tmp_path / "models"                      # the shipped text model, with a schema-1 capabilities file
    shutil.copytree(mf.DEFAULT_MODELS_DIR, models, ignore=shutil.ignore_patterns("diffusion-*", "emdm-a2m-*", "*.pt"))
    (models / C.file_name(T2M)).write_text(json.dumps(dict(caps, schema=1)))
    with pytest.raises(C.CapabilitiesError, match=f"{C.file_name(T2M)}: schema 1, this code reads 2; rebuild it"):
        C.load(T2M, models)
    assert sample_main(["--model", T2M, "--models-dir", str(models), "--text", "a person walks", "--frames", "20",
                        "--steps", "1", "--out", str(tmp_path / "w")]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("no prompt check: ") and "schema 1" in err[0], err
    assert list(tmp_path.glob("w*.bvh")), list(tmp_path.iterdir())


def test_missing_coverage_result_is_one_line_exit_2(tmp_path, capsys):
    assert C.main(["--model", T2M, "--coverage", str(tmp_path / "none.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "none.json: no coverage result" in err[0]


def test_the_check_names_the_closest_anchors_action(caps):
    a = caps["anchors"]
    vecs = C.dequantise(np.frombuffer(__import__("base64").b64decode(a["embeddings"]), np.int8).reshape(len(a["texts"]), -1))
    for p in ["a person walks forward", "a person is running", "swims"]:
        e = encode_texts([p])[0]
        assert C.check(caps, e)["action"] == a["actions"][int(np.argmax(vecs @ e))], p
    assert C.check(caps, encode_texts(["a person walks"])[0])["action"] == "walk"
    assert C.check(caps, encode_texts(["a person runs"])[0])["action"] == "run"


@pytest.mark.parametrize("model", [T2M, A2M])
def test_shipped_file_carries_the_real_clips_speed_per_action(model):
    """Each action's realSpeed is its real test clips' median and 5th–95th percentile, from the realism result the
    file names (real.reference.speeds: one speed per clip)."""
    c = json.loads((mf.DEFAULT_MODELS_DIR / C.file_name(model)).read_text())
    real = read_result(REPO_ROOT / c["realSpeedSource"])["real"]["reference"]["speeds"]
    rows = {r["label"]: r for r in c["actions"]}
    assert {a for a, r in rows.items() if "realSpeed" in r} == {a for a in rows if len(real.get(a, []))}
    walk = np.asarray(real["walk"])
    assert rows["walk"]["realSpeed"] == {"median": round(float(np.median(walk)), 2), "clips": len(walk),
                                         "low": round(float(np.percentile(walk, 5)), 2),
                                         "high": round(float(np.percentile(walk, 95)), 2)}
    assert 0.3 < rows["walk"]["realSpeed"]["low"] < rows["walk"]["realSpeed"]["median"] < rows["walk"]["realSpeed"]["high"] < 2.0
    assert rows["run"]["realSpeed"]["median"] > 2 * rows["walk"]["realSpeed"]["median"]


def test_realism_result_without_real_speeds_is_one_line_exit_2(tmp_path, capsys):
    bad = tmp_path / "realism-x.json"
    bad.write_text(json.dumps({"real": {"per_action": {}}}))
    assert C.main(["--model", T2M, "--realism", str(bad)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "realism-x.json" in err[0] and "real.reference.speeds" in err[0], err


def test_an_action_recognised_but_standing_still_is_not_covered_and_gives_no_chip():
    """The classifier can name a pose that never moves (a boxer's guard for punch): covered needs its motions to move
    too (realism's ``moving``), and a prompt whose motions stand still is not the action's prompt."""
    cov = {"default_steps": 10, "runs": [{"steps": 10, "per_action": {
        "punch": {"n": 8, "rate": 1.0}, "walk": {"n": 8, "rate": 0.9}, "bow": {"n": 8, "rate": 0.8}},
        "prompts": {"a person punches": {"rate": 1.0}, "a person walks": {"rate": 0.9}, "a person bows": {"rate": 1.0},
                    "someone takes a deep bow": {"rate": 0.8}}}]}
    prompts = {"punch": ["a person punches"], "walk": ["a person walks"], "bow": ["a person bows", "someone takes a deep bow"]}
    _, rows = C.actions_table(cov, prompts)                                     # not measured: the classifier alone
    assert all(r["covered"] for r in rows)
    moving = {"punch": 0.0, "walk": 1.0, "bow": 0.75}
    _, rows = C.actions_table(cov, prompts, moving, {"a person punches": 0.0, "a person bows": 0.25, "someone takes a deep bow": 1.0})
    rows = {r["label"]: r for r in rows}
    assert not rows["punch"]["covered"] and rows["punch"]["moving"] == 0.0 and "prompt" not in rows["punch"]
    assert rows["walk"]["covered"] and rows["bow"]["covered"]
    assert rows["bow"]["prompt"] == "someone takes a deep bow"                   # the best prompt whose bows move


def test_moving_shares_are_read_from_this_models_realism_result_only():
    r = {"model": T2M, "generated": {"per_action": {"punch": {"moving": 0.0}, "walk": {}},
                                     "prompts": {"a person punches": {"moving": 0.0}}}}
    assert C.moving_shares(r, T2M) == ({"punch": 0.0}, {"a person punches": 0.0})
    assert C.moving_shares(r, A2M) == ({}, {})


@pytest.mark.parametrize("model", [T2M, A2M])
def test_shipped_file_covers_only_actions_whose_motions_move(model):
    c = json.loads((mf.DEFAULT_MODELS_DIR / C.file_name(model)).read_text())
    src = read_result(REPO_ROOT / c["movingSource"])
    assert src["model"] == model
    gen = src["generated"]["per_action"]
    for r in c["actions"]:
        if "moving" in gen.get(r["label"], {}):       # measured where the action has real test clips
            assert r["moving"] == round(gen[r["label"]]["moving"], 4)
        else:
            assert "moving" not in r
        assert r["covered"] == (r["rate"] >= c["thresholds"]["covered"] and r.get("moving", 1) >= C.MOVES), r
    if model == T2M:
        prompts = src["generated"]["prompts"]
        chips = [t for t, a, s in zip(c["anchors"]["texts"], c["anchors"]["actions"], c["anchors"]["suggest"]) if s]
        assert chips and all(prompts[t]["moving"] >= C.MOVES for t in chips if t in prompts)


def test_a_paraphrase_is_the_chip_before_a_plain_prompt_no_caption_says_so_on_a_tie():
    """The list's chips read "a person walks turn left" and "a person jogs in circle" (the plain prompt, made from the
    label, won every tie): where the action's training captions never say the plain prompt's words, a written
    paraphrase is the chip on a tie; a plain prompt the captions say ("a person bows") keeps it."""
    cov = {"default_steps": 10, "runs": [{"steps": 10, "per_action": {
        "walk-turn-left": {"n": 8, "rate": 1.0}, "bow": {"n": 8, "rate": 1.0}},
        "prompts": {"a person walks turn left": {"rate": 1.0}, "someone turns left while walking": {"rate": 1.0},
                    "a person bows": {"rate": 1.0}, "someone takes a deep bow": {"rate": 1.0}}}]}
    prompts = {"walk-turn-left": ["a person walks turn left", "someone turns left while walking"],
               "bow": ["a person bows", "someone takes a deep bow"]}
    captions = {"walk-turn-left": ["A person walks and turns left."], "bow": ["Someone bows politely.", "A man bows."]}
    unwritten = C.unwritten_plain(prompts, captions)
    assert unwritten == {"walk-turn-left"}
    rows = {r["label"]: r["prompt"] for r in C.actions_table(cov, prompts, unwritten=unwritten)[1]}
    assert rows == {"walk-turn-left": "someone turns left while walking", "bow": "a person bows"}
    assert {r["label"]: r["prompt"] for r in C.actions_table(cov, prompts)[1]}["walk-turn-left"] == "a person walks turn left"


def test_the_shipped_file_suggests_no_plain_prompt_its_captions_never_say(caps):
    """The notice's suggestions and the list's chips were "a person walks turn left", "a person jogs in circle": they
    stay anchors (the check still knows them) but are never offered."""
    a = caps["anchors"]
    offered = {t for t, s in zip(a["texts"], a["suggest"]) if s} | {x.get("prompt") for x in caps["actions"]}
    unsaid = {"a person walks turn left", "a person walks turn right", "a person jogs in circle", "a person grabs high"}
    assert unsaid <= set(a["texts"]) and not unsaid & offered
    assert "a person walks and then turns to the left" in offered and "a person bows" in offered


@pytest.mark.parametrize("model", [T2M, A2M])
def test_shipped_file_names_the_judge_of_its_rates(model):
    """The rates the page lists were recognised by the coverage result's judge; the file says who (the page's source
    line counts its classifiers) and which (sha256), and the realism result that gates `moving` had the same judge."""
    c = json.loads((mf.DEFAULT_MODELS_DIR / C.file_name(model)).read_text())
    judge = read_result(REPO_ROOT / c["source"])["classifier"]
    assert c["judge"] == {"classifiers": len(judge.get("members") or [judge]), "sha256": judge["sha256"]}
    assert c["judge"]["classifiers"] == 3, "the shipped files are judged by the three seeds' classifiers (emdm.eval.judge)"
    assert read_result(REPO_ROOT / c["movingSource"])["classifier"]["sha256"] == judge["sha256"]
