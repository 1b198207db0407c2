"""The unified action vocabulary across sources, and left/right mirroring of labels.

Merges (decided from the data, see docs/DATA.md):
* Bandai dataset-1 ``walk`` / ``run`` and dataset-2 ``walk`` / ``run`` -> ``walk`` / ``run``;
  CMU "walk", "slow walk", "brisk walk" -> ``walk``; CMU "run/jog" -> ``run``.
* Bandai dataset-1 ``bye`` is a right-hand wave in all 15 clips (measured: the right wrist rises
  and moves, the left stays down) -> ``wave-right-hand`` (as dataset-2); ``byebye`` waves both
  hands -> ``wave-both-hands``.
* Bandai ``kick`` (right leg) and HDM05 ``kickLFront`` (left leg) -> ``kick``; the leg is named
  in the captions, not in the label. Likewise ``guide`` (right hand), ``respond`` (left hand),
  HDM05 ``depositFloorR`` / ``grabHighR`` / ``jogLeftCircle`` keep side-neutral labels.
* Labels that carry a side (``walk-left``, ``wave-left-hand``, ``raise-left-hand``,
  ``walk-turn-left`` ...) swap sides in mirrored copies (``mirror_label``).
"""

from __future__ import annotations

import re

BANDAI = {
    "walk": "walk", "run": "run", "dash": "sprint", "walk-back": "walk-backward",
    "walk-left": "walk-left", "walk-right": "walk-right", "bow": "bow", "bye": "wave-right-hand",
    "guide": "guide", "byebye": "wave-both-hands", "respond": "respond", "call": "call",
    "punch": "punch", "kick": "kick", "slash": "slash", "dance-long": "dance", "dance-short": "dance",
    "walk-turn-left": "walk-turn-left", "walk-turn-right": "walk-turn-right",
    "wave-both-hands": "wave-both-hands", "wave-left-hand": "wave-left-hand",
    "wave-right-hand": "wave-right-hand", "raise-up-both-hands": "raise-both-hands",
    "raise-up-left-hand": "raise-left-hand", "raise-up-right-hand": "raise-right-hand",
}

HDM05 = {
    "depositFloorR": "deposit-floor", "elbowToKnee": "elbow-to-knee", "grabHighR": "grab-high",
    "hopBothLegs": "hop", "jogLeftCircle": "jog-in-circle", "kickLFront": "kick",
    "lieDownFloor": "lie-down", "rotateArmsBothBackward": "rotate-arms", "sneak": "sneak",
    "squat": "squat", "throwBasketball": "throw",
}

# CMU trial descriptions: the first rule whose keyword occurs in the description wins. A verb wins over a
# setting: "playground" alone says climb only when no other rule's verb occurs ("playground - forward jumps,
# turn around" is a jump: its 16 windows were climb until the third wave, measured in docs/DATA.md).
CMU_RULES: list[tuple[tuple[str, ...], str]] = [
    (("dribble", "basketball"), "dribble"),
    (("climb",), "climb"),
    (("swordplay", "sword"), "swordplay"),
    (("dance", "pirouette", "arabesque"), "dance"),
    (("punch", "strike", "box"), "punch"),
    (("kick",), "kick"),
    (("run", "jog"), "run"),
    (("walk",), "walk"),
    (("jump", "hop"), "jump"),
    (("wash",), "wash"),
    (("scoop", "pick up", "bend over"), "pick-up"),
    (("playground",), "climb"),
]


def cmu_action(description: str) -> str:
    d = description.lower()
    for keys, label in CMU_RULES:
        if any(re.search(r"\b" + re.escape(k), d) for k in keys):
            return label
    return "other"


# The split (emdm.data.split) stratifies a take by its setting here, not by its label: the playground session's
# takes are split together as they were when the shipped models were trained. Relabelling 01_01 as a jump would
# otherwise reshuffle the climb takes and put two the models were trained on into the test split.
CMU_SPLIT_STRATA = {"playground": "climb"}


def cmu_stratum(description: str) -> str:
    """The group the split stratifies a CMU take by: its setting's (the text before " - ") where listed in
    ``CMU_SPLIT_STRATA``, else its action."""
    setting = description.split(" - ", 1)[0].strip().lower() if " - " in description else ""
    return CMU_SPLIT_STRATA.get(setting) or cmu_action(description)


def hdm05_action(name: str) -> str:
    """'kickLFront1Reps' -> 'kick' (matches the longest known HDM05 action prefix)."""
    for key in sorted(HDM05, key=len, reverse=True):
        if name.startswith(key):
            return HDM05[key]
    raise KeyError(f"unknown HDM05 action {name!r} (known: {', '.join(sorted(HDM05))})")


_SWAP = re.compile(r"\b(left|right)\b")


def mirror_label(label: str) -> str:
    """Swap 'left' and 'right' in a label (or any hyphen/space separated text)."""
    return _SWAP.sub(lambda m: "right" if m.group(1) == "left" else "left", label)


def vocabulary(labels: set[str] | list[str]) -> list[str]:
    """Sorted vocabulary, closed under mirroring (a left label implies its right twin)."""
    out = set(labels)
    out |= {mirror_label(x) for x in out}
    return sorted(out)
