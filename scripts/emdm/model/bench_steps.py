"""Step-by-step diagnostics of the sampler on a shipped model: where the condition acts, where the sampler's
x leaves the distribution the trainer's pairs come from, and what guidance in a limited interval keeps.

    python -m emdm.model.bench_steps --model emdm-t2m-web --steps 1,4,10 --guidance 2.5
    python -m emdm.model.bench_steps --model emdm-t2m-web --prompts "a person kicks" "a person bows" --guidance 1
    python -m emdm.model.bench_steps --model emdm-t2m-web emdm-a2m-web diffusion-t2m-web --steps 10 --interval

Runs ``emdm.sampler.sample_features`` (the sampler itself, with a step function that records what it is given and
returns), and prints per step k (time t = t_{k+1}): std of the sampler's input x (the trainer's x_{k+1} has
std √(a² Var x_0 + s²) ≈ 1 for normalised data), std of the conditional x̂_0, and the condition's effect
|x̂_0(c) − x̂_0(0)| / |x̂_0(0)|; then the final motion's mean within-clip (temporal) std: near 0 is a frozen pose.
A text model is conditioned on ``--prompts``, an action model on each of its labels (or ``--prompts`` naming labels).

``--interval``: guidance in a limited interval (``SamplingSettings.guidance_min_time`` = τ, the manifest's
``guidanceMinTime``): for each τ on the step grid, the share of guidance's effect on the final motion that is kept,
1 − |x(τ) − x(guided everywhere)| / |x(no guidance) − x(guided everywhere)| over all conditions and seeds (same
seeds, same noise), the largest per-condition loss, and the model rows the sampler runs (2 per guided step, 1 per
other step; guided everywhere = 2·T).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np

from emdm.model.open import onnx_step
from emdm.sampler import SamplingSettings, make_condition, sample_features
from emdm.sampler.schedule import make_schedule
from emdm import manifest as mf
from emdm import paths
from emdm import text as text_encoders      # .encode_texts looked up at each call: tests replace it

PROMPTS = ["a person kicks", "a person bows", "a person squats", "a person walks forward"]


def recorder(step, calls: list):
    def rec(x, z, c, t, mask):
        out = np.asarray(step(x, z, c, t, mask), np.float32)
        calls.append((x.copy(), out.copy()))
        return out
    return rec


def conditions(entry: dict, prompts: list[str] | None, models_dir: Path) -> list[tuple[str, np.ndarray]]:
    """(name, condition vector) per prompt (text model) or action label (action model)."""
    spec = entry["condition"]
    if spec["type"] == "text":
        prompts = prompts or PROMPTS
        emb = np.asarray(text_encoders.encode_texts(prompts, encoder_id=spec["encoder"], batch_size=1, models_dir=models_dir), np.float32)
        return list(zip(prompts, emb))
    labels = prompts or list(spec["labels"])
    return [(lab, make_condition(spec, None, lab, False, models_dir)) for lab in labels]


def bench_settings(entry: dict, T: int, guidance: float) -> SamplingSettings:
    """The model's method and sizes with T steps and ``guidance`` at every step, no x̂0 smoothing."""
    return dataclasses.replace(SamplingSettings.from_entry(entry, T, guidance), guidance_min_time=0.0, x0_smoothing=0.0,
                               speed_cap=0.0)


def per_step(step, conds, entry: dict, T: int, a) -> None:
    """The per-step table: input std, x̂_0 std, the condition's effect at each step time."""
    sch = make_schedule(T)
    settings = bench_settings(entry, T, a.guidance)
    effects = np.zeros((len(conds), T))
    for ci, (name, c) in enumerate(conds):
        calls: list = []
        x = sample_features(recorder(step, calls), c, a.frames, settings, a.seed, a.num)
        if a.verbose:
            print(f"  {name!r}: final within-clip std {x.std(axis=1).mean():.3f}")
        for (xin, out), k in zip(calls, range(T - 1, -1, -1)):
            xin, xc = xin[:a.num], out[:a.num]
            xu = out[a.num:] if len(out) > a.num else None
            fwd = np.sqrt(sch.a_cum[k + 1] ** 2 + sch.s_cum[k + 1] ** 2)
            effects[ci, k] = np.linalg.norm(xc - xu) / np.linalg.norm(xu) if xu is not None else np.nan
            if a.verbose:
                print(f"    k={k} t={sch.time[k]:.2f}  std(x) {xin.std():.3f} (trainer ≈{fwd:.2f})  "
                      f"std(x̂0|c) {xc.std():.3f}  |x̂0(c)−x̂0(0)|/|x̂0(0)| {effects[ci, k]:.4f}")
    print(f"  condition's effect |x̂0(c)−x̂0(0)|/|x̂0(0)| per step time (median / max over {len(conds)} conditions):")
    for k in range(T - 1, -1, -1):
        col = effects[:, k]
        print(f"    t={sch.time[k]:.4f}  {np.nanmedian(col):.4f} / {np.nanmax(col):.4f}")


def interval_table(step, conds, entry: dict, T: int, a) -> None:
    """For each threshold τ on the grid: the share of guidance's effect on the final motion kept."""
    sch = make_schedule(T)
    everywhere, plain = bench_settings(entry, T, a.guidance), bench_settings(entry, T, 1.0)
    full, none = [], []
    for _, c in conds:
        full.append(sample_features(step, c, a.frames, everywhere, a.seed, a.num))
        none.append(sample_features(step, c, a.frames, plain, a.seed, a.num))
    effect = [np.linalg.norm(f - n) for f, n in zip(full, none)]
    print(f"  guidance in a limited interval (guided where t > τ), final motion vs guided everywhere, "
          f"{len(conds)} conditions × {a.num} seeds; guidance's effect |x(s={a.guidance:g}) − x(s=1)|/|x(s={a.guidance:g})| "
          f"{sum(effect) / sum(np.linalg.norm(f) for f in full):.3f}:")
    print(f"    {'τ':>8}  guided steps  rows (of {2 * T})  kept (all)  kept (worst condition)")
    for tau in [0.0] + [float(t) for t in sch.time[:-1]]:
        at_tau = dataclasses.replace(everywhere, guidance_min_time=tau)
        part = [sample_features(step, c, a.frames, at_tau, a.seed, a.num) for _, c in conds]
        lost = [np.linalg.norm(p - f) for p, f in zip(part, full)]
        guided = int(np.sum(sch.time > tau))
        print(f"    {tau:8.4f}  {guided:>12}  {T + guided:>14}  {1 - sum(lost) / sum(effect):10.4f}  "
              f"{min(1 - lo / e for lo, e in zip(lost, effect)):22.4f}")


def main(argv=None) -> int:

    ap = argparse.ArgumentParser(prog="python -m emdm.model.bench_steps", description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", nargs="+", default=["emdm-t2m-web"])
    ap.add_argument("--models-dir", type=Path, default=None)
    ap.add_argument("--variant", default=None, help="a manifest variant such as int8 (default: the fp32 file)")
    ap.add_argument("--prompts", nargs="+", default=None, help="text prompts, or action labels for an action model "
                    f"(default: {PROMPTS} / every label)")
    ap.add_argument("--steps", default="1,4,10")
    ap.add_argument("--guidance", type=float, default=2.5)
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--num", type=int, default=8, help="seeds (one batch)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--interval", action="store_true", help="also the guidance-interval table (one more run per τ)")
    ap.add_argument("--verbose", action="store_true", help="per condition, per step: input std, x̂0 std, effect")
    a = ap.parse_args(argv)
    models_dir = paths.models_dir(a.models_dir)
    manifest = mf.load(models_dir)
    for name in a.model:
        if name not in manifest["models"]:
            ap.error(f"--model {name}: not in {models_dir / 'manifest.json'} (models: {', '.join(manifest['models'])})")
        entry = manifest["models"][name]
        onnx = entry["variants"][a.variant] if a.variant else entry["onnx"]
        step = onnx_step(models_dir / onnx, a.threads)
        conds = conditions(entry, a.prompts, models_dir)
        for T in [int(s) for s in a.steps.split(",")]:
            if T not in entry["supportedSteps"]:
                print(f"\n{name}: {T} steps not in its supportedSteps {entry['supportedSteps']}; skipped")
                continue
            print(f"\n{name} ({onnx}): {T} steps, guidance {a.guidance}, {a.num} seeds, {a.frames} frames")
            per_step(step, conds, entry, T, a)
            if a.interval:
                interval_table(step, conds, entry, T, a)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
