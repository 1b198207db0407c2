"""How much of a real motion one denoising step keeps, per noise level: real test clips of an action are noised to
each step's level of the sampler's schedule, x = a·x0 + s·ε, and the model gives one x̂0 for them with the action's
plain prompt (the page's guidance, only where the manifest guides: t > guidanceMinTime); the kinematic descriptors
of x̂0 (``emdm.eval.kinematics``) are set against the clips' own.

    python -m emdm.eval.retention [--model emdm-t2m-web | --ckpt FILE] [--actions wave-right-hand,dance,walk]

Where a descriptor of the sampled motions falls short of the real clips' (a wave held still), this says from which
noise level on the model no longer keeps it even when the input shows it (docs/MODELS.md "Slice 5": the shipped text
model keeps half a real wave at t = 0.1 and none from t = 0.6): the step counts and noise levels a training change
has to reach. Prints a table per action (medians over the clips, and as a share of the real clips' median) and
writes a JSON with ``--out``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from emdm import paths
from emdm.data.dataset import DatasetError
from emdm.eval.args import add_model_source
from emdm.eval.coverage import PROMPTS_FILE, CoverageError, load_prompts, model_defaults
from emdm.eval.data import load_split
from emdm.eval.kinematics import descriptors
from emdm.eval.results import write_result
from emdm.model.open import ModelError, open_model
from emdm.motion.features import recover_joints
from emdm.sampler.condition import make_condition
from emdm.sampler.flags import add_guidance_min_time
from emdm.sampler.schedule import make_schedule

ACTIONS = ("wave-right-hand", "wave-left-hand", "wave-both-hands", "dance", "walk")
# per action, the descriptors that say whether its motion is kept (the rest are printed with --all)
KEYS = {"wave-right-hand": ("wave_r", "arm_speed"), "wave-left-hand": ("wave_l", "arm_speed"),
        "wave-both-hands": ("wave_l", "wave_r", "arm_speed"), "dance": ("arm_speed", "leg_speed"),
        "walk": ("speed", "leg_speed"), "run": ("speed", "leg_speed"), "kick": ("foot_high", "leg_speed"),
        "punch": ("peak_speed", "arm_speed"), "jump": ("airborne", "pelvis_drop")}
DEFAULT_KEYS = ("arm_speed", "leg_speed", "peak_speed")


def one_step(step, x: np.ndarray, z: np.ndarray, cond: np.ndarray, t: float, guidance: float,
             guided: bool) -> np.ndarray:
    """x̂0 of a batch x (B, F, D) at time t, as the sampler's step takes it: with guidance g where ``guided``, one
    call on [c, 0] and x̂0 = x̂0_u + g·(x̂0_c − x̂0_u)."""
    b, f = x.shape[:2]
    c = np.repeat(np.asarray(cond, np.float32)[None], b, 0)
    if guided:
        xin, zin, cin = np.concatenate([x, x]), np.concatenate([z, z]), np.concatenate([c, np.zeros_like(c)])
    else:
        xin, zin, cin = x, z, c
    out = np.asarray(step(xin, zin, cin, np.full(len(xin), t, np.float32), np.ones((len(xin), f), np.float32)),
                     np.float32)
    return out[b:] + np.float32(guidance) * (out[:b] - out[b:]) if guided else out


def retention(step, clips: list[np.ndarray], cond: np.ndarray, mean: np.ndarray, std: np.ndarray, *, steps: int = 10,
              guidance: float = 1.0, guidance_min_time: float = 0.0, z_dim: int = 64, seed: int = 0) -> dict:
    """{"real": [descriptors per clip], "levels": [{"t", "noise", "guided", "x0": [descriptors per clip]}, ...]}:
    each raw clip (F, 263) normalised, noised to each of the ``steps``-step schedule's levels (x_{k+1} of time[k]),
    one x̂0 each (clip by clip: their lengths differ), de-normalised and described."""
    sch = make_schedule(steps)
    rng = np.random.default_rng(seed)
    real = [descriptors(recover_joints(c)) for c in clips]
    levels = []
    for k in range(steps):
        t = float(sch.time[k])
        guided = guidance != 1.0 and t > guidance_min_time and bool(np.any(cond != 0))
        got = []
        for c in clips:
            x0 = ((c - mean) / std).astype(np.float32)[None]
            x = (np.float32(sch.a_cum[k + 1]) * x0
                 + np.float32(sch.s_cum[k + 1]) * rng.standard_normal(x0.shape, dtype=np.float32))
            z = rng.standard_normal((1, z_dim), dtype=np.float32)
            y = one_step(step, x, z, cond, t, guidance, guided)[0]
            got.append(descriptors(recover_joints(y * std + mean)))
        levels.append({"t": round(t, 4), "noise": round(float(sch.s_cum[k + 1]), 4), "guided": guided, "x0": got})
    return {"real": real, "levels": levels}


def summary(res: dict, keys: tuple[str, ...]) -> dict:
    """Per descriptor: the real clips' median and, per level, x̂0's median and its share of the real one."""
    med = lambda rows, k: float(np.median([r[k] for r in rows]))      # noqa: E731
    out = {}
    for k in keys:
        r = med(res["real"], k)
        out[k] = {"real": r, "levels": [{"t": lv["t"], "median": med(lv["x0"], k),
                                         "share": (med(lv["x0"], k) / r) if r > 1e-9 else None}
                                        for lv in res["levels"]]}
    return out


def table(action: str, prompt: str, n: int, summ: dict, levels: list[dict]) -> str:
    """The figures of one action as text: a column per level (its t, noise s, g where guided)."""
    head = [f"t={lv['t']:.2f}" for lv in levels]
    noise = [f"s {lv['noise']:.2f}{' g' if lv['guided'] else ''}" for lv in levels]
    lines = [f"{action} ({n} real test clips, prompt {prompt!r}): x̂0's median (share of the real clips')",
             f"{'descriptor':12s} {'real':>7s} " + " ".join(f"{h:>12s}" for h in head),
             f"{'':12s} {'':>7s} " + " ".join(f"{h:>12s}" for h in noise)]
    for k, v in summ.items():
        share = ["–" if c["share"] is None else format(c["share"], ".0%") for c in v["levels"]]
        cells = [f"{c['median']:6.2f} ({sh})" for c, sh in zip(v["levels"], share)]
        lines.append(f"{k:12s} {v['real']:7.2f} " + " ".join(f"{c:>12s}" for c in cells))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.retention", description=__doc__.split("\n\n")[0])
    add_model_source(ap, required=False,
                     model_help="a shipped model of public/models/manifest.json (default emdm-t2m-web; ONNX Runtime)")
    ap.add_argument("--actions", default=",".join(ACTIONS))
    ap.add_argument("--clips", type=int, default=10, help="real test clips per action (a seeded choice)")
    ap.add_argument("--steps", type=int, default=10, help="the schedule whose noise levels are measured")
    ap.add_argument("--guidance", type=float, default=None, help="default: the manifest's (2.5 for checkpoints)")
    add_guidance_min_time(ap)
    ap.add_argument("--dataset", type=Path, default=paths.DATASET_DIR)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--all", action="store_true", help="every descriptor, not only the action's")
    ap.add_argument("--out", type=Path, default=None, help="also write the figures here (JSON)")
    a = ap.parse_args(argv)
    if a.clips < 1 or a.steps < 1:
        ap.error("--clips and --steps: expected ≥ 1")
    try:
        m = open_model(a.ckpt if a.ckpt is not None else (a.model or "emdm-t2m-web"), models_dir=a.models_dir,
                       variant=a.variant)
    except ModelError as e:
        print(f"emdm.eval.retention: {e}", file=sys.stderr)
        return 2
    if m.supported_steps and a.steps not in m.supported_steps:
        print(f"emdm.eval.retention: --steps {a.steps}: the model supports {m.supported_steps}", file=sys.stderr)
        return 2
    g = model_defaults(m)[0] if a.guidance is None else a.guidance
    gmin = float(m.meta.get("guidanceMinTime", 0.0)) if a.guidance_min_time is None else a.guidance_min_time
    try:
        split = load_split(a.dataset, "test", require_action=True)
        actions = [s.strip() for s in a.actions.split(",") if s.strip()]
        unknown = [x for x in actions if x not in split.action_labels]
        if unknown:
            raise CoverageError(f"--actions: {', '.join(unknown)} not among the dataset's actions")
        prompts = load_prompts(PROMPTS_FILE, split.action_labels)
    except (CoverageError, DatasetError) as e:
        print(f"emdm.eval.retention: {str(e).splitlines()[0]}", file=sys.stderr)
        return 2
    results = {"model": str(a.ckpt or a.model or "emdm-t2m-web"), "variant": a.variant, "steps": a.steps,
               "guidance": g, "guidance_min_time": gmin, "seed": a.seed, "actions": {}}
    for action in actions:
        idx = np.flatnonzero(split.actions == split.action_labels.index(action))
        if len(idx) == 0:
            print(f"{action}: no real test clips; skipped")
            continue
        pick = np.sort(np.random.default_rng(a.seed).permutation(idx)[:a.clips])
        clips = [split.motions[i] for i in pick]
        spec = m.condition
        prompt = prompts[action][0]
        cond = make_condition(spec, prompt if spec["type"] == "text" else None,
                              action if spec["type"] == "action" else None, False, a.models_dir)
        res = retention(m.step, clips, cond, m.mean, m.std, steps=a.steps, guidance=g, guidance_min_time=gmin,
                        z_dim=m.z_dim, seed=a.seed)
        keys = tuple(res["real"][0]) if a.all else KEYS.get(action, DEFAULT_KEYS)
        summ = summary(res, keys)
        print(table(action, prompt, len(clips), summ, res["levels"]) + "\n")
        results["actions"][action] = {"prompt": prompt, "clips": [split.names[i] for i in pick], "descriptors": summ}
    if a.out is not None:
        print(f"wrote {write_result(results, a.out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
