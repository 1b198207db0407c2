"""CLI: mocap sources -> dataset in the HumanML3D layout (docs/DATA.md, docs/ARCHITECTURE.md).

    python -m emdm.data.prepare                       # all three shared sources -> data/dataset
    python -m emdm.data.prepare --sources bandai,hdm05 --out data/ds-small
    python -m emdm.data.prepare --input-dir my_mocap --joint-map my_rig.json --out data/mine

The dataset is written into a temporary folder beside ``--out`` and renamed into place at the end,
so ``--out`` is never half-written (training may start as soon as train.txt and Mean.npy exist); a run
killed while renaming is completed or undone by the next one (``emdm.outdir.recover``).
An existing ``--out`` is replaced only when it is a dataset this tool wrote (or with ``--force``), and
never when it is, or holds, an input or the repository (``emdm.outdir``). The joint map is loaded and
checked against the first readable input file before any take is processed. A file that cannot be used
(for any reason, MemoryError included) is skipped with its reason (``skipped.txt``); when every file is skipped nothing is written, the reasons
are printed and kept in ``<out>.skipped.txt`` beside ``--out``, and the exit status is 2.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import shutil
import sys
import time
from collections import Counter, defaultdict
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
from emdm.data.unpack import UnsafeArchiveError, unpack_archive
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.jointmap import JointMap, load_joint_map
from emdm.mocap.load import source_point_names
from emdm.outdir import PREPARE_TOOL, OutputRefused, check_out, check_place, replace_dir, temp_dir

ARCHIVES = {
    "bandai": "bandai-namco-motion.tar.xz",
    "hdm05": "hdm05-subset.tar.xz",
    "cmu": "cmu-mocap-subset.tar.xz",
}
DEFAULT_MIN_FRAMES = sk.MIN_FRAMES


SIDE_HEADER = "# emdm.data.prepare: every file was skipped, nothing was written to "


class PrepareError(Exception):
    """A run that cannot go on; the message is one line saying what was wrong and what to do (exit 2)."""


def run_inputs(args) -> list[tuple[str, str]]:
    """(option, path) of everything the run reads: --out may be none of them, nor hold one."""
    inputs = [("--input-dir", args.input_dir)] if args.input_dir else []
    if args.joint_map and Path(args.joint_map).is_file():
        inputs.append(("--joint-map", args.joint_map))
    if args.sources:
        inputs += [("--shared", args.shared), ("--raw-dir", args.raw_dir)]
    return inputs


def load_map(name_or_path: str) -> JointMap:
    try:
        return load_joint_map(name_or_path)
    except (FileNotFoundError, MocapFormatError) as e:
        raise PrepareError(f"--joint-map: {e}") from None


def check_joint_map(jm: JointMap, jobs: list[sources.Job]) -> None:
    """The map's points all exist in the first input file whose skeleton reads (files that do not read are
    skipped later, each with its own reason)."""
    for job in jobs:
        try:
            names = source_point_names(job.kind, job.path, job.asf)
        except (MocapFormatError, OSError):
            continue
        have = set(names)
        missing = [n for n in jm.point_names() if n not in have]
        if missing:
            more = f" and {len(missing) - 6} more" if len(missing) > 6 else ""
            raise PrepareError(
                f"--joint-map {jm.name!r} ({jm.path}) needs {', '.join(map(repr, missing[:6]))}{more}, which "
                f"{job.path} (the first input file that reads) does not have; it has {', '.join(names[:8])}"
                f"{' ...' if len(names) > 8 else ''}. Is this the map for this rig? (see docs/DATA.md)")
        return


def collect_jobs(args) -> list[sources.Job]:
    """Every take to process. Errors that stop the run (no input, a bad joint map) are PrepareError."""
    jobs: list[sources.Job] = []
    if args.input_dir:
        if not args.joint_map:
            raise PrepareError("--input-dir needs --joint-map (a built-in name or a JSON file; see docs/DATA.md)")
        jm = load_map(args.joint_map)          # before any file is read
        root = Path(args.input_dir)
        if not root.is_dir():
            raise PrepareError(f"--input-dir {root}: not a folder")
        try:
            user = sources.user_jobs(root, args.joint_map, args.amc_fps, args.captions)
        except FileNotFoundError as e:
            raise PrepareError(f"--input-dir: {e}") from None
        check_joint_map(jm, user)
        jobs += user
    names = [s.strip() for s in args.sources.split(",") if s.strip()] if args.sources else []
    for name in names:
        if name not in ARCHIVES:
            raise PrepareError(f"--sources: unknown source {name!r} (expected any of {', '.join(ARCHIVES)})")
        archive = Path(args.shared) / ARCHIVES[name]
        try:
            root = unpack_archive(archive, Path(args.raw_dir), force=args.force)
            finder = {"bandai": sources.bandai_jobs, "hdm05": sources.hdm05_jobs, "cmu": sources.cmu_jobs}[name]
            jobs += finder(root, args.captions)
        except (FileNotFoundError, MocapFormatError, UnsafeArchiveError, OutputRefused) as e:
            raise PrepareError(f"--sources {name}: {e}") from None
    if not jobs:
        raise PrepareError("nothing to do: give --sources and/or --input-dir")
    return sources.unique_clips(jobs)      # user clips are unique already; a clash elsewhere gets a suffix


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
                raise PrepareError(f"{exc} (--strict stops at the first bad file; nothing was written)") from exc
            skipped.append((job.path, skip_reason(exc)))
        elif fut_result["skipped"]:
            skipped.append((job.path, fut_result["skipped"]))
            results.append(fut_result)
        else:
            results.append(fut_result)
        if bar:
            bar.update(1)

    recoverable = Exception        # one file's failure, whatever it is, is that file's skip (skip_reason)
    try:
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
    finally:
        if bar:
            bar.close()
    return results, skipped


def skip_reason(exc: BaseException) -> str:
    """One line saying why a file was skipped: the reader's message, or what else went wrong with it."""
    if isinstance(exc, MemoryError):
        return (f"MemoryError: the file needs more memory than this machine has ({exc or 'no detail'}); "
                "split the take into shorter files")
    text = " ".join(str(exc).split()) or "(no message)"
    if isinstance(exc, (MocapFormatError, ValueError, KeyError, OSError)):
        return f"{type(exc).__name__}: {text}"
    return f"{type(exc).__name__}: {text} (unexpected: please report it with the file)"


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
    dup = next((i for i, n in Counter(i for v in ids.values() for i in v).items() if n > 1), None)
    if dup is not None:
        raise PrepareError(f"clip id {dup} was made by two files; nothing was written (a bug: please report it)")
    if count < 2:
        raise PrepareError(f"no training frames: the {len(windows)} windows all went to val/test "
                           "(give more takes, or check skipped files)")
    mean, std = mean_std(total, total_sq, count)
    bad = np.flatnonzero(~(np.isfinite(mean) & np.isfinite(std)))
    if bad.size:
        raise PrepareError(f"Mean/Std are not finite in {bad.size} of {mean.size} channels (first: {bad[0]}): some "
                           "take holds out-of-range values that passed the per-file checks; nothing was written")
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
    info = dict({"tool": PREPARE_TOOL}, **info, windows=len(windows), labels=len(labels), train_frames=count,
                splits={k: len(v) for k, v in ids.items()},
                captions=sum(len(w["captions"]) for _, w in windows),
                roundtrip_max_m=max((w["roundtrip"] for _, w in windows), default=0.0))
    (tmp / "info.json").write_text(json.dumps(info, indent=1) + "\n")
    return info


def skipped_report(skipped: list[tuple[str, str]], limit: int = 20) -> str:
    lines = [f"skipped files: {len(skipped)}"] + [f"  {p}: {why}" for p, why in skipped[:limit]]
    if len(skipped) > limit:
        lines.append(f"  ... and {len(skipped) - limit} more")
    return "\n".join(lines)


def side_list(out: Path) -> Path:
    """Where the skipped list of a run that wrote nothing is kept: ``<out>.skipped.txt`` beside --out."""
    return out.with_name(out.name + ".skipped.txt")


def _ours(side: Path) -> bool:
    try:
        with open(side) as f:
            return f.readline().startswith(SIDE_HEADER)
    except OSError:
        return False


def keep_skipped(out: Path, skipped: list[tuple[str, str]]) -> str:
    """Write the list beside --out (never over a file this tool did not write); says where it is."""
    side = side_list(out)
    if side.exists() and not _ours(side):
        return f"not saved: {side} exists and was not written by this tool"
    side.write_text(SIDE_HEADER + f"{out} (path<TAB>reason)\n" + "".join(f"{p}\t{why}\n" for p, why in skipped))
    return f"the list is in {side}"


def _parser() -> argparse.ArgumentParser:
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
    ap.add_argument("--force", action="store_true",
                    help="replace an existing --out (or unpack folder) that is not a dataset this tool wrote; "
                         "an --out that is or holds an input or the repository is refused even so")
    ap.add_argument("--strict", action="store_true", help="fail on the first bad file instead of skipping it")
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--min-frames", type=int, default=DEFAULT_MIN_FRAMES, help="drop takes shorter than this at 20 fps")
    ap.add_argument("--max-frames", type=int, default=sk.MAX_FRAMES, help="window length at 20 fps")
    ap.add_argument("--stride", type=int, default=sk.MAX_FRAMES // 2, help="window stride for long takes")
    ap.add_argument("--captions", type=int, default=4, help="captions per clip")
    ap.add_argument("--no-mirror", action="store_true", help="do not add mirrored copies")
    ap.add_argument("--seed", type=int, default=0, help="split seed")
    ap.add_argument("--limit", type=int, default=0, help="only the first N takes per source (quick tries)")
    return ap


def main(argv: list[str] | None = None) -> int:
    ap = _parser()
    args = ap.parse_args(argv)
    if not 2 <= args.min_frames <= args.max_frames:
        ap.error("--min-frames must be between 2 and --max-frames")
    if args.stride < 1:
        ap.error("--stride must be >= 1")
    if not (math.isfinite(args.amc_fps) and 0.1 <= args.amc_fps <= 1e5):
        ap.error(f"--amc-fps must be a frame rate between 0.1 and 100000, got {args.amc_fps}")
    try:
        return run(args)
    except (PrepareError, OutputRefused) as e:
        print(f"prepare: {e}", file=sys.stderr)
        return 2
    except OSError as e:   # the disk filled up, a folder went away...: nothing was published
        print(f"prepare: cannot write {e.filename or args.out}: {e.strerror or e}; nothing was written to "
              f"{args.out}", file=sys.stderr)
        return 2


def run(args) -> int:
    t0 = time.time()
    out = check_out(args.out, inputs=run_inputs(args), force=args.force)   # before anything is read
    check_place(out, args.out)
    jobs = collect_jobs(args)
    if args.limit:
        per = defaultdict(int)
        kept = []
        for j in jobs:
            per[j.source] += 1
            if per[j.source] <= args.limit:
                kept.append(j)
        jobs = kept
    take_strata: dict[str, str] = {}           # take -> what the split stratifies it by (its action, or a stratum)
    for j in jobs:
        take_strata.setdefault(j.take, j.stratum or j.action)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(out)
    try:
        for d in ("new_joints", "new_joint_vecs", "texts"):
            (tmp / d).mkdir()
        print(f"prepare: {len(jobs)} takes from {args.sources or ''}{' + ' + args.input_dir if args.input_dir else ''}"
              f" -> {out} ({args.workers} workers)", file=sys.stderr)
        results, skipped = _run_all(jobs, tmp, args, args.strict)
        if not any(r["windows"] for r in results):
            print(skipped_report(skipped), file=sys.stderr)
            raise PrepareError(f"every one of the {len(jobs)} files was skipped (reasons above; "
                               f"{keep_skipped(out, skipped)}); nothing was written to {out}")
        take_windows: dict[str, int] = defaultdict(int)       # the split holds out few of an action's windows
        for r in results:
            take_windows[r["job"]["take"]] += len(r["windows"])
        split_of = split_takes(take_strata, seed=args.seed, windows=dict(take_windows))
        try:
            info = write_dataset(results, tmp, split_of, {
                "sources": args.sources, "input_dir": args.input_dir or "", "fps": sk.FPS,
                "min_frames": args.min_frames, "max_frames": args.max_frames, "stride": args.stride,
                "mirrored": not args.no_mirror, "takes": len(take_strata), "files": len(jobs), "skipped": len(skipped),
                "clips": sum(1 for r in results if r["windows"]),
            })
        except PrepareError as e:
            if skipped:
                print(skipped_report(skipped), file=sys.stderr)
                raise PrepareError(f"{e} ({len(skipped)} files skipped: {keep_skipped(out, skipped)})") from None
            raise
        table = summary_table(results, skipped, time.time() - t0)
        extra = (f"\ncaptions: {info['captions']} lines, actions: {info['labels']}, splits: {info['splits']}, "
                 f"round-trip max error: {info['roundtrip_max_m'] * 1000:.4f} mm")
        (tmp / "summary.txt").write_text(table + extra + "\n")
        with open(tmp / "skipped.txt", "w") as f:
            for p, why in skipped:
                f.write(f"{p}\t{why}\n")
        replace_dir(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    if _ours(side_list(out)):
        side_list(out).unlink()           # a stale list from an earlier run that wrote nothing
    print(table + extra)
    print(f"dataset written to {out} in {time.time() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
