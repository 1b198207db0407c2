"""Benchmark candidate generator presets: ORT CPU time of one denoising step (196 frames).

    python -m emdm.model.bench --candidates 256x4x1024,256x6x1024,192x4x768 --threads 1,2

Prints a table of ms per step for batch 1 (no guidance) and batch 2 (classifier-free guidance) and the
fp32/int8 file sizes. Weights are random (timing does not depend on them).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

from emdm.export import export_onnx, make_int8, time_step
from emdm.model.generator import Generator, Preset, count_parameters


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m emdm.model.bench")
    p.add_argument("--candidates", default="256x4x1024,256x6x1024,192x4x768",
                   help="comma list of d x layers x ff (heads = d/64)")
    p.add_argument("--threads", default="1,2")
    p.add_argument("--frames", type=int, default=196)
    p.add_argument("--cond-dim", type=int, default=384)
    p.add_argument("--int8", action="store_true")
    a = p.parse_args(argv)
    threads = [int(t) for t in a.threads.split(",")]
    print(f"{'preset':>14} {'params':>9} {'MB':>6} " + " ".join(f"{f'b{b} {th}t':>9}" for b in (1, 2) for th in threads))
    with tempfile.TemporaryDirectory() as tmp:
        for cand in a.candidates.split(","):
            d, layers, ff = (int(v) for v in cand.split("x"))
            G = Generator(a.cond_dim, Preset(d=d, layers=layers, heads=max(d // 64, 1), ff=ff))
            path = export_onnx(G, Path(tmp) / f"{cand}.onnx")
            rows = [(cand, path)]
            if a.int8:
                rows.append((cand + "-int8", make_int8(path, Path(tmp) / f"{cand}.int8.onnx")))
            for label, pth in rows:
                ms = [time_step(pth, a.cond_dim, a.frames, b, th) for b in (1, 2) for th in threads]
                print(f"{label:>14} {count_parameters(G):>9,} {pth.stat().st_size / 1e6:>6.1f} "
                      + " ".join(f"{m:>9.1f}" for m in ms), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
