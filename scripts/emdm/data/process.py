"""One take -> retargeted 20 fps windows (and their mirrored copies) written in the HumanML3D layout.

``process_job`` runs in a worker process: it reads the file, retargets, cuts windows, computes
features and writes ``new_joints/<id>.npy``, ``new_joint_vecs/<id>.npy`` and ``texts/<id>.txt``
under ``out``; it returns small records (no arrays) plus per-window feature sums for Mean/Std.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from emdm import skeleton as sk
from emdm.data.actions import mirror_label
from emdm.data.captions import caption_line, mirror_caption
from emdm.data.sources import Job
from emdm.mocap import asfamc
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.jointmap import load_joint_map
from emdm.mocap.load import SourceClip, load_amc_clip, load_bvh_clip
from emdm.motion.features import extract_features, recover_joints
from emdm.motion.retarget import normalize_clip, prepare_take, window_starts

_JMAPS: dict = {}
_ASFS: dict = {}


def load_source(job: Job) -> SourceClip:
    jm = _JMAPS.get(job.joint_map) or _JMAPS.setdefault(job.joint_map, load_joint_map(job.joint_map))
    if job.kind == "bvh":
        return load_bvh_clip(job.path, jm)
    if not job.asf or not Path(job.asf).is_file():
        raise MocapFormatError(job.path, None, job.extra.get("asf_error") or f"its skeleton {job.asf} is missing")
    asf = _ASFS.get(job.asf) or _ASFS.setdefault(job.asf, asfamc.read_asf(job.asf))
    return load_amc_clip(job.path, asf, jm, job.fps or 120.0)


def windows_for(job: Job, min_frames: int = sk.MIN_FRAMES, max_frames: int = sk.MAX_FRAMES,
                stride: int = sk.MAX_FRAMES // 2) -> tuple[np.ndarray, list[tuple[int, int]], float]:
    """(take joints at 20 fps on the reference skeleton, [start, end) windows, source fps)."""
    clip = load_source(job)
    if clip.joints.shape[0] < 2:
        raise ValueError(f"{job.path}: only {clip.joints.shape[0]} frame(s)")
    if not (math.isfinite(clip.fps) and clip.fps > 0):
        raise MocapFormatError(job.path, None, f"frame rate {clip.fps} is not a positive number (check --amc-fps)")
    take = prepare_take(clip.joints, clip.fps)
    return take, window_starts(take.shape[0], max_frames, stride, min_frames), clip.fps


def process_job(job: Job, out: str, min_frames: int, max_frames: int, stride: int, mirror: bool = True) -> dict:
    """Returns {'job', 'frames', 'fps', 'windows': [...], 'skipped': reason or ''}."""
    out_p = Path(out)
    take, wins, fps = windows_for(job, min_frames, max_frames, stride)
    result = {"job": asdict(job), "frames": int(take.shape[0]), "fps": fps, "windows": [], "skipped": ""}
    if not wins:
        result["skipped"] = f"{take.shape[0]} frames at 20 fps, shorter than the minimum {min_frames}"
        return result
    files = []                       # computed and checked first, written after: a bad take leaves no file
    for k, (s, e) in enumerate(wins):
        base = normalize_clip(take[s:e])
        variants = [(False, base)]
        if mirror:
            variants.append((True, normalize_clip(sk.mirror_joints(base))))
        for mirrored, joints in variants:
            cid = ("M" if mirrored else "") + f"{job.source}_{job.clip}_{k:02d}"
            feats = extract_features(joints)
            f64 = feats.astype(np.float64)
            sums = f64.sum(0), (f64 ** 2).sum(0)
            if not (np.isfinite(joints).all() and all(np.isfinite(x).all() for x in sums)):
                raise MocapFormatError(job.path, None, f"window {k} (frames {s}-{e} at 20 fps): features are not "
                                                       "finite: a value in the file is out of range")
            err = float(np.abs(recover_joints(feats) - joints[:-1]).max())
            caps = [mirror_caption(c) for c in job.captions] if mirrored else list(job.captions)
            files.append((cid, joints, feats, caps))
            result["windows"].append({
                "id": cid, "mirrored": mirrored, "start": s, "frames": int(joints.shape[0]),
                "action": mirror_label(job.action) if mirrored else job.action,
                "captions": caps, "roundtrip": err, "sum": sums[0], "sumsq": sums[1], "n": int(f64.shape[0]),
            })
    for cid, joints, feats, caps in files:
        np.save(out_p / "new_joints" / f"{cid}.npy", joints.astype(np.float32))
        np.save(out_p / "new_joint_vecs" / f"{cid}.npy", feats)
        (out_p / "texts" / f"{cid}.txt").write_text("".join(caption_line(c) + "\n" for c in caps))
    return result
