"""Pack a prepared dataset into one small archive to move it to a training machine, and unpack it there.

    python -m emdm.data.pack data/dataset dataset.tar.xz              # ~1 GB of .npy files -> tens of MB
    python -m emdm.data.pack --unpack dataset.tar.xz data/dataset      # rebuilds the full folder

The archive keeps every small file as it is (texts/, the split lists, metadata.csv, actions.json, Mean.npy,
Std.npy, info.json, summary.txt, skipped.txt) and stores the joints of the non-mirrored windows only,
quantised to ``QUANTUM`` metres and delta-coded along time (xz-compressed). Unpacking rebuilds
``new_joints/`` (mirrored copies through ``normalize_clip(mirror_joints(...))``, as ``emdm.data.prepare``
makes them) and recomputes ``new_joint_vecs/`` with ``extract_features``: the code ``prepare`` ran, on
joints within QUANTUM/2 of the originals (mirrored copies, re-normalised, within ~0.3 mm). Mean/Std are the packed (original) ones, so normalisation is
unchanged. Both directions write to a temporary file/folder and rename it into place at the end.

Neither direction destroys what it did not write (``emdm.outdir``): an existing archive path that is not a
pack archive, or an unpack folder that is not a dataset, is refused unless ``--force``; an unpack folder
that is or holds the archive (or the repository) is refused always. Archive members are checked before
anything is written: only plain files, inside the target folder (``emdm.data.unpack.unsafe_member``).
"""

from __future__ import annotations

import argparse
import io
import json
import lzma
import os
import shutil
import sys
import tarfile
import time
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.data.dataset import DatasetError
from emdm.data.unpack import UnsafeArchiveError, unsafe_member
from emdm.motion.features import extract_features
from emdm.motion.retarget import normalize_clip
from emdm.outdir import OutputRefused, check_out, check_place, replace_dir, temp_dir

QUANTUM = 1e-5            # metres (0.01 mm)
FORMAT = 1
SMALL_FILES = ("train.txt", "val.txt", "test.txt", "all.txt", "metadata.csv", "actions.json", "Mean.npy",
               "Std.npy", "info.json", "summary.txt", "skipped.txt")


def _ids(root: Path) -> list[str]:
    f = root / "all.txt"
    if not f.is_file():
        raise DatasetError(f"{root}: all.txt not found (not a dataset written by emdm.data.prepare)")
    return [line.strip() for line in f.read_text().splitlines() if line.strip()]


def _add_bytes(tar: tarfile.TarFile, name: str, data: bytes) -> None:
    info = tarfile.TarInfo(name)
    info.size = len(data)
    info.mtime = 0
    tar.addfile(info, io.BytesIO(data))


def is_pack_archive(path: Path) -> bool:
    """An archive written by ``pack``: an xz tar whose first member is pack.json."""
    try:
        with tarfile.open(path, "r:xz") as tar:
            first = tar.next()
    except (tarfile.TarError, OSError, EOFError, lzma.LZMAError):
        return False
    return first is not None and first.name == "pack.json"


def pack(root: Path, out: Path, force: bool = False) -> dict:
    root = Path(root)
    out = Path(out)
    if out.is_dir():
        raise OutputRefused(f"{out}: is a folder; give the archive's file name (e.g. dataset.tar.xz)")
    if out.exists() and not force and not is_pack_archive(out):
        raise OutputRefused(f"{out}: exists and is not an archive written by emdm.data.pack; nothing was changed "
                            "(give --force to replace it, or choose a new name)")
    check_place(out, out, option="archive")
    ids = _ids(root)
    base_ids = [i for i in ids if not i.startswith("M")]
    mirrored = sorted(set(ids) - set(base_ids))
    missing = [m for m in mirrored if m[1:] not in set(base_ids)]
    if missing:
        raise DatasetError(f"{root}: mirrored clip {missing[0]} has no original {missing[0][1:]}")
    lengths, deltas = [], []
    for cid in base_ids:
        path = root / "new_joints" / f"{cid}.npy"
        if not path.is_file():
            raise DatasetError(f"{path}: joints not found")
        j = np.load(path).astype(np.float64)
        if j.ndim != 3 or j.shape[1:] != (22, 3):
            raise DatasetError(f"{path}: expected (F, 22, 3) joints, got {j.shape}")
        q = np.round(j / QUANTUM).astype(np.int64)
        deltas.append(np.diff(q, axis=0, prepend=np.zeros_like(q[:1])))
        lengths.append(len(j))
    d = np.concatenate(deltas).astype(np.int32)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".tmp")
    header = {"format": FORMAT, "quantum": QUANTUM, "ids": base_ids, "lengths": lengths,
              "mirrored": mirrored, "clips": len(ids)}
    try:
        _write_pack(tmp, root, ids, d, header)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    os.replace(tmp, out)
    return {"clips": len(ids), "packed_clips": len(base_ids), "frames": int(sum(lengths)), "bytes": out.stat().st_size}


def _write_pack(tmp: Path, root: Path, ids: list[str], d: np.ndarray, header: dict) -> None:
    with tarfile.open(tmp, "w:xz", preset=6) as tar:
        _add_bytes(tar, "pack.json", json.dumps(header).encode())
        buf = io.BytesIO()
        np.save(buf, d)
        _add_bytes(tar, "joints_delta.npy", buf.getvalue())
        for name in SMALL_FILES:
            if (root / name).is_file():
                _add_bytes(tar, name, (root / name).read_bytes())
        for cid in ids:
            p = root / "texts" / f"{cid}.txt"
            if p.is_file():
                _add_bytes(tar, f"texts/{cid}.txt", p.read_bytes())


def _rebuild_clip(job: tuple[str, str, np.ndarray, bool]) -> None:
    """Joints from the deltas (+ the mirrored copy, as prepare makes it), then features, written under root."""
    root, cid, delta, with_mirror = job
    joints = np.cumsum(delta.astype(np.int64), axis=0) * QUANTUM
    variants = [(cid, joints)]
    if with_mirror:
        variants.append(("M" + cid, normalize_clip(sk.mirror_joints(joints))))
    for vid, j in variants:
        np.save(Path(root) / "new_joints" / f"{vid}.npy", j.astype(np.float32))
        np.save(Path(root) / "new_joint_vecs" / f"{vid}.npy", extract_features(j))


def _extract(archive: Path, tmp: Path) -> tuple[dict, np.ndarray]:
    """Check the archive's members, write its small files under ``tmp``; (header, joint deltas)."""
    with tarfile.open(archive, "r:xz") as tar:
        members = tar.getmembers()
        for m in members:
            why = unsafe_member(m, tmp) or ("" if m.isfile() else "is a folder; a pack archive holds files only")
            if why:
                raise UnsafeArchiveError(f"{archive}: refusing member {m.name!r}: it {why}")
        names = {m.name for m in members}
        for need in ("pack.json", "joints_delta.npy", "all.txt", "Mean.npy", "Std.npy"):
            if need not in names:
                raise DatasetError(f"{archive}: member {need} missing (not written by emdm.data.pack)")
        header = json.loads(tar.extractfile("pack.json").read())
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            got = header.get("format") if isinstance(header, dict) else header
            raise DatasetError(f"{archive}: pack format {got!r}, this reader knows {FORMAT}")
        d = np.load(io.BytesIO(tar.extractfile("joints_delta.npy").read()), allow_pickle=False)
        for m in members:
            if m.name in ("pack.json", "joints_delta.npy"):
                continue
            dst = tmp / m.name
            dst.parent.mkdir(parents=True, exist_ok=True)
            dst.write_bytes(tar.extractfile(m).read())
    if d.shape != (sum(header["lengths"]), 22, 3):
        raise DatasetError(f"{archive}: joints_delta.npy has shape {d.shape}, header says "
                           f"{sum(header['lengths'])} frames")
    return header, d


def unpack(archive: Path, out: Path, workers: int = 1, force: bool = False) -> dict:
    archive, out = Path(archive), Path(out)
    if not archive.is_file():
        raise DatasetError(f"{archive}: archive not found")
    out = check_out(out, inputs=[("archive", archive)], force=force, option="unpack folder")
    check_place(out, out, option="unpack folder")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(out)
    try:
        try:
            header, d = _extract(archive, tmp)
        except (tarfile.TarError, lzma.LZMAError, EOFError, ValueError, KeyError, TypeError) as e:
            if isinstance(e, (DatasetError, UnsafeArchiveError)):
                raise
            raise DatasetError(f"{archive}: not a readable pack archive ({type(e).__name__}: "
                               f"{' '.join(str(e).split()) or 'truncated'}); write it again with emdm.data.pack") from None
        (tmp / "new_joints").mkdir()
        (tmp / "new_joint_vecs").mkdir()
        mirrored = set(header["mirrored"])
        offsets = np.concatenate([[0], np.cumsum(header["lengths"])])
        jobs = [(str(tmp), cid, d[offsets[i]:offsets[i + 1]], "M" + cid in mirrored)
                for i, cid in enumerate(header["ids"])]
        if workers > 1:
            from concurrent.futures import ProcessPoolExecutor

            with ProcessPoolExecutor(workers) as ex:
                list(ex.map(_rebuild_clip, jobs, chunksize=64))
        else:
            for job in jobs:
                _rebuild_clip(job)
        replace_dir(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return {"clips": header["clips"], "frames": int(sum(header["lengths"]))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.data.pack", description=__doc__.split("\n\n")[0])
    ap.add_argument("src", type=Path, help="dataset folder (pack) or archive (--unpack)")
    ap.add_argument("dst", type=Path, help="archive (pack) or dataset folder (--unpack)")
    ap.add_argument("--unpack", action="store_true")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1, help="unpack: processes rebuilding features")
    ap.add_argument("--force", action="store_true",
                    help="replace a destination this tool did not write (never the archive's own folder or the repository)")
    a = ap.parse_args(argv)
    t0 = time.time()
    try:
        if a.unpack:
            r = unpack(a.src, a.dst, a.workers, force=a.force)
            print(f"unpacked {a.src} -> {a.dst}: {r['clips']} clips ({time.time() - t0:.1f} s)")
        else:
            r = pack(a.src, a.dst, force=a.force)
            print(f"packed {a.src} -> {a.dst}: {r['clips']} clips ({r['packed_clips']} stored, {r['frames']} frames), "
                  f"{r['bytes'] / 1e6:.1f} MB ({time.time() - t0:.1f} s)")
    except (DatasetError, OutputRefused, UnsafeArchiveError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
