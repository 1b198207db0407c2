"""The results folder and what every benchmark writes into it: one JSON per run under ``docs/results/json``
(schema SCHEMA; the fields of each task are listed in :mod:`emdm.eval.report`), written whole or not at all.

    out = RESULTS_DIR / "json" / f"coverage-{slug(name)}.json"
    write_result({"schema": SCHEMA, "task": "coverage", "hardware": hardware(), ...}, out)

``hardware``, ``dataset_info`` and ``evaluator_info`` are the descriptions every result carries, so that a row of
docs/RESULTS.md says where, on what and against which evaluator it was measured.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import platform
import re
from pathlib import Path

from emdm.paths import REPO_ROOT, display_path

RESULTS_DIR = REPO_ROOT / "docs" / "results"
RESULTS_MD = REPO_ROOT / "docs" / "RESULTS.md"
SCHEMA = 1


def slug(*parts) -> str:
    """A file-name part from labels: lower case, runs of anything but [a-z0-9] as one '-'; None parts left out."""
    return re.sub(r"[^a-z0-9]+", "-", "-".join(str(p) for p in parts if p is not None).lower()).strip("-")


def write_result(result: dict, out: Path) -> Path:
    """``result`` as JSON at ``out`` through a temporary file (an interrupted write leaves the old file)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_suffix(".tmp")
    tmp.write_text(json.dumps(result, indent=1))
    tmp.replace(out)
    return out


def hardware(torch_threads: bool = True) -> str:
    """The CPU (model name, cores), torch's thread count (unless ``torch_threads`` is False: a time row that names
    its own threads) and the GPU when there is one."""
    import torch  # lazy: the report and the page's figures are read and written without torch

    cpu = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    gpu = f", GPU {torch.cuda.get_device_name(0)}" if torch.cuda.is_available() else ""
    threads = f" ({torch.get_num_threads()} torch thread(s))" if torch_threads else ""
    return f"{cpu}, {os.cpu_count()} cores shared{threads}{gpu}"


def dataset_info(root: Path, split: str) -> dict:
    """The dataset a result was measured on: its name, split, clip ids per split and mocap sources."""
    counts = {}
    for s in ("train", "val", "test"):
        f = root / f"{s}.txt"
        if f.exists():
            counts[s] = sum(1 for line in f.read_text().splitlines() if line.strip())
    desc = ", ".join(f"{v} {k}" for k, v in counts.items()) + " clip ids"
    meta = root / "metadata.csv"
    if meta.exists():
        with open(meta, newline="") as fh:
            sources = sorted({row.get("source", "?") for row in csv.DictReader(fh)})
        desc += f"; sources: {', '.join(sources)}"
    return {"name": root.name, "split": split, "description": desc, "ids": counts}


def evaluator_info(model, path: Path) -> dict:
    """The trained evaluator (matcher or classifier, :mod:`emdm.eval.evaluators`) a result was judged by; ``sha256``
    (the file's first 16 hex digits) tells two judges apart: a retrained classifier moves single actions' rates by up to
    0.35 (docs/MODELS.md "Between slices (2026-11-28)")."""
    meta = getattr(model, "meta", {})
    final = meta.get("final", {})
    val = ", ".join(f"{k[4:]} {v:.3f}" for k, v in final.items() if k.startswith("val_"))
    digest = hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16] if Path(path).is_file() else None
    return {"path": display_path(path), "sha256": digest, "train_items": meta.get("train_items"), "minutes": meta.get("minutes"),
            "epochs_run": meta.get("epochs_run"), "config": meta.get("config"), "final": final,
            "summary": f"{type(model).__name__} (hidden {model.config['hidden']}) trained on "
                       f"{meta.get('train_items', '?')} train clips for {meta.get('epochs_run', '?')} epochs "
                       f"({meta.get('minutes', 0) or 0:.1f} min{'; val ' + val if val else ''})"}
