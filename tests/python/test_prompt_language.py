"""Python's English check (emdm.prompt_language) is the page's (src/language.ts): the same word lists, the same
verdicts, and the CLI's unknown-prompt line says a prompt is not English as the page's notice does."""

import re
from pathlib import Path

from emdm import prompt_check
from emdm.prompt_language import ENGLISH_WORDS, OTHER_WORDS, reads_as_english

TS = Path(__file__).resolve().parents[2] / "src" / "language.ts"


def _ts_list(name: str) -> list[str]:
    m = re.search(name + r": readonly string\[\] = \[([^\]]*)\]", TS.read_text())
    assert m, f"{name} not found in {TS}"
    return re.findall(r"'([^']+)'", m.group(1))


def test_the_word_lists_are_the_pages():
    assert list(ENGLISH_WORDS) == _ts_list("ENGLISH_WORDS")
    assert list(OTHER_WORDS) == _ts_list("OTHER_WORDS")
    assert not set(ENGLISH_WORDS) & set(OTHER_WORDS)


def test_prompts_in_other_languages_are_not_english_and_english_ones_are():
    for p in ["une personne marche en avant", "Une personne lève les deux mains", "una persona camina",
              "der Mann springt hoch", "eine Person winkt mit beiden Händen", "uma pessoa anda", "a pessoa dança",
              "een persoon loopt", "un uomo cammina", "人が歩いている", "человек идёт", "άνθρωπος περπατά", "Salut ça va",
              "Une personne le\u0300ve les mains"]:           # decomposed accent: the same as the composed one
        assert not reads_as_english(p), p
    for p in ["a person walks", "A person waves with both hands happily", "a person dances the samba",
              "someone does the macarena", "a person waves to la la land", "asdf qwerty", "123", "",
              "a man kicks, then bows"]:
        assert reads_as_english(p), p


def test_the_cli_line_says_a_prompt_is_not_english():
    far = {"known": False, "covered": False, "score": 0.58, "action": "dance", "nearest": ["a person walks"]}
    line = prompt_check.notice(far, "une personne marche en avant")
    assert "does not read as English, and the model understands English prompts only; best match 0.58" in line
    assert "dance" not in line and "'a person walks'" in line
    assert "English" not in prompt_check.notice(far, "a person juggles")
    assert "reads as dance" in prompt_check.notice(far)                 # no prompt given: as before
