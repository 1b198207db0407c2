"""Two realism results side by side, per action: the three checks of a model or sampling change (the classifier, the
kinematic rule, the share of motions that move) and the speed against real, old → new; an action where any check
drops by more than ``WORSE`` (one motion in 8) is flagged; then all motions' foot skate, feet acceleration and
largest joint step (``feet``); then, for each action the new result's kinematic rule fails in most motions, the
rule's conditions its median motion misses, against the real clips' median (``rules``: "a person waves" that
raises the hand and holds it still, the shipped text model's of GPU slice 4 against slice 3's, whose result predates
the medians: ``wave-right-hand (rule passed by 0.00) misses wave_r >= 0.2: real 0.74, – → 0.08``). How a GPU
slice's candidates are judged against the shipped weights (docs/MODELS.md): a candidate that lifts the classifier while its punches stop moving is not a win.

    python -m emdm.eval.realism_diff docs/results/json/realism-OLD.json runs/lease/realism-NEW.json
    python -m emdm.eval.realism_diff OLD.json NEW.json --fail-on-worse       # exit 1 when an action got worse

Compare results of one benchmark (prompts, seeds, steps): their ``key`` fields are compared and any difference is
named on stderr (the decode and dataset may differ: a change of those is what one compares).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from emdm.eval.kinematics import RULES, holds

WORSE = 1 / 8
CHECKS = ("classifier", "kinematic", "moving")


def checks(r: dict, action: str) -> dict[str, float | None]:
    """The three checks and the speed ratio of ``action`` in result ``r`` (None where not measured)."""
    g = r["generated"]
    per = g["per_action"].get(action, {})
    return {"classifier": g["classifier"].get(action), "kinematic": g["kinematic"].get(action),
            "moving": per.get("moving"), "speed": per.get("speed_ratio")}


def diff(old: dict, new: dict, worse: float = WORSE) -> list[dict]:
    """Per action of either result: {action, old: checks, new: checks, worse: [checks that dropped by > worse],
    better: [checks that rose by > worse]}."""
    actions = sorted(set(old["generated"]["per_action"]) | set(new["generated"]["per_action"]))
    rows = []
    for a in actions:
        o, n = checks(old, a), checks(new, a)
        moved = {c: n[c] - o[c] for c in CHECKS if o[c] is not None and n[c] is not None}
        rows.append({"action": a, "old": o, "new": n, "worse": [c for c, d in moved.items() if d < -worse],
                     "better": [c for c, d in moved.items() if d > worse]})
    return rows


def key_differences(old: dict, new: dict) -> list[str]:
    ko, kn = old.get("key", {}), new.get("key", {})
    return [f"{k}: {ko.get(k)!r} → {kn.get(k)!r}" for k in sorted(set(ko) | set(kn)) if ko.get(k) != kn.get(k)]


def _f(v) -> str:
    return "   –" if v is None else f"{v:4.2f}"


def report(rows: list[dict], worse: float = WORSE) -> list[str]:
    """The table of ``diff``'s rows, the mean of each check, and the actions worse by more than ``worse``."""
    out = [f"{'action':18s} " + "  ".join(f"{c[:10]:>11s}" for c in (*CHECKS, "speed×real")) + "   verdict"]
    for r in rows:
        cells = "  ".join(f"{_f(r['old'][c])}→{_f(r['new'][c])}" for c in (*CHECKS, "speed"))
        verdict = "; ".join(f"{k}: {', '.join(r[k])}" for k in ("worse", "better") if r[k])
        out.append(f"{r['action']:18s} {cells}   {verdict}")
    for c in CHECKS:
        pairs = [(r["old"][c], r["new"][c]) for r in rows if r["old"][c] is not None and r["new"][c] is not None]
        if pairs:
            out.append(f"mean {c} over {len(pairs)} actions: {sum(p[0] for p in pairs) / len(pairs):.3f} → "
                       f"{sum(p[1] for p in pairs) / len(pairs):.3f}")
    names = [r["action"] for r in rows if r["worse"]]
    bar = f"1 motion in {round(1 / worse)}" if abs(1 / worse - round(1 / worse)) < 1e-9 else f"{worse:.3g}"
    out.append(f"actions worse by more than {bar} on a check: {', '.join(names) or 'none'}")
    return out


FEET = (("skate_cm_s", "foot skate", "cm/s", "{:.1f}"), ("foot_acc", "feet acceleration", "m/s²", "{:.0f}"),
        ("max_step", "largest joint step", "m", "{:.3f}"))


def feet(old: dict, new: dict) -> list[str]:
    """All motions' foot skate, feet acceleration and largest joint step, old → new (real): what a foot clean-up
    trades (a skate stopped makes the swing after it faster); a figure either result lacks is left out."""
    out = []
    for k, name, unit, fmt in FEET:
        o, n = old["generated"].get("all", {}).get(k), new["generated"].get("all", {}).get(k)
        if o is None or n is None:
            continue
        real = new.get("real", {}).get("all", {}).get(k)
        out.append(f"all motions' {name}: {fmt.format(o)} → {fmt.format(n)} {unit}"
                   + (f" (real clips {fmt.format(real)})" if real is not None else ""))
    return out


def _desc(r: dict, side: str, action: str) -> dict:
    return r.get(side, {}).get("per_action", {}).get(action, {}).get("desc") or {}


def rules(old: dict, new: dict) -> list[str]:
    """Per action whose kinematic rule the new result passes in fewer than half its motions: each condition of the
    rule its median motion misses, ``descriptor op threshold: real R, old O → new N`` (the real clips' median and
    the old result's, "–" where a result predates the descriptor medians)."""
    out = []
    for a, share in sorted(new["generated"].get("kinematic", {}).items()):
        med = _desc(new, "generated", a)
        if share is None or share >= 0.5 or a not in RULES or not med:
            continue
        missed = [(d, op, t) for d, op, t in RULES[a] if d in med and not holds(med[d], op, t)]
        if missed:
            real, was = _desc(new, "real", a), _desc(old, "generated", a)
            out.append(f"{a} (rule passed by {share:.2f}) misses " + "; ".join(
                f"{d} {op} {t:g}: real {_g(real.get(d))}, {_g(was.get(d))} → {_g(med[d])}" for d, op, t in missed))
    return out


def _g(v) -> str:
    return "–" if v is None else f"{v:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.realism_diff", description=__doc__.split("\n\n")[0])
    ap.add_argument("old", type=Path)
    ap.add_argument("new", type=Path)
    ap.add_argument("--fail-on-worse", action="store_true", help="exit 1 when an action got worse on a check")
    a = ap.parse_args(argv)
    res = []
    for p in (a.old, a.new):
        try:
            r = json.loads(p.read_text())
            if not isinstance(r, dict) or r.get("task") != "realism":
                raise ValueError(f"task is {r.get('task') if isinstance(r, dict) else None!r}, not 'realism'")
            if not all(isinstance(r.get("generated", {}).get(k), dict) for k in ("classifier", "kinematic", "per_action")):
                raise ValueError("no generated.classifier / kinematic / per_action")
            res.append(r)
        except (OSError, ValueError) as e:
            print(f"error: {p}: not a realism result ({e}); make one with python -m emdm.eval.realism", file=sys.stderr)
            return 2
    old, new = res
    for d in key_differences(old, new):
        print(f"note: the two runs differ in {d}", file=sys.stderr)
    rows = diff(old, new)
    print("\n".join(report(rows) + feet(old, new) + rules(old, new)))
    return 1 if a.fail_on_worse and any(r["worse"] for r in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
