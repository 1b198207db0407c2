"""CLI: mocap sources -> dataset in the HumanML3D layout (docs/DATA.md, docs/ARCHITECTURE.md).

    python -m emdm.data.prepare                       # all three shared sources -> data/dataset
    python -m emdm.data.prepare --sources bandai,hdm05 --out data/ds-small
    python -m emdm.data.prepare --input-dir my_mocap --joint-map my_rig.json --out data/mine

The dataset is written into a temporary folder beside ``--out`` and renamed into place at the end,
so ``--out`` is never half-written (training may start as soon as train.txt and Mean.npy exist).
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import sys
import tempfile
import time
from collections import defaultdict
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from emdm import paths
from emdm import skeleton as sk
from emdm.data import sources
from emdm.data.actions import vocabulary
from emdm.data.process import process_job
from emdm.data.split import split_takes
from emdm.data.stats import mean_std
from emdm.data.unpack import unpack_archive
from emdm.mocap.errors import MocapFormatError

ARCHIVES = {
    "bandai": "bandai-namco-motion.tar.xz",
    "hdm05": "hdm05-subset.tar.xz",
    "cmu": "cmu-mocap-subset.tar.xz",
}
DEFAULT_MIN_FRAMES = sk.MIN_FRAMES


def collect_jobs(args) -> tuple[list[sources.Job], list[tuple[str, str]]]:
    jobs: list[sources.Job] = []
    problems: list[tuple[str, str]] = []
    if args.input_dir:
        if not args.joint_map:
            raise SystemExit("--input-dir needs --joint-map (a built-in name or a JSON file; see docs/DATA.md)")
        jobs += sources.user_jobs(Path(args.input_dir), args.joint_map, args.amc_fps, args.captions)
    names = [s.strip() for s in args.sources.split(",") if s.strip()] if args.sources else []
    for name in names:
        if name not in ARCHIVES:
            raise SystemExit(f"--sources: unknown source {name!r} (expected any of {', '.join(ARCHIVES)})")
        archive = Path(args.shared) / ARCHIVES[name]
        root = unpack_archive(archive, Path(args.raw_dir))
        finder = {"bandai": sources.bandai_jobs, "hdm05": sources.hdm05_jobs, "cmu": sources.cmu_jobs}[name]
        jobs += finder(root, args.captions)
    if not jobs:
        raise SystemExit("nothing to do: give --sources and/or --input-dir")
    return jobs, problems


def _run_all(jobs, tmp: Path, args, strict: bool):
    results, skipped = [], []
    work = [(j, str(tmp), args.min_frames, args.max_frames, args.stride, not args.no_mirror) for j in jobs]
    try:
        from tqdm import tqdm
        bar = tqdm(total=len(work), unit="take", desc="prepare", file=sys.stderr, dynamic_ncols=True)
    except ImportError:  # pragma: no cover
        bar = None

    def handle(job, fut_result=None, exc=None):
        if exc is not None:
            if strict:
                raise exc
            skipped.append((job.path, f"{type(exc).__name__}: {exc}"))
        elif fut_result["skipped"]:
            skipped.append((job.path, fut_result["skipped"]))
            results.append(fut_result)
        else:
            results.append(fut_result)
        if bar:
            bar.update(1)

    recoverable = (MocapFormatError, ValueError, KeyError, OSError)
    if args.workers <= 1:
        for w in work:
            try:
                r = process_job(*w)
            except recoverable as e:
                handle(w[0], exc=e)
                continue
            handle(w[0], r)
    else:
        with ProcessPoolExecutor(max_workers=args.workers) as pool:
            futs = {pool.submit(process_job, *w): w[0] for w in work}
            try:
                for fut in as_completed(futs):
                    try:
                        r = fut.result()
                    except recoverable as e:
                        handle(futs[fut], exc=e)
                        continue
                    handle(futs[fut], r)
            except BaseException:
                for f in futs:
                    f.cancel()
                raise
    if bar:
        bar.close()
    return results, skipped


def summary_table(results: list[dict], skipped: list[tuple[str, str]], elapsed: float) -> str:
    rows = defaultdict(lambda: {"takes": 0, "clips": 0, "windows": 0, "frames": 0})
    act = defaultdict(lambda: {"windows": 0, "frames": 0})
    for r in results:
        src = r["job"]["source"]
        if r["windows"]:
            rows[src]["takes"] += 1
            rows[src]["clips"] += 1
        for w in r["windows"]:
            rows[src]["windows"] += 1
            rows[src]["frames"] += w["frames"]
            act[(w["action"])]["windows"] += 1
            act[(w["action"])]["frames"] += w["frames"]
    lines = ["", "source      files  windows(+mirrors)   hours", "-" * 48]
    tot = {"takes": 0, "windows": 0, "frames": 0}
    for src in sorted(rows):
        r = rows[src]
        lines.append(f"{src:<10} {r['takes']:>6} {r['windows']:>18} {r['frames'] / sk.FPS / 3600:>7.2f}")
        for k in tot:
            tot[k] += r[k]
    lines.append(f"{'total':<10} {tot['takes']:>6} {tot['windows']:>18} {tot['frames'] / sk.FPS / 3600:>7.2f}")
    lines += ["", "action                  windows    hours", "-" * 40]
    for a in sorted(act):
        lines.append(f"{a:<22} {act[a]['windows']:>8} {act[a]['frames'] / sk.FPS / 3600:>8.3f}")
    reasons = defaultdict(list)
    for path, why in skipped:
        key = why if "shorter than" not in why else "shorter than the minimum length"
        reasons[key].append(path)
    lines += ["", f"skipped files: {len(skipped)}"]
    for why, ps in sorted(reasons.items(), key=lambda kv: -len(kv[1])):
        lines.append(f"  {len(ps):>5}  {why}" + (f"  (e.g. {Path(ps[0]).name})" if ps else ""))
    lines.append(f"\nrun time: {elapsed:.1f} s")
    return "\n".join(lines)


def write_dataset(results: list[dict], tmp: Path, split_of: dict[str, str], info: dict) -> dict:
    windows = [(r, w) for r in results for w in r["windows"]]
    labels = vocabulary({w["action"] for _, w in windows})
    label_id = {a: i for i, a in enumerate(labels)}
    total = np.zeros(sk.FEATURE_DIM)
    total_sq = np.zeros(sk.FEATURE_DIM)
    count = 0
    ids = {"train": [], "val": [], "test": []}
    meta_rows = []
    for r, w in sorted(windows, key=lambda rw: rw[1]["id"]):
        job = r["job"]
        split = split_of[job["take"]]
        ids[split].append(w["id"])
        if split == "train":
            total += w["sum"]
            total_sq += w["sumsq"]
            count += w["n"]
        meta_rows.append([w["id"], job["source"], job["take"], w["action"], label_id[w["action"]], job["style"], sk.FPS,
                          w["frames"], int(w["mirrored"]), split, round(float(r["fps"]), 3), w["start"],
                          job["extra"].get("content", job["extra"].get("description", ""))])
    if count < 2:
        raise SystemExit("no training frames: every take was skipped or went to val/test")
    mean, std = mean_std(total, total_sq, count)
    np.save(tmp / "Mean.npy", mean)
    np.save(tmp / "Std.npy", std)
    with open(tmp / "metadata.csv", "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["id", "source", "take", "action", "action_id", "style", "fps", "frames", "mirrored", "split",
                     "source_fps", "start_frame", "source_label"])
        wr.writerows(meta_rows)
    (tmp / "actions.json").write_text(json.dumps({"labels": labels}, indent=1) + "\n")
    for split in ("val", "test", "train"):  # train.txt last: its presence means the rest is there
        (tmp / f"{split}.txt").write_text("".join(i + "\n" for i in ids[split]))
    (tmp / "all.txt").write_text("".join(i + "\n" for s in ("train", "val", "test") for i in ids[s]))
    info = dict(info, windows=len(windows), labels=len(labels), train_frames=count,
                splits={k: len(v) for k, v in ids.items()},
                captions=sum(len(w["captions"]) for _, w in windows),
                roundtrip_max_m=max((w["roundtrip"] for _, w in windows), default=0.0))
    (tmp / "info.json").write_text(json.dumps(info, indent=1) + "\n")
    return info


def publish(tmp: Path, out: Path) -> None:
    """Rename the finished temp folder onto ``out`` (replacing an older dataset)."""
    os.chmod(tmp, 0o755)  # mkdtemp makes it private
    if out.exists():
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        os.replace(out, old)
        os.replace(tmp, out)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.replace(tmp, out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.data.prepare", description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sources", default="bandai,hdm05,cmu",
                    help="comma-separated shared sources: bandai, hdm05, cmu (default: all three; '' for none)")
    ap.add_argument("--shared", default=str(paths.shared_data_dir()), help="folder of the shared archives")
    ap.add_argument("--raw-dir", default=str(paths.DATA_DIR / "raw"), help="where archives are unpacked (cache)")
    ap.add_argument("--input-dir", help="a folder of your own .bvh/.amc files (needs --joint-map)")
    ap.add_argument("--joint-map", help="joint map for --input-dir: built-in name or JSON path")
    ap.add_argument("--amc-fps", type=float, default=120.0, help="frame rate of AMC files in --input-dir")
    ap.add_argument("--out", default=str(paths.DATASET_DIR), help="output dataset folder")
    ap.add_argument("--strict", action="store_true", help="fail on the first bad file instead of skipping it")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--min-frames", type=int, default=DEFAULT_MIN_FRAMES, help="drop takes shorter than this at 20 fps")
    ap.add_argument("--max-frames", type=int, default=sk.MAX_FRAMES, help="window length at 20 fps")
    ap.add_argument("--stride", type=int, default=sk.MAX_FRAMES // 2, help="window stride for long takes")
    ap.add_argument("--captions", type=int, default=4, help="captions per clip")
    ap.add_argument("--no-mirror", action="store_true", help="do not add mirrored copies")
    ap.add_argument("--seed", type=int, default=0, help="split seed")
    ap.add_argument("--limit", type=int, default=0, help="only the first N takes per source (quick tries)")
    args = ap.parse_args(argv)
    if not 2 <= args.min_frames <= args.max_frames:
        ap.error("--min-frames must be between 2 and --max-frames")
    if args.stride < 1:
        ap.error("--stride must be >= 1")

    t0 = time.time()
    jobs, _ = collect_jobs(args)
    if args.limit:
        per = defaultdict(int)
        kept = []
        for j in jobs:
            per[j.source] += 1
            if per[j.source] <= args.limit:
                kept.append(j)
        jobs = kept
    take_actions: dict[str, str] = {}
    for j in jobs:
        take_actions.setdefault(j.take, j.action)
    split_of = split_takes(take_actions, seed=args.seed)
    out = Path(args.out).resolve()
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.tmp-", dir=out.parent))
    try:
        for d in ("new_joints", "new_joint_vecs", "texts"):
            (tmp / d).mkdir()
        print(f"prepare: {len(jobs)} takes from {args.sources or ''}{' + ' + args.input_dir if args.input_dir else ''}"
              f" -> {out} ({args.workers} workers)", file=sys.stderr)
        results, skipped = _run_all(jobs, tmp, args, args.strict)
        elapsed = time.time() - t0
        info = write_dataset(results, tmp, split_of, {
            "sources": args.sources, "input_dir": args.input_dir or "", "fps": sk.FPS, "min_frames": args.min_frames,
            "max_frames": args.max_frames, "stride": args.stride, "mirrored": not args.no_mirror,
            "takes": len(take_actions), "files": len(jobs), "skipped": len(skipped),
        })
        table = summary_table(results, skipped, time.time() - t0)
        extra = (f"\ncaptions: {info['captions']} lines, actions: {info['labels']}, splits: {info['splits']}, "
                 f"round-trip max error: {info['roundtrip_max_m'] * 1000:.4f} mm")
        (tmp / "summary.txt").write_text(table + extra + "\n")
        with open(tmp / "skipped.txt", "w") as f:
            for p, why in skipped:
                f.write(f"{p}\t{why}\n")
        publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    print(table + extra)
    print(f"dataset written to {out} in {time.time() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
