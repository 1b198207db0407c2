"""Impossible poses over every supported setting of a model (issue 12's grid check).

    python -m emdm.eval.poses                                  # emdm-t2m-web: steps × guidance × seconds, 5 seeds
    python -m emdm.eval.poses --model emdm-a2m-web --steps 1,10 --guidance 1,2.5
    python -m emdm.eval.poses --ckpt runs/t2m-bal/ckpt.pt --json /tmp/grid.json

A model's step counts, guidance scales and lengths are all choices of the page (step slider, guidance slider
1…6, length slider up to the model's 9.8 s), so a retrained model must not give an impossible body at ANY of
them. Each setting samples ``--seeds`` motions of every prompt (``--prompts``; an action model: every label of
``--actions``), decodes the 22 joints (``emdm.motion.features.recover_joints``) and counts, per frame, the
three things a human body cannot do. The bars come from the real clips (``data/dataset/new_joints``, 1,500
random clips): their bones have exactly the reference lengths, no leg is ever longer than fully straight
(hip–ankle distance ≤ 1.000 × thigh + shin), and no joint is below the floor.

* **bone**: some bone's length is off its reference length (``skeleton.REFERENCE_OFFSETS``) by more than
  ``BONE_TOL`` (30 %). The page's IK keeps its own bone lengths, so such a frame shows as a broken, squashed or
  flung body rather than a stretched one.
* **leg**: a hip–ankle distance above ``LEG_TOL`` (1.15) × the leg's full length (thigh + shin): the ankle is
  where no straight leg reaches (e.g. ankles 0.78 m ahead of a pelvis 0.87 m up).
* **floor**: the lowest joint more than ``FLOOR_TOL`` (0.10 m) below the floor.

A setting *fails* when any of its motions has an impossible frame. Prints one row per setting (share of
impossible frames, worst bone error, worst leg stretch, deepest joint); ``--json`` writes the rows (default
``docs/results/json/poses-<model>.json``, which ``python -m emdm.eval.report`` turns into RESULTS.md's section).
Exit status 0 when no setting fails, 1 when some do (so it can gate a model before it is shipped), 2 on bad input.

JSON: {"schema": 1, "task": "poses", "name": model, "variant", "seeds", "conditions": [...], "bars": {...},
"rows": [{"steps", "guidance", "seconds", "motions", "failed_motions", "impossible_share", ..., "ok"}]}
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import sys
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.sampler import SampleError, make_condition, sample_features
from emdm.eval.args import add_model_source
from emdm.eval.results import RESULTS_DIR, hardware, slug
from emdm.model.open import ModelError, open_model
from emdm.motion.features import recover_joints
from emdm.outdir import OutputRefused, check_writable
from emdm.sampler.flags import add_sampling_settings

BONE_TOL = 0.30
LEG_TOL = 1.15
FLOOR_TOL = 0.10
LEGS = ((1, 4, 7), (2, 5, 8))            # (hip, knee, ankle), left and right
PROMPTS = ["a person walks forward", "a person kicks with the right leg", "a person waves with both hands"]
STEPS = [1, 2, 4, 10]
GUIDANCE = [1.0, 2.5, 6.0]               # the page's slider: 1 … 6
SECONDS = [2.0, 6.0, 9.8]

_REF = np.linalg.norm(sk.REFERENCE_OFFSETS[1:], axis=1)        # (21,) bone j+1 → its parent
_PARENTS = np.asarray(sk.PARENTS[1:])


class PosesError(ValueError):
    """A grid request that cannot be run (the message says which option and why)."""


@dataclass(frozen=True)
class FrameChecks:
    """Per-frame booleans (F,) of the three impossibilities, and the worst values behind them."""
    bone: np.ndarray
    leg: np.ndarray
    floor: np.ndarray
    worst_bone: float          # max relative bone-length error
    worst_leg: float           # max hip–ankle distance / (thigh + shin)
    lowest: float              # min joint height, m

    @property
    def impossible(self) -> np.ndarray:
        return self.bone | self.leg | self.floor


def check_frames(joints) -> FrameChecks:
    """The impossibilities of each frame of ``joints`` (F, 22, 3), metres, Y up, floor at 0."""
    j = np.asarray(joints, dtype=np.float64)
    if j.ndim != 3 or j.shape[1:] != (sk.NUM_JOINTS, 3) or j.shape[0] < 1:
        raise PosesError(f"joints: expected shape (frames, {sk.NUM_JOINTS}, 3), got {j.shape}")
    if not np.all(np.isfinite(j)):
        f = int(np.argwhere(~np.isfinite(j))[0][0])
        raise PosesError(f"joints: non-finite position at frame {f}")
    bone_err = np.abs(np.linalg.norm(j[:, 1:] - j[:, _PARENTS], axis=-1) / _REF - 1.0).max(axis=1)
    stretch = np.stack([np.linalg.norm(j[:, a] - j[:, h], axis=-1) / (_REF[k - 1] + _REF[a - 1])
                        for h, k, a in LEGS]).max(axis=0)
    low = j[:, :, 1].min(axis=1)
    return FrameChecks(bone=bone_err > BONE_TOL, leg=stretch > LEG_TOL, floor=low < -FLOOR_TOL,
                       worst_bone=float(bone_err.max()), worst_leg=float(stretch.max()), lowest=float(low.min()))


@dataclass(frozen=True)
class Row:
    steps: int
    guidance: float
    seconds: float
    motions: int
    failed_motions: int         # motions with at least one impossible frame
    impossible_share: float     # impossible frames / all frames
    bone_share: float
    leg_share: float
    floor_share: float
    worst_bone: float
    worst_leg: float
    lowest: float

    @property
    def ok(self) -> bool:
        return self.failed_motions == 0


def setting_row(steps: int, guidance: float, seconds: float, motions: list[np.ndarray]) -> Row:
    checks = [check_frames(m) for m in motions]
    frames = sum(len(c.bone) for c in checks)
    share = lambda attr: float(sum(getattr(c, attr).sum() for c in checks) / frames)  # noqa: E731
    return Row(steps=steps, guidance=guidance, seconds=seconds, motions=len(checks),
               failed_motions=sum(bool(c.impossible.any()) for c in checks),
               impossible_share=float(sum(c.impossible.sum() for c in checks) / frames),
               bone_share=share("bone"), leg_share=share("leg"), floor_share=share("floor"),
               worst_bone=max(c.worst_bone for c in checks), worst_leg=max(c.worst_leg for c in checks),
               lowest=min(c.lowest for c in checks))


def conditions(opened, prompts: list[str], actions: list[str] | None) -> list[tuple[str, np.ndarray]]:
    """(label, condition vector) for every prompt (text model) or action label (action model)."""
    spec = opened.meta["condition"]
    if spec["type"] == "text":
        return [(p, make_condition(spec, p, None, False, opened.models_dir)) for p in prompts]
    labels = actions if actions else list(spec.get("labels", []))
    if not labels:
        raise PosesError("--actions: the action model lists no labels; name them with --actions")
    return [(a, make_condition(spec, None, a, False, opened.models_dir)) for a in labels]


def run_grid(opened, steps: list[int], guidance: list[float], seconds: list[float], seeds: int,
             conds: list[tuple[str, np.ndarray]], seed: int = 0, log=print,
             guidance_min_time: float | None = None, x0_smoothing: float | None = None) -> list[Row]:
    """Sample every (steps, guidance, seconds) setting for every condition and ``seeds`` seeds; one row each.
    ``guidance_min_time``: guide only steps above it (None: the model's manifest guidanceMinTime, else 0);
    ``x0_smoothing``: σ of x̂_0's smoothing along time (None: the manifest's x0Smoothing, else 0)."""

    meta = opened.meta
    supported = meta.get("supportedSteps")
    bad = [s for s in steps if s < 1 or (supported and s not in supported)]
    if bad:
        raise PosesError(f"--steps {','.join(map(str, bad))}: the model supports {supported}")
    max_s = meta["maxFrames"] / sk.FPS
    too_long = [s for s in seconds if not (0 < s <= max_s + 1e-9)]
    if too_long:
        raise PosesError(f"--seconds {','.join(map(str, too_long))}: lengths must be in (0, {max_s:g}] s for this model")
    if any(not np.isfinite(g) or g < 1 for g in guidance):
        raise PosesError(f"--guidance {guidance}: scales must be finite and ≥ 1")
    model = opened.settings()
    gmin = model.guidance_min_time if guidance_min_time is None else guidance_min_time
    sigma = model.x0_smoothing if x0_smoothing is None else x0_smoothing
    rows = []
    for T, g, sec in itertools.product(steps, guidance, seconds):
        t0 = time.perf_counter()
        frames = max(2, min(meta["maxFrames"], int(round(sec * sk.FPS))))
        motions = []
        for ci, (_, c) in enumerate(conds):
            settings = dataclasses.replace(model, steps=T, guidance=g, guidance_min_time=gmin, x0_smoothing=sigma)
            x = sample_features(opened.step, c, frames, settings, seed + 1000 * ci, seeds)
            motions += [recover_joints(xi * opened.std + opened.mean) for xi in x]
        row = setting_row(T, g, sec, motions)
        rows.append(row)
        log(f"steps {T:>3}  guidance {g:<4g} {sec:>4g} s  "
            f"{'ok  ' if row.ok else 'FAIL'} {row.failed_motions:>3}/{row.motions} motions, "
            f"{row.impossible_share:6.1%} frames impossible (bone {row.bone_share:.1%}, leg {row.leg_share:.1%}, "
            f"floor {row.floor_share:.1%}); worst bone {row.worst_bone:.0%}, leg {row.worst_leg:.2f}×, "
            f"lowest {row.lowest:+.2f} m  ({time.perf_counter() - t0:.1f} s)")
    return rows


def default_json(ref, variant: str | None) -> Path:
    name = Path(ref).parent.name if isinstance(ref, Path) else str(ref)
    return RESULTS_DIR / "json" / f"poses-{slug(name)}{'' if variant in (None, 'fp32') else '-' + variant}.json"


def section(r: dict) -> list[str]:
    """RESULTS.md lines for one poses JSON: the failing settings of the grid, or that none fails."""
    rows = r["rows"]
    bad = [x for x in rows if not x["ok"]]
    head = (f"**{r['name']}** ({r.get('variant', 'fp32')}; {len(r.get('conditions', []))} conditions × {r.get('seeds')} "
            f"seeds per setting): {len(bad)} of {len(rows)} settings give an impossible pose")
    if not bad:
        return [head + ".", ""]
    table = ["| steps | guidance | seconds | motions failing | impossible frames (bone / leg / floor) | worst bone | "
             "worst leg | lowest joint |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    table += [f"| {x['steps']} | {x['guidance']:g} | {x['seconds']:g} | {x['failed_motions']}/{x['motions']} | "
              f"{x['impossible_share']:.1%} ({x['bone_share']:.1%} / {x['leg_share']:.1%} / {x['floor_share']:.1%}) | "
              f"{x['worst_bone']:.0%} | {x['worst_leg']:.2f}× | {x['lowest']:+.2f} m |" for x in bad]
    return [head + ":", "", *table, ""]


def build_parser() -> argparse.ArgumentParser:
    ints = lambda s: [int(x) for x in s.split(",") if x.strip()]      # noqa: E731
    floats = lambda s: [float(x) for x in s.split(",") if x.strip()]  # noqa: E731
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.poses", description=__doc__.split("\n\n")[0])
    add_model_source(ap, required=False,
                     model_help="a shipped model of public/models/manifest.json (default emdm-t2m-web)")
    ap.add_argument("--steps", type=ints, default=None, help="default 1,2,4,10 (those the model supports)")
    ap.add_argument("--guidance", type=floats, default=GUIDANCE)
    add_sampling_settings(ap)
    ap.add_argument("--seconds", type=floats, default=SECONDS)
    ap.add_argument("--seeds", type=int, default=5, help="motions per prompt and setting")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--prompts", type=lambda s: [p.strip() for p in s.split(";") if p.strip()], default=PROMPTS,
                    help="text model: prompts separated by ';'")
    ap.add_argument("--actions", type=lambda s: [p.strip() for p in s.split(",") if p.strip()], default=None,
                    help="action model: labels separated by ',' (default: all of the model's)")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu", help="with --ckpt: cpu or cuda")
    ap.add_argument("--json", type=Path, default=None, help="write the rows here (default docs/results/json/poses-<model>.json)")
    ap.add_argument("--no-json", action="store_true", help="print only")
    return ap


def main(argv: list[str] | None = None) -> int:

    a = build_parser().parse_args(argv)
    try:
        if a.seeds < 1:
            raise PosesError(f"--seeds {a.seeds}: need at least 1")
        ref = a.ckpt if a.ckpt is not None else (a.model or "emdm-t2m-web")
        out = None if a.no_json else check_writable(a.json or default_json(ref, a.variant), option="--json")
        opened = open_model(ref, models_dir=a.models_dir, variant=a.variant, device=a.device, threads=a.threads)
        supported = opened.meta.get("supportedSteps")
        steps = a.steps if a.steps is not None else [s for s in STEPS if not supported or s in supported]
        conds = conditions(opened, a.prompts, a.actions)
        rows = run_grid(opened, steps, a.guidance, a.seconds, a.seeds, conds, a.seed,
                        guidance_min_time=a.guidance_min_time, x0_smoothing=a.x0_smoothing)
    except (PosesError, SampleError, ModelError, OutputRefused, FileNotFoundError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    failed = [r for r in rows if not r.ok]
    print(f"{len(failed)} of {len(rows)} settings give an impossible pose" if failed else
          f"no impossible pose in {len(rows)} settings")
    if out:
        tmp = out.with_suffix(out.suffix + ".tmp")

        tmp.write_text(json.dumps({"schema": 1, "task": "poses", "name": str(ref), "model": str(ref), "hardware": hardware(),
                                   "variant": a.variant or "fp32", "seeds": a.seeds, "conditions": [c for c, _ in conds],
                                   "bars": {"bone": BONE_TOL, "leg": LEG_TOL, "floor_m": FLOOR_TOL},
                                   "rows": [{**asdict(r), "ok": r.ok} for r in rows]}, indent=1))
        tmp.replace(out)
        print(f"wrote {out}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
