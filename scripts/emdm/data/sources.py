"""Find the takes of each source and describe them as jobs (file, joint map, take, action, captions).

* ``bandai``: every ``*.bvh`` with its ``*.json`` ``{"content": i, "style": j}`` indexing its
  dataset's ``cfg/content_label.txt`` / ``cfg/style_label.txt``.
* ``hdm05``: ``HDM_<actor>_<action>_<id>_120.amc`` with ``HDM_<actor>.asf``; 120 fps.
* ``cmu``: ``cmu/bvh/SSS_TT.bvh`` (Character Creator rig, first frame a T-pose) and
  ``cmu/asfamc/SS_TT.amc`` (120 fps), captions from ``cmu-descriptions.csv``. The BVH and AMC
  versions of one trial share a take id, so the split never separates them.
* a user folder (``user_jobs``): every ``*.bvh`` / ``*.amc`` below it, with one joint map; the action
  is the file's sub-folder name (or ``unknown``), captions from a ``<stem>.txt`` beside the file
  (one caption per line) or made from the action name. An AMC without its ASF is still a job: it is
  skipped when processed, with the reason naming the file looked for. The clip name is the file's path
  made file-safe; names that would clash (``walk ä.bvh``, ``walk-ü.bvh``, ``walk.BVH`` all become
  ``walk``; case is ignored, for case-insensitive disks) each get ``-`` and a short hash of the relative
  path (``unique_clips``), so every file is its own clip and its id is the same on every run.
"""

from __future__ import annotations

import csv
import hashlib
import json
import re
from dataclasses import dataclass, field
from pathlib import Path

from emdm.data import actions, captions
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.load import find_asf


@dataclass
class Job:
    source: str
    kind: str                 # 'bvh' | 'amc'
    path: str
    joint_map: str            # built-in name or JSON path
    take: str                 # split unit (mirrors and formats of one take share it)
    clip: str                 # unique clip name (file-safe)
    action: str               # unified label
    style: str
    captions: list[str]
    asf: str = ""
    fps: float = 0.0          # for AMC (BVH files carry their frame time)
    split: str = ""
    extra: dict = field(default_factory=dict)
    stratum: str = ""         # what the split stratifies the take by, where not its action (actions.cmu_stratum)


def _safe(s: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", s).strip("-")


def unique_clips(jobs: list[Job], key=lambda j: j.path) -> list[Job]:
    """``jobs`` with every clip name that clashes with another of the same source (ignoring case) suffixed
    by ``-`` and the first hex digits of sha1(``key(job)``), as many as make them all distinct."""
    groups: dict[tuple[str, str], list[Job]] = {}
    for j in jobs:
        groups.setdefault((j.source, j.clip.lower()), []).append(j)
    taken = set(groups)
    for (source, _), same in groups.items():
        if len(same) < 2:
            continue
        digests = [hashlib.sha1(key(j).encode("utf-8", "surrogateescape")).hexdigest() for j in same]
        n = 6
        while len({d[:n] for d in digests}) < len(same) or any((source, f"{j.clip}-{d[:n]}".lower()) in taken
                                                                  for j, d in zip(same, digests)):
            n += 2
        for j, d in zip(same, digests):
            j.clip = f"{j.clip}-{d[:n]}"
    return jobs


def bandai_jobs(root: Path, n_captions: int = 4) -> list[Job]:
    jobs = []
    sets = sorted(p for p in root.rglob("Bandai-Namco-Research-Motiondataset-*") if p.is_dir())
    if not sets:
        raise FileNotFoundError(f"{root}: no Bandai-Namco-Research-Motiondataset-* folders")
    for ds in sets:
        contents = [l.strip() for l in (ds / "cfg" / "content_label.txt").read_text().splitlines() if l.strip()]
        styles = [l.strip() for l in (ds / "cfg" / "style_label.txt").read_text().splitlines() if l.strip()]
        strip = lambda s: re.sub(r"^dataset-\d+_", "", s)
        contents, styles = [strip(c) for c in contents], [strip(s) for s in styles]
        dsname = "d" + ds.name.rsplit("-", 1)[-1]
        for bvh in sorted((ds / "data").glob("*.bvh")):
            meta_path = bvh.with_suffix(".json")
            try:
                meta = json.loads(meta_path.read_text())
                content, style = contents[int(meta["content"])], styles[int(meta["style"])]
            except FileNotFoundError:
                raise MocapFormatError(str(meta_path), None, "label file missing beside the BVH") from None
            except (KeyError, ValueError, IndexError, json.JSONDecodeError) as e:
                raise MocapFormatError(str(meta_path), None, f"expected {{\"content\": i, \"style\": j}} with valid indices ({e})") from None
            seed = int(re.sub(r"\D", "", bvh.stem)[-3:] or 0)
            jobs.append(Job("bandai", "bvh", str(bvh), "bandai", f"bandai/{bvh.stem}", _safe(f"{dsname}-{bvh.stem.split('_', 1)[1]}"),
                            actions.BANDAI[content], style, captions.bandai_captions(content, style, n_captions, seed),
                            extra={"content": content}))
    return jobs


def hdm05_jobs(root: Path, n_captions: int = 4) -> list[Job]:
    jobs = []
    amcs = sorted(p for p in root.rglob("*") if p.suffix.lower() == ".amc")
    if not amcs:
        raise FileNotFoundError(f"{root}: no HDM05 .amc files")
    for amc in amcs:
        m = re.match(r"HDM_([a-z]+)_([A-Za-z0-9]+)_(\d+)_(\d+)$", amc.stem)
        if not m:
            raise MocapFormatError(str(amc), None, "file name does not match HDM_<actor>_<action>_<id>_<fps>.amc")
        actor, name, idx, fps = m.groups()
        key = next(k for k in sorted(actions.HDM05, key=len, reverse=True) if name.startswith(k)) \
            if any(name.startswith(k) for k in actions.HDM05) else None
        if key is None:
            raise MocapFormatError(str(amc), None, f"unknown HDM05 action {name!r}")
        asf = amc.parent / f"HDM_{actor}.asf"
        jobs.append(Job("hdm05", "amc", str(amc), "cmu_asfamc", f"hdm05/{actor}_{name}_{idx}", _safe(f"{actor}-{name}-{idx}"),
                        actions.HDM05[key], "", captions.hdm05_captions(key, n_captions, int(idx)), asf=str(asf), fps=float(fps),
                        extra={"actor": actor}))
    return jobs


def cmu_descriptions(csv_path: Path) -> dict[tuple[int, int], str]:
    out = {}
    with open(csv_path, newline="", encoding="utf-8", errors="replace") as f:
        for row in csv.DictReader(f):
            try:
                out[(int(row["Subject"]), int(row["Trial #"]))] = row["Motion Description"].strip()
            except (KeyError, ValueError):
                continue
    return out


def cmu_jobs(root: Path, n_captions: int = 4) -> list[Job]:
    csvs = list(root.rglob("cmu-descriptions.csv"))
    if not csvs:
        raise FileNotFoundError(f"{root}: cmu-descriptions.csv not found")
    desc = cmu_descriptions(csvs[0])
    jobs = []
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in (".bvh", ".amc"))
    for f in files:
        m = re.match(r"(\d+)_(\d+)$", f.stem)
        if not m:
            continue
        subj, trial = int(m.group(1)), int(m.group(2))
        d = desc.get((subj, trial))
        if d is None:
            raise MocapFormatError(str(f), None, f"no description for subject {subj}, trial {trial} in {csvs[0]}")
        take = f"cmu/{subj:02d}_{trial:02d}"
        caps = captions.cmu_captions(d, n_captions, trial)
        if f.suffix.lower() == ".bvh":
            jobs.append(Job("cmu", "bvh", str(f), "cmu_cc_bvh", take, f"{subj:02d}_{trial:02d}-bvh", actions.cmu_action(d), "", caps,
                            extra={"description": d}, stratum=actions.cmu_stratum(d)))
        else:
            jobs.append(Job("cmu", "amc", str(f), "cmu_asfamc", take, f"{subj:02d}_{trial:02d}-amc", actions.cmu_action(d), "", caps,
                            asf=str(f.parent / f"{subj:02d}.asf"), fps=120.0, extra={"description": d},
                            stratum=actions.cmu_stratum(d)))
    return jobs


def user_jobs(root: Path, joint_map: str, amc_fps: float = 120.0, n_captions: int = 4) -> list[Job]:
    root = Path(root)
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in (".bvh", ".amc"))
    if not files:
        raise FileNotFoundError(f"{root}: no .bvh or .amc files found")
    jobs = []
    for f in files:
        rel = f.relative_to(root)
        action = _safe(rel.parts[0]).lower() if len(rel.parts) > 1 else "unknown"
        side = f.with_suffix(".txt")
        if side.is_file():
            caps = [l.strip().replace("#", " ") for l in side.read_text().splitlines() if l.strip()]
        else:
            caps = []
        if not caps:
            phrase = action.replace("-", " ").replace("_", " ")
            caps = [f"A person performs the motion: {phrase}."]
        clip = _safe(str(rel.with_suffix("")).replace("/", "-")) or "clip"
        kind = "bvh" if f.suffix.lower() == ".bvh" else "amc"
        asf, extra = "", {}
        if kind == "amc":
            try:
                asf = str(find_asf(f))
            except MocapFormatError as e:   # that file is skipped with this reason, the others go on
                extra["asf_error"] = e.message
        jobs.append(Job("user", kind, str(f), joint_map, "", clip, action, "", caps[:max(n_captions, len(caps))],
                        asf=asf, fps=amc_fps, extra=extra))
    unique_clips(jobs, key=lambda j: Path(j.path).relative_to(root).as_posix())
    for j in jobs:
        j.take = f"user/{j.clip}"
    return jobs
