"""Step-by-step diagnostics of the sampler on a shipped model: where the prompt acts and where the sampler's
x leaves the distribution the trainer's pairs come from.

    python -m emdm.model.bench_steps --model emdm-t2m-web --steps 1,4,10 --guidance 2.5
    python -m emdm.model.bench_steps --model emdm-t2m-web --prompts "a person kicks" "a person bows" --guidance 1

Runs ``emdm.sample.sample_features`` (the sampler itself, with a step function that records what it is given and
returns), and prints per step k (time t = t_{k+1}): std of the sampler's input x (the trainer's x_{k+1} has
std √(a² Var x_0 + s²) ≈ 1 for normalised data), std of the conditional x̂_0, and the condition's effect
|x̂_0(c) − x̂_0(0)| / |x̂_0(0)|; then the final motion's mean within-clip (temporal) std: near 0 is a frozen pose.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emdm.model.schedule import make_schedule

PROMPTS = ["a person kicks", "a person bows", "a person squats", "a person walks forward"]


def recorder(step, calls: list):
    def rec(x, z, c, t, mask):
        out = np.asarray(step(x, z, c, t, mask), np.float32)
        calls.append((x.copy(), out.copy()))
        return out
    return rec


def main(argv=None) -> int:
    from emdm import manifest as mf
    from emdm.paths import MODELS_DIR
    from emdm.sample import onnx_step, sample_features
    from emdm.text import encode_texts

    ap = argparse.ArgumentParser(prog="python -m emdm.model.bench_steps", description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", default="emdm-t2m-web")
    ap.add_argument("--models-dir", type=Path, default=None)
    ap.add_argument("--prompts", nargs="+", default=PROMPTS)
    ap.add_argument("--steps", default="1,4,10")
    ap.add_argument("--guidance", type=float, default=2.5)
    ap.add_argument("--frames", type=int, default=120)
    ap.add_argument("--num", type=int, default=8, help="seeds (one batch)")
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args(argv)
    models_dir = Path(a.models_dir or MODELS_DIR)
    entry = mf.load(models_dir)["models"][a.model]
    step = onnx_step(models_dir / entry["onnx"], a.threads)
    emb = np.asarray(encode_texts(a.prompts, encoder_id=entry["condition"]["encoder"], batch_size=1), np.float32)
    for T in [int(s) for s in a.steps.split(",")]:
        sch = make_schedule(T)
        print(f"\n{a.model}: {T} steps, guidance {a.guidance}, {a.num} seeds, {a.frames} frames")
        for prompt, c in zip(a.prompts, emb):
            calls: list = []
            x = sample_features(recorder(step, calls), c, a.frames, steps=T, guidance=a.guidance, seed=0, num=a.num,
                                z_dim=int(entry.get("zDim", 64)))
            print(f"  {prompt!r}: final within-clip std {x.std(axis=1).mean():.3f}")
            for (xin, out), k in zip(calls, range(T - 1, -1, -1)):
                xin, xc = xin[:a.num], out[:a.num]
                xu = out[a.num:] if len(out) > a.num else None
                fwd = np.sqrt(sch.a_cum[k + 1] ** 2 + sch.s_cum[k + 1] ** 2)
                eff = f"{np.linalg.norm(xc - xu) / np.linalg.norm(xu):.3f}" if xu is not None else "-"
                print(f"    k={k} t={sch.time[k]:.2f}  std(x) {xin.std():.3f} (trainer ≈{fwd:.2f})  "
                      f"std(x̂0|c) {xc.std():.3f}  |x̂0(c)−x̂0(0)|/|x̂0(0)| {eff}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
