"""Captions and action labels: line format, POS tags, truthful sides, mirroring, unified vocabulary."""

import re

import pytest

from emdm.data import actions, captions as C

TAGS = {"NOUN", "VERB", "ADJ", "ADV", "DET", "ADP", "PRON", "NUM", "CCONJ", "PART", "OTHER"}


def test_line_format_round_trips_and_tags_are_universal():
    line = C.caption_line("A person walks forward happily.")
    assert line.count("#") == 3
    cap, toks, start, end = C.parse_caption_line(line)
    assert cap == "A person walks forward happily."
    assert toks == [("a", "DET"), ("person", "NOUN"), ("walk", "VERB"), ("forward", "ADV"), ("happily", "ADV")]
    assert (start, end) == (0.0, 0.0)
    with pytest.raises(ValueError, match="x.txt:3: expected 'caption#tokens#from#to'"):
        C.parse_caption_line("no hashes", "x.txt", 3)


@pytest.mark.parametrize("content", sorted(C.BANDAI_PHRASES))
def test_every_bandai_content_and_style_gets_several_distinct_captions(content):
    for style in C.STYLE_PHRASES:
        caps = C.bandai_captions(content, style, n=4)
        assert len(caps) == len(set(caps)) >= 3
        for c in caps:
            assert c[0].isupper() and c.endswith(".")
            _, toks, _, _ = C.parse_caption_line(C.caption_line(c))
            assert {t for _, t in toks} <= TAGS and any(t == "VERB" for _, t in toks)


@pytest.mark.parametrize("content,side", [
    ("walk-left", "left"), ("walk-right", "right"), ("wave-left-hand", "left"), ("raise-up-right-hand", "right"),
    ("walk-turn-left", "left"), ("bye", "right"), ("respond", "left"), ("kick", "right"),
])
def test_sided_captions_name_only_their_side_and_mirror_to_the_other(content, side):
    other = {"left": "right", "right": "left"}[side]
    for style in ("normal", "happy", "old"):
        for c in C.bandai_captions(content, style, n=6):
            assert other not in c.split() and other + "." not in c, c
            m = C.mirror_caption(c)
            assert side not in re.findall(r"[a-z]+", m) and other in m, m


@pytest.mark.parametrize("content", ["walk", "run", "bow", "byebye", "dance-long", "raise-up-both-hands"])
def test_unsided_actions_never_mention_a_side(content):
    for c in C.bandai_captions(content, "normal", n=6):
        assert not re.search(r"\b(left|right)\b", c), c


def test_hdm05_and_cmu_captions():
    for key in actions.HDM05:
        assert len(set(C.hdm05_captions(key))) >= 3
    assert "left" in " ".join(C.hdm05_captions("kickLFront"))
    caps = C.cmu_captions("playground - climb, sit, dangle legs, jump down")
    assert all("climbs, sits, dangles legs and jumps down" in c for c in caps)
    assert C.cmu_captions("run/jog")[0].endswith("runs or jogs.")
    assert "walks slowly" in C.cmu_captions("slow walk")[0]


def test_unified_labels_merge_sources_and_mirror():
    assert actions.BANDAI["bye"] == actions.BANDAI["wave-right-hand"] == "wave-right-hand"
    assert actions.hdm05_action("kickLFront1Reps") == actions.BANDAI["kick"] == "kick"
    assert actions.cmu_action("brisk walk") == actions.BANDAI["walk"] == "walk"
    assert actions.cmu_action("run/jog") == "run"
    assert actions.cmu_action("basketball - forward dribble") == "dribble"
    # a verb wins over the setting: the playground's forward jumps are jumps, its climbs stay climbs
    assert actions.cmu_action("playground - forward jumps, turn around") == "jump"
    assert actions.cmu_action("playground - climb, sit, dangle legs, jump down") == "climb"
    assert actions.cmu_action("playground - grip bar, swing body") == "climb"
    # ... and the split keeps stratifying the playground session as one group (the test split the models know)
    assert actions.cmu_stratum("playground - forward jumps, turn around") == "climb"
    assert actions.cmu_stratum("run/jog") == actions.cmu_action("run/jog") == "run"
    assert actions.mirror_label("walk-turn-left") == "walk-turn-right"
    assert actions.mirror_label("raise-both-hands") == "raise-both-hands"
    vocab = actions.vocabulary({"wave-left-hand", "walk"})
    assert vocab == ["walk", "wave-left-hand", "wave-right-hand"]
