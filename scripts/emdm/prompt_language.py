"""Whether a prompt reads as English, as the page's src/language.ts says (its word lists are these, checked equal by
tests/python/test_prompt_language.py). The shipped text encoder and the training captions are English, so a prompt in
another language lands far from all the model learned; the unknown-prompt notice says why. A heuristic on words, not a
language detector: *not English* when the prompt has letters but none Latin, or more of ``OTHER_WORDS`` than of
``ENGLISH_WORDS``, or accented letters and no English word."""

from __future__ import annotations

import re
import unicodedata

# English words common in motion prompts (function words, people, body parts, common motion verbs)
ENGLISH_WORDS = (
    "a", "an", "the", "and", "or", "then", "while", "with", "without", "to", "of", "in", "on", "at", "up", "down",
    "into", "over", "around", "from", "forward", "forwards", "backward", "backwards", "left", "right", "both", "his",
    "her", "their", "its", "he", "she", "they", "it", "is", "are", "was", "does", "person", "someone", "somebody",
    "man", "woman", "people", "figure", "character", "guy", "girl", "boy", "hand", "hands", "arm", "arms", "leg",
    "legs", "foot", "feet", "head", "body", "knee", "knees", "walks", "walk", "walking", "runs", "run", "running",
    "jumps", "jump", "jumping", "waves", "wave", "waving", "dances", "dance", "dancing", "kicks", "kick", "punches",
    "punch", "bows", "bow", "sits", "sit", "stands", "stand", "turns", "turn", "raises", "raise", "lifts", "lift",
    "throws", "throw", "climbs", "climb", "squats", "squat", "slowly", "quickly", "happily", "again", "steps",
    "step", "moves", "move",
)

# common words of prompts in French, Spanish, German, Italian, Portuguese and Dutch that are not English words
OTHER_WORDS = (
    "une", "un", "le", "la", "les", "des", "du", "personne", "homme", "femme", "qui", "avec", "et", "il", "elle",
    "marche", "court", "saute", "danse", "bras", "main", "mains", "jambe", "lève", "leve", "salue", "una", "uno",
    "el", "los", "las", "persona", "hombre", "mujer", "con", "y", "camina", "corre", "salta", "baila", "brazos",
    "manos", "levanta", "saluda", "ein", "eine", "einer", "der", "das", "und", "mit", "mann", "frau", "mensch",
    "läuft", "lauft", "springt", "tanzt", "geht", "hebt", "winkt", "hände", "hande", "arme", "lo", "gli", "uomo",
    "donna", "che", "cammina", "balla", "alza", "uma", "um", "pessoa", "homem", "mulher", "com", "anda", "pula",
    "dança", "danca", "een", "persoon", "loopt", "rent", "danst", "zwaait", "met", "de", "het", "en",
)

_ENGLISH = frozenset(ENGLISH_WORDS)
_OTHER = frozenset(OTHER_WORDS)
_WORD = re.compile(r"[^\W\d_]+")
_LATIN = re.compile(r"[a-z\u00c0-\u024f]")


def reads_as_english(prompt: str) -> bool:
    """Whether ``prompt`` reads as English (see the module doc); True for a prompt without letters."""
    words = _WORD.findall(unicodedata.normalize("NFC", prompt).lower())
    if not words:
        return True
    if not any(_LATIN.search(w) for w in words):
        return False
    en = sum(w in _ENGLISH for w in words)
    if sum(w in _OTHER for w in words) > en:
        return False
    return en > 0 or not any(re.search(r"[^a-z]", w) for w in words)
