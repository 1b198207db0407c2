"""Captions: templates per source action and style, a small lexicon POS tagger, and the
HumanML3D text line format ``caption#tok/POS tok/POS ...#from#to``.

spaCy's models cannot be downloaded here, so tokens are tagged by a lexicon plus suffix rules
with the universal tags NOUN VERB ADJ ADV DET ADP PRON NUM CCONJ PART OTHER; verbs are lemmatised
("walks" -> "walk/VERB") like HumanML3D's spaCy tokens.

Truthfulness: every template is written for the action it belongs to; sides (left/right) are only
named where the source says (or the data shows) which side it is, and mirrored copies swap
"left" and "right" in every caption (``mirror_caption``).
"""

from __future__ import annotations

import random
import re

SUBJECTS = ["a person", "someone", "a human", "the person", "a figure"]

# Verb phrases per unified action (third person singular). Sided phrases follow the source.
BANDAI_PHRASES: dict[str, list[str]] = {
    "walk": ["walks forward", "walks straight ahead", "strolls ahead", "walks forward in a straight line"],
    "run": ["runs forward", "jogs straight ahead", "runs ahead"],
    "dash": ["sprints forward", "dashes ahead", "runs forward very fast"],
    "walk-back": ["walks backward", "steps backwards", "walks backwards slowly"],
    "walk-left": ["walks forward to the left", "walks diagonally to the left", "walks ahead while veering left"],
    "walk-right": ["walks forward to the right", "walks diagonally to the right", "walks ahead while veering right"],
    "bow": ["bows", "bows politely", "bends forward in a bow"],
    "bye": ["waves goodbye with the right hand", "waves the right hand to say bye", "raises the right hand and waves goodbye"],
    "guide": ["gestures the way with the right hand", "guides someone with the right hand", "shows the direction with the right arm"],
    "byebye": ["waves goodbye with both hands", "waves both hands to say goodbye", "raises both hands and waves"],
    "respond": ["raises the left hand to respond", "responds by lifting the left hand", "answers with a raised left hand"],
    "call": ["calls out to someone", "calls someone over", "gestures to call someone"],
    "punch": ["punches", "throws punches", "punches forward"],
    "kick": ["kicks with the right leg", "kicks forward with the right foot", "does a kick with the right leg"],
    "slash": ["slashes as if holding a sword", "swings an imaginary sword", "makes sword slashing moves"],
    "dance-long": ["dances", "performs a dance", "dances energetically"],
    "dance-short": ["dances", "performs a short dance", "dances for a moment"],
    "walk-turn-left": ["walks and turns left", "walks forward then turns to the left", "makes a left turn while walking"],
    "walk-turn-right": ["walks and turns right", "walks forward then turns to the right", "makes a right turn while walking"],
    "wave-both-hands": ["waves both hands", "waves with both hands", "raises both hands and waves them"],
    "wave-left-hand": ["waves the left hand", "waves with the left hand", "raises the left hand and waves"],
    "wave-right-hand": ["waves the right hand", "waves with the right hand", "raises the right hand and waves"],
    "raise-up-both-hands": ["raises both hands", "lifts both arms up", "puts both hands up in the air"],
    "raise-up-left-hand": ["raises the left hand", "lifts the left arm up", "puts the left hand up"],
    "raise-up-right-hand": ["raises the right hand", "lifts the right arm up", "puts the right hand up"],
}

# Style -> adverbial phrases appended to the verb phrase ("" = none). Dataset-1 and -2 names.
STYLE_PHRASES: dict[str, list[str]] = {
    "normal": ["", "", "normally"],
    "happy": ["happily", "cheerfully", "in a cheerful mood"],
    "sad": ["sadly", "in a sad mood", "gloomily"],
    "angry": ["angrily", "in an angry way", "furiously"],
    "proud": ["proudly", "with pride", "with a proud posture"],
    "not-confident": ["timidly", "without confidence", "hesitantly"],
    "masculinity": ["in a masculine manner", "in a manly way"],
    "masculine": ["in a masculine manner", "in a manly way"],
    "feminine": ["in a feminine manner", "in a graceful feminine way"],
    "childish": ["like a child", "in a childish way", "playfully like a kid"],
    "youthful": ["in a youthful way", "energetically like a young person"],
    "old": ["like an elderly person", "slowly like an old person"],
    "elderly": ["like an elderly person", "slowly like an old person"],
    "tired": ["tiredly", "wearily", "as if exhausted"],
    "exhausted": ["wearily", "as if exhausted", "in an exhausted way"],
    "active": ["actively", "energetically", "in a lively way"],
    "musical": ["rhythmically", "theatrically like in a musical"],
    "giant": ["like a giant", "with heavy giant steps"],
    "chimpira": ["like a thug", "in a swaggering thuggish way"],
}
STYLE_SUBJECTS: dict[str, list[str]] = {
    "old": ["an elderly person", "an old person"],
    "elderly": ["an elderly person", "an old person"],
    "childish": ["a childlike person"],
    "youthful": ["a young person"],
}

HDM05_PHRASES: dict[str, list[str]] = {
    "depositFloorR": ["bends down and puts something on the floor with the right hand",
                      "places an object on the floor with the right hand", "puts something down on the ground using the right hand"],
    "elbowToKnee": ["does an elbow to knee exercise starting with the left elbow",
                    "brings an elbow to the opposite knee starting with the left elbow", "touches elbow to knee starting with the left elbow"],
    "grabHighR": ["reaches up and grabs something high with the right hand", "grabs an object from a high place with the right hand",
                  "stretches the right arm up to grab something"],
    "hopBothLegs": ["hops once with both legs", "jumps up on both feet", "does a small hop with both feet"],
    "jogLeftCircle": ["jogs in a circle to the left", "jogs around in a counterclockwise circle", "jogs while turning left in a circle"],
    "kickLFront": ["kicks forward with the left leg", "does a front kick with the left foot", "kicks to the front with the left leg"],
    "lieDownFloor": ["lies down on the floor", "gets down and lies on the ground", "lowers the body to lie on the floor"],
    "rotateArmsBothBackward": ["rotates both arms backward", "circles both arms backwards", "swings both arms around backwards"],
    "sneak": ["sneaks forward starting with the left foot", "tiptoes forward quietly", "sneaks ahead a couple of steps"],
    "squat": ["does a squat", "squats down and stands back up", "bends the knees into a squat and rises"],
    "throwBasketball": ["throws a basketball", "throws a ball forward", "makes a basketball throw"],
}

# --- CMU descriptions -> sentences -------------------------------------------------------------

_IRREGULAR_3SG = {"go": "goes", "do": "does", "have": "has", "be": "is"}
CMU_VERBS = {
    "walk", "run", "jog", "jump", "climb", "sit", "dangle", "swing", "hang", "go", "turn", "drop", "lean",
    "pull", "rock", "lower", "descend", "hold", "push", "punch", "strike", "bend", "scoop", "rise", "lift",
    "wash", "balance", "dribble", "shoot", "dance", "kick", "step", "stretch", "throw", "catch", "hop",
    "spin", "roll", "crawl", "stand", "fall", "reach", "wave", "look", "bow", "twist", "squat", "skip",
    "march", "sneak", "leap", "slide", "fold", "raise",
}
_LEAD_ADJ = {"slow": "slowly", "brisk": "briskly", "fast": "fast", "quick": "quickly"}


def _third_person(verb: str) -> str:
    if verb in _IRREGULAR_3SG:
        return _IRREGULAR_3SG[verb]
    if re.search(r"(s|sh|ch|x|z|o)$", verb):
        return verb + "es"
    if re.search(r"[^aeiou]y$", verb):
        return verb[:-1] + "ies"
    return verb + "s"


def _phrase(item: str) -> str:
    words = item.replace("/", " or ").split()
    if not words:
        return ""
    w0 = words[0].lower()
    if w0 in CMU_VERBS:
        rest = words[1:]
        if w0 in ("run",) and rest[:2] == ["or", "jog"]:
            rest = rest[2:]
            return " ".join(["runs or jogs"] + rest)
        return " ".join([_third_person(w0)] + rest).replace(" self", " themself")
    if w0 in _LEAD_ADJ and len(words) > 1 and words[1].lower() in CMU_VERBS:
        return " ".join([_third_person(words[1].lower())] + words[2:] + [_LEAD_ADJ[w0]])
    if w0.endswith("ing") and w0[:-3] in CMU_VERBS | {"fold", "bend"}:
        return " ".join([_third_person(w0[:-3])] + words[1:])
    last = words[-1].lower()
    plural = last.endswith("s") and not last.endswith("ss")
    article = "" if plural or w0.endswith("ing") or w0 in ("swordplay",) else ("an " if w0[0] in "aeiou" else "a ")
    return "does " + article + " ".join(words)


def cmu_phrases(description: str) -> list[str]:
    """Verb phrases from a CMU trial description ("playground - climb, sit" -> 'climbs and sits
    on a playground'). Every variant keeps all the description's parts."""
    desc = description.strip().rstrip(".")
    context = ""
    if " - " in desc:
        context, desc = [s.strip() for s in desc.split(" - ", 1)]
    items = [p.strip() for p in re.split(r",|;", desc) if p.strip()]
    parts = [_phrase(p) for p in items]
    if not parts:
        parts = [_phrase(context)] if context else ["moves"]
        context = ""
    joined = parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]
    ctx = context.lower()
    if ctx == "playground":
        tails = [" on a playground", " on the playground equipment"]
    elif ctx == "basketball":
        tails = [" with a basketball", " while playing basketball"]
    elif ctx == "dance":
        tails = [" while dancing", " in a dance"]
    elif ctx:
        tails = [f" ({ctx})"]
    else:
        tails = [""]
    return [joined + t for t in tails] + ([joined] if ctx else [])


# --- the caption sentences ---------------------------------------------------------------------


def _sentences(subjects: list[str], phrases: list[str], adverbs: list[str], n: int, rng: random.Random,
               plain_subjects: tuple[str, ...] = ()) -> list[str]:
    """``plain_subjects`` already carry the style ("an elderly person"): no adverb is added to them."""
    combos = [(s, p, "" if s in plain_subjects else a) for s in subjects for p in phrases for a in adverbs]
    combos = list(dict.fromkeys(combos))
    rng.shuffle(combos)
    out: list[str] = []
    used_phrase: dict[str, int] = {}
    for s, p, a in combos:
        text = f"{s} {p}" + (f" {a}" if a else "")
        if text in out:
            continue
        # prefer variety of verb phrases first
        if used_phrase.get(p, 0) > (len(out) // max(len(phrases), 1)):
            continue
        used_phrase[p] = used_phrase.get(p, 0) + 1
        out.append(text)
        if len(out) == n:
            break
    for s, p, a in combos:  # fill up if the variety rule was too strict
        if len(out) >= n:
            break
        text = f"{s} {p}" + (f" {a}" if a else "")
        if text not in out:
            out.append(text)
    return [o[0].upper() + o[1:] + "." for o in out]


def bandai_captions(content: str, style: str, n: int = 4, seed: int = 0) -> list[str]:
    if content not in BANDAI_PHRASES:
        raise KeyError(f"no caption templates for Bandai content {content!r}")
    if style not in STYLE_PHRASES:
        raise KeyError(f"no caption templates for Bandai style {style!r}")
    rng = random.Random(f"bandai/{content}/{style}/{seed}")
    styled = STYLE_SUBJECTS.get(style, [])
    return _sentences(styled + SUBJECTS[:3], BANDAI_PHRASES[content], STYLE_PHRASES[style], n, rng, tuple(styled))


def hdm05_captions(action_key: str, n: int = 4, seed: int = 0) -> list[str]:
    rng = random.Random(f"hdm05/{action_key}/{seed}")
    return _sentences(SUBJECTS, HDM05_PHRASES[action_key], [""], n, rng)


def cmu_captions(description: str, n: int = 4, seed: int = 0) -> list[str]:
    rng = random.Random(f"cmu/{description}/{seed}")
    return _sentences(SUBJECTS, cmu_phrases(description), [""], n, rng)


_SIDE = re.compile(r"\b(left|right|Left|Right|counterclockwise|clockwise)\b")
_SIDE_SWAP = {"left": "right", "right": "left", "Left": "Right", "Right": "Left",
              "counterclockwise": "clockwise", "clockwise": "counterclockwise"}


def mirror_caption(text: str) -> str:
    """Swap left/right (and clockwise/counterclockwise) words for a mirrored clip."""
    return _SIDE.sub(lambda m: _SIDE_SWAP[m.group(1)], text)


# --- POS tagging and the line format ---------------------------------------------------------

_LEX: dict[str, str] = {}
for _w in "a an the this that these those each every some any".split():
    _LEX[_w] = "DET"
for _w in ("to in on at with by for from of into onto over under around up down off out about through "
           "across along behind toward towards while like as").split():
    _LEX[_w] = "ADP"
for _w in "he she it they them him her his their its themself himself herself someone something one".split():
    _LEX[_w] = "PRON"
for _w in "and or but then".split():
    _LEX[_w] = "CCONJ"
for _w in "not".split():
    _LEX[_w] = "PART"
for _w in ("left right both high low small short long slow fast quick heavy giant proud sad happy angry "
           "cheerful gloomy masculine manly feminine graceful childish childlike youthful young old elderly "
           "tired exhausted active lively musical straight energetic quiet opposite front uneven imaginary "
           "expressive free sideways diagonal counterclockwise clockwise thuggish swaggering brisk low").split():
    _LEX[_w] = "ADJ"
for _w in ("forward backward backwards ahead again away slowly quickly normally happily cheerfully sadly "
           "gloomily angrily furiously proudly timidly hesitantly tiredly wearily actively energetically "
           "rhythmically theatrically playfully politely diagonally briskly quietly back once twice fast "
           "very then around together").split():
    _LEX.setdefault(_w, "ADV")
_NUMS = {"one", "two", "three", "four", "five", "six", "ten", "twice", "once"}
_VERB_LEMMAS = CMU_VERBS | {
    "stroll", "veer", "wave", "raise", "put", "make", "take", "gesture", "guide", "show", "answer", "respond",
    "call", "punch", "slash", "swing", "perform", "place", "touch", "bring", "reach", "grab", "stretch",
    "circle", "rotate", "tiptoe", "get", "lie", "say", "dash", "sprint", "throw", "squat", "hop", "bow",
    "use", "play", "rise", "stand", "lower", "sneak", "move", "kick", "dance", "jog", "run", "walk", "does",
}
_VERB_FORMS: dict[str, str] = {}
for _v in _VERB_LEMMAS:
    _VERB_FORMS[_v] = _v
    _VERB_FORMS[_third_person(_v)] = _v
    _VERB_FORMS[_v + "ing"] = _v
    _VERB_FORMS[(_v[:-1] if _v.endswith("e") else _v) + "ing"] = _v
    _VERB_FORMS[_v + "ed"] = _v
_VERB_FORMS.update({"does": "do", "do": "do", "is": "be", "goes": "go", "lies": "lie", "lying": "lie",
                    "gets": "get", "puts": "put", "swings": "swing", "runs": "run", "has": "have",
                    "dangle": "dangle", "says": "say", "throws": "throw"})


def tokenize(text: str) -> list[str]:
    return re.findall(r"[a-z0-9]+(?:'[a-z]+)?", text.lower())


def pos_tag(word: str) -> tuple[str, str]:
    """(lemma, tag) for one lower-case token."""
    if word.isdigit() or word in _NUMS:
        return word, "NUM"
    if word in _LEX and word not in ("back",):
        return word, _LEX[word]
    if word in _VERB_FORMS:
        return _VERB_FORMS[word], "VERB"
    if word.endswith("ly") and len(word) > 4:
        return word, "ADV"
    if re.search(r"(ful|ous|ive|ish|ic|al|less)$", word) and len(word) > 4:
        return word, "ADJ"
    if word.isalpha():
        return (word[:-1] if word.endswith("s") and not word.endswith("ss") and len(word) > 3 else word), "NOUN"
    return word, "OTHER"


def caption_line(caption: str, start: float = 0.0, end: float = 0.0) -> str:
    """``caption#tok/POS ...#from#to`` (from/to seconds; 0.0 0.0 = the whole clip)."""
    clean = caption.replace("#", " ").strip()
    toks = " ".join(f"{lemma}/{tag}" for lemma, tag in (pos_tag(w) for w in tokenize(clean)))
    return f"{clean}#{toks}#{start:.1f}#{end:.1f}"


def parse_caption_line(line: str, path: str = "<text>", lineno: int = 1) -> tuple[str, list[tuple[str, str]], float, float]:
    parts = line.rstrip("\n").split("#")
    if len(parts) != 4:
        raise ValueError(f"{path}:{lineno}: expected 'caption#tokens#from#to' (4 fields), got {len(parts)}")
    toks = []
    for t in parts[1].split():
        if "/" not in t:
            raise ValueError(f"{path}:{lineno}: token {t!r} is not 'word/POS'")
        w, p = t.rsplit("/", 1)
        toks.append((w, p))
    try:
        start, end = float(parts[2]), float(parts[3])
    except ValueError:
        raise ValueError(f"{path}:{lineno}: from/to must be numbers, got {parts[2]!r} {parts[3]!r}") from None
    return parts[0], toks, start, end
