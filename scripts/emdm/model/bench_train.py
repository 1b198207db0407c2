"""Benchmark the training loop: samples per second of an older ``emdm.train`` against today's, same data, same
device, same run, each configuration in its own ``python -m emdm.train`` process.

    python -m emdm.model.bench_train --data data/dataset --old-rev 6efc27a \\
        --new "" --new "--amp bf16" --new "--batch 256 --lr-scale sqrt --amp bf16 --compile"
    python -m emdm.model.bench_train --synthetic 256 --device cpu --preset tiny --batch 16 --steps 20   # CPU smoke

``--old-rev REV`` takes the ``scripts/`` tree of a git revision (``git archive``; needs the repository's .git),
``--old-src DIR`` an already extracted ``scripts/`` folder (for a machine without git history); without either
only the current loop runs. Seconds per step come from each run's log.csv (``sec_per_step``, wall time between
log rows, which the new loop measures after its once-per-row device sync); the first row (start-up, compilation)
is left out. ``--synthetic N`` writes N synthetic walking clips (40–196 frames) instead of reading ``--data``.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from emdm import paths
from emdm.motion.features import extract_features
from emdm.motion.synthetic import synthetic_walk


def write_synthetic(root: Path, n: int, seed: int = 0) -> Path:
    """A HumanML3D-layout folder of ``n`` synthetic walks (real 263-d features), two actions, two captions each."""
    rng = np.random.default_rng(seed)
    (root / "new_joint_vecs").mkdir(parents=True, exist_ok=True)
    (root / "texts").mkdir(exist_ok=True)
    ids, feats = [], []
    for i in range(n):
        frames = int(rng.integers(41, 198))
        f = extract_features(synthetic_walk(frames, turn_per_frame=float(rng.uniform(-0.05, 0.05)),
                                            speed=float(rng.uniform(0.02, 0.08))))
        cid = f"{i:06d}"
        np.save(root / "new_joint_vecs" / f"{cid}.npy", f.astype(np.float32))
        (root / "texts" / f"{cid}.txt").write_text(f"a person walks {i % 7}#a/DET#0.0#0.0\nsomeone walks#x#0.0#0.0\n")
        ids.append(cid)
        feats.append(f)
    allf = np.concatenate(feats)
    np.save(root / "Mean.npy", allf.mean(0).astype(np.float32))
    np.save(root / "Std.npy", allf.std(0).astype(np.float32))
    (root / "train.txt").write_text("\n".join(ids) + "\n")
    (root / "actions.json").write_text(json.dumps({"labels": ["walk", "turn"]}))
    rows = ["id,action_id"] + [f"{cid},{int(i % 5 == 0)}" for i, cid in enumerate(ids)]
    (root / "metadata.csv").write_text("\n".join(rows) + "\n")
    return root


def extract_rev(rev: str, dest: Path) -> Path:
    """``git archive REV scripts`` unpacked under dest; returns dest/scripts."""
    arch = subprocess.run(["git", "-C", str(paths.REPO_ROOT), "archive", rev, "scripts"], capture_output=True, check=False)
    if arch.returncode != 0:
        raise SystemExit(f"--old-rev {rev}: git archive failed: {arch.stderr.decode().strip()[:300]}")
    dest.mkdir(parents=True, exist_ok=True)
    subprocess.run(["tar", "-x", "-C", str(dest)], input=arch.stdout, check=True)
    return dest / "scripts"


def run_loop(src: Path, data: Path, out: Path, flags: list[str], env_extra: dict) -> dict:
    """One ``emdm.train`` run with ``src`` first on PYTHONPATH; its batch, seconds per step and samples/s."""
    env = {**os.environ, **env_extra, "PYTHONPATH": str(src)}
    cmd = [sys.executable, "-m", "emdm.train", "--data", str(data), "--out", str(out), "--no-progress",
           "--ckpt-minutes", "1000", *flags]
    res = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if res.returncode != 0:
        raise SystemExit(f"{' '.join(map(shlex.quote, flags))}: emdm.train failed ({res.returncode}):\n{res.stderr[-2000:]}")
    with open(out / "log.csv") as f:
        rows = list(csv.DictReader(f))
    timed = rows[1:] or rows
    sps = float(np.mean([float(r["sec_per_step"]) for r in timed]))
    p = argparse.ArgumentParser(add_help=False)
    p.add_argument("--batch", type=int, default=64)
    batch = p.parse_known_args(flags)[0].batch
    return {"batch": batch, "sec_per_step": sps, "samples_per_s": batch / sps, "steps_timed": len(timed)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.model.bench_train", description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", type=Path, default=None, help="dataset folder (default: emdm.paths.DATASET_DIR)")
    ap.add_argument("--synthetic", type=int, default=0, help="use N synthetic clips instead of --data")
    ap.add_argument("--old-rev", default=None, help="git revision of the old loop (its scripts/ tree)")
    ap.add_argument("--old-src", type=Path, default=None, help="an extracted scripts/ folder of the old loop")
    ap.add_argument("--new", action="append", default=None,
                    help="extra flags of one new-loop configuration (repeatable; default: one with none)")
    ap.add_argument("--task", default="text")
    ap.add_argument("--objective", default="ddgan")
    ap.add_argument("--preset", default="web")
    ap.add_argument("--batch", type=int, default=64)
    ap.add_argument("--steps", type=int, default=60, help="steps per run (the first --log-every are not timed)")
    ap.add_argument("--log-every", type=int, default=10)
    ap.add_argument("--device", default=None)
    ap.add_argument("--threads", type=int, default=None)
    ap.add_argument("--extra", default="", help="flags for every run, old and new (e.g. '--d-width 64')")
    ap.add_argument("--cache", type=Path, default=None, help="folder of caption embeddings (text-*.npy) to start from")
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    a = ap.parse_args(argv)

    base = ["--task", a.task, "--objective", a.objective, "--preset", a.preset, "--batch", str(a.batch),
            "--steps", str(a.steps), "--log-every", str(a.log_every), "--random-crop", "0.3", "--min-frames", "16",
            *shlex.split(a.extra)]
    if a.device:
        base += ["--device", a.device]
    if a.threads:
        base += ["--threads", str(a.threads)]
    results = []
    with tempfile.TemporaryDirectory(prefix="bench-train-") as tmp:
        tmp = Path(tmp)
        data = write_synthetic(tmp / "data", a.synthetic) if a.synthetic else Path(a.data or paths.DATASET_DIR)
        cache = tmp / "cache"
        cache.mkdir()
        for f in (a.cache.glob("text-*.npy") if a.cache else []):
            (cache / f.name).write_bytes(f.read_bytes())
        # new loops first (they embed the captions once, into the cache), the old one last
        runs: list[tuple[str, Path, list[str]]] = []
        for extra in (a.new or [""]):
            runs.append((f"new {extra}".strip(), paths.REPO_ROOT / "scripts", base + shlex.split(extra)))
        old = None
        if a.old_src or a.old_rev:         # beside it this checkout's public/ (text encoder, manifest: same cache key)
            if a.old_src:
                shutil.copytree(a.old_src, tmp / "old" / "scripts")
                old = tmp / "old" / "scripts"
            else:
                old = extract_rev(a.old_rev, tmp / "old")
            (tmp / "old" / "public").symlink_to(paths.REPO_ROOT / "public", target_is_directory=True)
            runs.append((f"old ({a.old_rev or a.old_src})", old, base))
        for i, (label, src, flags) in enumerate(runs):
            out = tmp / f"run{i}"
            out.mkdir()
            for f in cache.glob("text-*.npy"):               # caption embeddings once for all runs
                (out / f.name).write_bytes(f.read_bytes())
            r = run_loop(src, data, out, flags, {})
            for f in out.glob("text-*.npy"):
                (cache / f.name).write_bytes(f.read_bytes())
            r["loop"] = label
            results.append(r)
            print(f"{label:<60} batch {r['batch']:>4}  {1000 * r['sec_per_step']:>8.1f} ms/step  "
                  f"{r['samples_per_s']:>8.1f} samples/s", flush=True)
    if old is not None:                   # the ratios against the old loop, same data and device
        ref = results[-1]["samples_per_s"]
        for r in results:
            r["vs_old"] = r["samples_per_s"] / ref
        print("samples/s relative to the old loop: " + "; ".join(f"{r['loop']} ×{r['vs_old']:.2f}" for r in results))
    if a.json:
        a.json.write_text(json.dumps({"device": a.device or "auto", "data": "synthetic" if a.synthetic else str(data),
                                      "steps": a.steps, "results": results}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
