"""A second judge of meaning, independent of the action classifier: kinematic descriptors and one readable rule
per action of the vocabulary (issue 28).

    python -m emdm.eval.kinematics --data data/dataset          # each rule's pass rates on the train and test clips

A motion is given as joints (F, 22, 3) in metres, Y up, floor at y = 0, 20 fps (``recover_joints`` of the 263-d
features). ``descriptors`` reduces it to a few numbers a person can check against a video (root speed, direction
of travel against the body's facing, turning angle, hand heights, head and pelvis drops, foot height, frames with
both feet off the floor, ...). ``RULES`` says, per action, which ranges of those numbers the action needs, e.g.
walk = ``speed ≥ 0.5 and speed ≤ 1.85 and forward ≥ 0.6``. The thresholds were read off the train split's clips
(``python -m emdm.eval.kinematics`` prints each rule's pass rate there and on the test split); an action is
*judged* only when its rule passes ≥ ``BAR`` of its own real test clips (``validate``), of which it needs at least
coverage's ``MIN_CLIPS``, and the rule's false-pass rate on the other actions' clips is reported beside it. Actions
without a rule, or whose rule misses the bar or has too few test clips, are reported as not judged.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from emdm.eval import data as evdata
from emdm.eval.coverage import MIN_CLIPS
from emdm.motion.features import recover_joints
from emdm.paths import DATASET_DIR

FPS = 20.0
BAR = 0.85                 # a rule judges an action when it passes at least this share of the action's real test clips
MOVING = 0.3               # m/s: frames whose root moves faster count for the direction of travel
AIRBORNE = 0.10            # m: a frame is airborne when the lowest ankle/toe joint is above this
FEET = [7, 8, 10, 11]      # l_ankle, r_ankle, l_foot, r_foot
HEAD, PELVIS = 15, 0
WRIST = {"l": 20, "r": 21}
SHOULDER = {"l": 16, "r": 17}
ELBOW = {"l": 18, "r": 19}

# descriptor: what it measures (the report prints these)
DESCRIPTORS = {
    "speed": "median horizontal root speed, m/s",
    "forward": "mean cosine between the direction of travel and the body's facing (moving frames; 1 = forwards, −1 = backwards)",
    "lateral": "mean cosine between the direction of travel and the body's left (moving frames; 1 = to its left)",
    "turn": "heading change from the first to the last frame, degrees (positive = to the left)",
    "turning": "size of that heading change, degrees",
    "travel": "horizontal distance from the first to the last frame, m",
    "head_drop": "95th-percentile head height minus the lowest, m",
    "head_min": "lowest head height, m",
    "pelvis_drop": "95th-percentile pelvis height minus the lowest, m",
    "lean": "largest forward offset of the head from the pelvis along the facing, m",
    "hand_up_l": "highest the left wrist gets above the left shoulder, m",
    "hand_up_r": "highest the right wrist gets above the right shoulder, m",
    "wave_l": "mean sideways (body left–right) speed of the left wrist relative to its shoulder while above the elbow, m/s",
    "wave_r": "mean sideways (body left–right) speed of the right wrist relative to its shoulder while above the elbow, m/s",
    "reach": "largest forward reach of a wrist from its shoulder along the facing, m",
    "foot_high": "largest height of an ankle above the other ankle, m",
    "airborne": "share of frames with both feet off the floor (lowest ankle/toe above 10 cm)",
    "arm_speed": "mean speed of the wrists relative to the pelvis, m/s",
    "leg_speed": "mean speed of the ankles relative to the pelvis, m/s",
    "peak_speed": "95th percentile over frames of the fastest joint's speed, m/s: whether the body moves at all (a "
                  "figure holding a pose: ≈ 0; one throw in 4 s: ≈ 2)",
}

# action: conditions (descriptor, ">=" | "<=", threshold), all of which must hold. Thresholds read off the train split.
RULES: dict[str, tuple[tuple[str, str, float], ...]] = {
    "walk": (("speed", ">=", 0.4), ("speed", "<=", 1.7), ("forward", ">=", 0.6)),
    "run": (("speed", ">=", 1.6), ("speed", "<=", 4.0), ("forward", ">=", 0.8), ("turning", "<=", 60)),
    "sprint": (("speed", ">=", 2.5), ("forward", ">=", 0.8)),
    "jog-in-circle": (("speed", ">=", 1.2), ("speed", "<=", 2.3), ("turning", ">=", 60)),
    "sneak": (("speed", ">=", 0.3), ("speed", "<=", 0.8), ("forward", ">=", 0.7), ("lean", ">=", 0.18)),
    "walk-backward": (("speed", ">=", 0.3), ("forward", "<=", -0.7)),
    "walk-left": (("speed", ">=", 0.3), ("lateral", ">=", 0.25)),
    "walk-right": (("speed", ">=", 0.3), ("lateral", "<=", -0.25)),
    "walk-turn-left": (("speed", ">=", 0.5), ("turn", ">=", 45)),
    "walk-turn-right": (("speed", ">=", 0.5), ("turn", "<=", -45)),
    "raise-left-hand": (("hand_up_l", ">=", -0.08), ("hand_up_r", "<=", -0.2), ("leg_speed", "<=", 0.2)),
    "raise-right-hand": (("hand_up_r", ">=", -0.08), ("hand_up_l", "<=", -0.2), ("leg_speed", "<=", 0.2)),
    "raise-both-hands": (("hand_up_l", ">=", -0.08), ("hand_up_r", ">=", -0.08), ("leg_speed", "<=", 0.2)),
    "wave-left-hand": (("hand_up_l", ">=", -0.08), ("hand_up_r", "<=", -0.2), ("wave_l", ">=", 0.2), ("leg_speed", "<=", 0.2)),
    "wave-right-hand": (("hand_up_r", ">=", -0.08), ("hand_up_l", "<=", -0.2), ("wave_r", ">=", 0.2), ("leg_speed", "<=", 0.2)),
    "wave-both-hands": (("hand_up_l", ">=", -0.08), ("hand_up_r", ">=", -0.08), ("wave_l", ">=", 0.2), ("wave_r", ">=", 0.2),
                        ("leg_speed", "<=", 0.2)),
    "squat": (("pelvis_drop", ">=", 0.4), ("head_min", ">=", 0.75), ("airborne", "<=", 0.05), ("travel", "<=", 0.3)),
    "bow": (("lean", ">=", 0.25), ("pelvis_drop", "<=", 0.12), ("travel", "<=", 0.3)),
    "lie-down": (("head_min", "<=", 0.35),),
    "pick-up": (("head_min", "<=", 0.7), ("head_min", ">=", 0.45), ("lean", ">=", 0.45), ("speed", "<=", 0.3)),
    "deposit-floor": (("head_drop", ">=", 0.6), ("head_min", ">=", 0.5), ("lean", ">=", 0.45), ("speed", "<=", 0.6)),
    "kick": (("foot_high", ">=", 0.5), ("speed", "<=", 0.8), ("head_min", ">=", 1.2)),
    "jump": (("airborne", ">=", 0.08), ("pelvis_drop", ">=", 0.4), ("travel", "<=", 0.5)),
    "climb": (("airborne", ">=", 0.1), ("pelvis_drop", ">=", 0.3)),
    "dance": (("leg_speed", ">=", 0.3), ("arm_speed", ">=", 0.5), ("speed", "<=", 1.0), ("head_min", ">=", 0.7)),
}


def facing(j: np.ndarray) -> np.ndarray:
    """(F, 2) unit xz vector the body faces, from the hips and shoulders (left minus right, turned by −90° about Y)."""
    across = (j[:, 1] - j[:, 2]) + (j[:, 16] - j[:, 17])
    f = np.stack([-across[:, 2], across[:, 0]], axis=1)          # (x, z): cross(across, up)
    return f / np.maximum(np.linalg.norm(f, axis=1, keepdims=True), 1e-9)


def _hand(j: np.ndarray, s: str, left: np.ndarray) -> tuple[float, float]:
    """(hand_up, wave) of side ``s``; ``left`` (F-1, 2) is the body's left per frame pair."""
    rel = j[:, WRIST[s]] - j[:, SHOULDER[s]]
    up = j[:, WRIST[s], 1] > j[:, ELBOW[s], 1]
    side = np.abs(np.einsum("fi,fi->f", np.diff(rel[:, [0, 2]], axis=0), left)) * FPS
    raised = up[1:] & up[:-1]
    return float(rel[:, 1].max()), float(side[raised].mean()) if raised.any() else 0.0


def descriptors(joints, fps: float = FPS) -> dict[str, float]:
    """The DESCRIPTORS of one motion (F ≥ 2, 22, 3)."""
    j = np.asarray(joints, np.float64)
    if j.ndim != 3 or j.shape[1:] != (22, 3) or len(j) < 2:
        raise ValueError(f"joints: expected shape (frames ≥ 2, 22, 3), got {j.shape}")
    root = j[:, PELVIS][:, [0, 2]]
    v = np.diff(root, axis=0) * fps                              # (F-1, 2)
    speed = np.linalg.norm(v, axis=1)
    f = facing(j)
    fm = (f[1:] + f[:-1]) / 2
    left = np.stack([fm[:, 1], -fm[:, 0]], axis=1)               # facing turned +90° about Y (x, z) → the body's left
    moving = speed > MOVING
    unit = v[moving] / speed[moving, None]
    heading = np.unwrap(np.arctan2(f[:, 0], f[:, 1]))
    head, pelvis = j[:, HEAD, 1], j[:, PELVIS, 1]
    lean = np.einsum("fi,fi->f", (j[:, HEAD] - j[:, PELVIS])[:, [0, 2]], f)
    reach = max(np.einsum("fi,fi->f", (j[:, WRIST[s]] - j[:, SHOULDER[s]])[:, [0, 2]], f).max() for s in "lr")
    lowest = j[:, FEET, 1].min(axis=1)
    rel = j - j[:, PELVIS:PELVIS + 1]
    limb = lambda idx: float(np.linalg.norm(np.diff(rel[:, idx], axis=0), axis=2).mean() * fps)  # noqa: E731
    (ul, wl), (ur, wr) = _hand(j, "l", left), _hand(j, "r", left)
    return {
        "speed": float(np.median(speed)),
        "forward": float(np.einsum("fi,fi->f", unit, fm[moving]).mean()) if moving.any() else 0.0,
        "lateral": float(np.einsum("fi,fi->f", unit, left[moving]).mean()) if moving.any() else 0.0,
        "turn": float(np.degrees(heading[-1] - heading[0])),
        "turning": float(abs(np.degrees(heading[-1] - heading[0]))),
        "travel": float(np.linalg.norm(root[-1] - root[0])),
        "head_drop": float(np.percentile(head, 95) - head.min()),
        "head_min": float(head.min()),
        "pelvis_drop": float(np.percentile(pelvis, 95) - pelvis.min()),
        "lean": float(lean.max()),
        "hand_up_l": ul, "hand_up_r": ur, "wave_l": wl, "wave_r": wr,
        "reach": float(reach),
        "foot_high": float(np.abs(j[:, 7, 1] - j[:, 8, 1]).max()),
        "airborne": float((lowest > AIRBORNE).mean()),
        "arm_speed": limb([20, 21]),
        "leg_speed": limb([7, 8]),
        "peak_speed": float(np.percentile(np.linalg.norm(np.diff(j, axis=0), axis=2).max(axis=1), 95) * fps),
    }


def table(motions_joints) -> dict[str, np.ndarray]:
    """Descriptors of many motions: {descriptor: (N,) array}."""
    rows = [descriptors(m) for m in motions_joints]
    return {k: np.array([r[k] for r in rows]) for k in DESCRIPTORS}


def rule_text(action: str) -> str:
    return " and ".join(f"{d} {'≥' if op == '>=' else '≤'} {t:g}" for d, op, t in RULES[action])


def holds(value, op: str, threshold: float):
    """Whether ``value`` (a number or an array of them) meets one condition of a rule, ``op`` ">=" or "<="."""
    return value >= threshold if op == ">=" else value <= threshold


def passes(action: str, desc: dict[str, np.ndarray]) -> np.ndarray:
    """(N,) bool: which motions (descriptor table ``desc``) pass ``action``'s rule."""
    n = len(next(iter(desc.values())))
    ok = np.ones(n, bool)
    for d, op, t in RULES[action]:
        ok &= holds(desc[d], op, t)
    return ok


def validate(labels: list[str], actions: np.ndarray, desc: dict[str, np.ndarray]) -> dict[str, dict]:
    """Per action with a rule: its pass rate on its own clips (``own``, n) and on all other actions' clips
    (``false_pass``), and the other action passing most often (``confused``, its rate)."""
    actions = np.asarray(actions)
    out = {}
    for i, a in enumerate(labels):
        if a not in RULES:
            continue
        ok = passes(a, desc)
        own, other = actions == i, (actions != i) & (actions >= 0)
        worst = max(((labels[k], float(ok[actions == k].mean())) for k in np.unique(actions[other])),
                    key=lambda kv: kv[1], default=(None, 0.0))
        out[a] = {"rule": rule_text(a), "n": int(own.sum()), "own": float(ok[own].mean()) if own.any() else None,
                  "false_pass": float(ok[other].mean()) if other.any() else None,
                  "confused": worst[0], "confused_rate": worst[1]}
    return out


def judged(test_validation: dict[str, dict], bar: float = BAR, min_clips: int = MIN_CLIPS) -> list[str]:
    """The actions whose rule passes ≥ ``bar`` of their own real test clips, of which they have ≥ ``min_clips``."""
    return [a for a, v in test_validation.items() if v["n"] >= max(min_clips, 1) and v["own"] >= bar]


def split_table(root: Path, split: str):
    """(labels, action ids, descriptor table) of a dataset split's real clips."""
    s = evdata.load_split(root, split, require_action=True)
    return s.action_labels, s.actions, table([recover_joints(m) for m in s.motions])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.kinematics", description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=DATASET_DIR)
    ap.add_argument("--quantiles", action="store_true", help="also print each action's train descriptor quantiles")
    a = ap.parse_args(argv)
    try:
        res = {sp: split_table(a.data, sp) for sp in ("train", "test")}
    except (FileNotFoundError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    labels = res["train"][0]
    if a.quantiles:
        _, acts, d = res["train"]
        for i, lab in enumerate(labels):
            sel = acts == i
            if sel.any():
                print(f"{lab} ({sel.sum()}): " + " ".join(
                    f"{k}={np.percentile(v[sel], 5):.2f}/{np.median(v[sel]):.2f}/{np.percentile(v[sel], 95):.2f}"
                    for k, v in d.items()))
    val = {sp: validate(labels, r[1], r[2]) for sp, r in res.items()}
    ok = judged(val["test"])
    for act in labels:
        if act not in RULES:
            print(f"{act:18s} no rule")
            continue
        tr, te = val["train"][act], val["test"][act]
        f = lambda v: "–" if v is None else f"{v:.2f}"  # noqa: E731
        print(f"{act:18s} train {f(tr['own'])} ({tr['n']}) test {f(te['own'])} ({te['n']}) false-pass {f(te['false_pass'])} "
              f"(most: {te['confused']} {te['confused_rate']:.2f}) {'judged' if act in ok else 'NOT judged'}: {rule_text(act)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
