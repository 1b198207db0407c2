"""docs/MODELS.md's generated tables, from committed inputs only — the two commands:

    python -m emdm.eval.models_report measure    # bone lengths of every shipped ONNX file -> docs/results/json/models-bones.json
    python -m emdm.eval.models_report            # rewrites the generated blocks of docs/MODELS.md

A generated block sits between ``<!-- models_report:NAME -->`` and ``<!-- /models_report:NAME -->``:

* ``files``: each model's training steps and file sizes (public/models/manifest.json);
* ``losses``: final training losses (the manifest's ``training.losses``);
* ``bones``: bone lengths of every shipped ONNX file, fp32 and each variant (models-bones.json, written by
  ``measure`` with the measure of tests/python/test_shipped_models.py, which checks the JSON is current);
* ``variants``: the variants' one-step error (the manifest's ``variantRelErr``, written by ``emdm.export``).

Everything else in MODELS.md is prose; numbers whose inputs are not in the repository are marked there.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import time
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm import skeleton as sk
from emdm.model.open import onnx_step, read_meanstd
from emdm.sampler import SamplingSettings, denormalise, make_condition, sample_features
from emdm.sampler.settings import method_of
from emdm.motion.features import recover_joints
from emdm.outdir import write_text_atomic

MODELS_MD = paths.REPO_ROOT / "docs" / "MODELS.md"
BONES_JSON = paths.REPO_ROOT / "docs" / "results" / "json" / "models-bones.json"
SCHEMA = 1

# The bone measure (as tests/python/test_shipped_models.py): these conditions, two seeds each, FRAMES frames,
# the model's default steps and guidance; per bone the median over frames of |length / reference - 1|.
PROMPTS = ["a person walks forward", "a person waves with both hands", "a person jumps up"]
ACTIONS = ["walk", "wave-both-hands", "jump"]
SEEDS = (0, 1)
FRAMES = 120

WHAT = {("text", "ddgan"): "EMDM text-to-motion (also unconditional; classifier-free guidance {guidance})",
        ("action", "ddgan"): "EMDM action-to-motion ({labels} labels)",
        ("text", "diffusion"): "the DDIM baseline: the same network trained on the plain x0 objective"}


class ModelsReportError(ValueError):
    pass


# ----------------------------------------------------------------------------------------------- measuring

def condition(entry: dict, i: int) -> np.ndarray:
    if entry["condition"]["type"] == "text":
        return make_condition(entry["condition"], PROMPTS[i], None, False)
    return make_condition(entry["condition"], None, ACTIONS[i], False)


def onnx_files(entry: dict) -> dict[str, str]:
    """{'fp32': file, 'int8': file, ...}: the model's ONNX file and every variant the manifest lists."""
    return {"fp32": entry["onnx"], **entry.get("variants", {})}


def bone_errors(joints: np.ndarray) -> np.ndarray:
    """(21,) median over frames of each bone's relative length error against the reference skeleton."""
    ref = np.linalg.norm(sk.REFERENCE_OFFSETS[1:], axis=1)
    bones = np.linalg.norm(joints[:, 1:] - joints[:, sk.PARENTS[1:]], axis=-1)
    return np.median(np.abs(bones / ref - 1.0), axis=0)


def measure_file(entry: dict, onnx: Path) -> dict:
    """Worst bone (median over frames, worst over conditions and seeds) and the mean over bones of each bone's
    worst, for one ONNX file."""

    step = onnx_step(onnx, threads=1)
    mean, std = read_meanstd(paths.MODELS_DIR / entry["meanStd"])
    per_bone = np.zeros(len(sk.PARENTS) - 1)
    # the model's own bones: its default steps and guidance, guided at every step, no x̂0 smoothing (what
    # tests/python/test_shipped_models.py measures against this table)
    settings = SamplingSettings(method_of(entry.get("objective", "ddgan")), entry["defaultSteps"], entry["guidance"],
                                z_dim=entry["zDim"])
    for i in range(len(PROMPTS)):
        cond = condition(entry, i)
        for seed in SEEDS:
            x = sample_features(step, cond, FRAMES, settings, seed)
            per_bone = np.maximum(per_bone, bone_errors(recover_joints(denormalise(x[0], mean, std))))
    worst = int(np.argmax(per_bone))
    return {"worst": float(per_bone[worst]), "worst_bone": sk.JOINT_NAMES[worst + 1], "mean": float(per_bone.mean())}


def measure(models_dir: Path = paths.MODELS_DIR) -> dict:
    man = mf.load(models_dir)
    rows = []
    for name, entry in man["models"].items():
        for variant, file in onnx_files(entry).items():
            t0 = time.perf_counter()
            r = measure_file(entry, models_dir / file)
            rows.append({"model": name, "variant": variant, "file": file, "sha256": man["files"][file]["sha256"], **r})
            print(f"{file}: worst bone {r['worst']:.1%} ({r['worst_bone']}), mean {r['mean']:.1%} "
                  f"({time.perf_counter() - t0:.1f} s)")
    return {"schema": SCHEMA, "task": "models-bones", "frames": FRAMES, "seeds": list(SEEDS),
            "conditions": {"text": PROMPTS, "action": ACTIONS}, "rows": rows}


def load_bones(path: Path = BONES_JSON) -> dict:
    try:
        doc = json.loads(path.read_text())
    except FileNotFoundError as e:
        raise ModelsReportError(f"{path}: absent; run `python -m emdm.eval.models_report measure`") from e
    if doc.get("schema") != SCHEMA or doc.get("task") != "models-bones":
        raise ModelsReportError(f"{path}: not a models-bones JSON of schema {SCHEMA}")
    return doc


def stale_rows(bones: dict, man: dict) -> list[str]:
    """Rows measured on another file than the one shipped now, and shipped files never measured."""
    out = []
    have = {(r["model"], r["variant"]): r for r in bones["rows"]}
    for name, entry in man["models"].items():
        for variant, file in onnx_files(entry).items():
            r = have.get((name, variant))
            if r is None:
                out.append(f"{file}: not measured")
            elif r["sha256"] != man["files"][file]["sha256"]:
                out.append(f"{file}: measured on another file (sha256 {r['sha256'][:12]}…)")
    return out


# ----------------------------------------------------------------------------------------------- tables

def _table(header: list[str], rows: list[list[str]]) -> str:
    return "\n".join(["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
                     + ["| " + " | ".join(r) + " |" for r in rows])


def _mb(n: int) -> str:
    return f"{n / 1e6:.1f} MB"


def total_steps(entry: dict) -> int:
    t = entry["training"]
    return int(t["steps"]) + int(t.get("continuedFrom", {}).get("steps", 0))


def files_table(man: dict) -> str:
    rows = []
    for name, e in man["models"].items():
        what = WHAT.get((e["task"], e.get("objective", "ddgan")), e["task"]).format(
            guidance=e["guidance"], labels=len(e["condition"].get("labels", [])))
        sizes = [f"fp32 {_mb(man['files'][e['onnx']]['bytes'])}"]
        sizes += [f"{v} {_mb(man['files'][f]['bytes'])}" for v, f in e.get("variants", {}).items()]
        if "trainingWeights" in e:
            sizes.append(f"training weights {_mb(man['files'][e['trainingWeights']]['bytes'])}")
        rows.append([f"`{name}`", what, f"{total_steps(e):,}", ", ".join(sizes)])
    return _table(["model", "what", "steps trained", "files"], rows)


def losses_table(man: dict) -> str:
    keys = ["loss_d", "g_adv", "recon", "pos", "vel", "foot", "bone"]
    rows = []
    for name, e in man["models"].items():
        losses = e["training"].get("losses", {})
        rows.append([f"`{name}`"] + [f"{losses[k]:.3g}" if k in losses else "–" for k in keys])
    return _table(["model"] + keys, rows)


def bones_table(bones: dict, man: dict) -> str:
    have = {(r["model"], r["variant"]): r for r in bones["rows"]}
    variants = sorted({v for e in man["models"].values() for v in onnx_files(e)}, key=lambda v: (v != "fp32", v))
    rows = []
    for name, e in man["models"].items():
        cells = [f"`{name}`"]
        for v in variants:
            r = have.get((name, v))
            cells.append("–" if r is None else f"{r['worst']:.1%} ({r['worst_bone']}); mean {r['mean']:.1%}")
        rows.append(cells)
    return _table(["model"] + [f"{v}: worst bone (median); mean over bones" for v in variants], rows)


def variants_table(man: dict) -> str:
    variants = sorted({v for e in man["models"].values() for v in e.get("variantRelErr", {})})
    rows = [[f"`{name}`"] + [f"{e['variantRelErr'][v]:.3g}" if v in e.get("variantRelErr", {}) else "–" for v in variants]
            for name, e in man["models"].items()]
    return _table(["model"] + [f"{v}: max error ÷ output std" for v in variants], rows)


def blocks(man: dict, bones: dict) -> dict[str, str]:
    return {"files": files_table(man), "losses": losses_table(man), "bones": bones_table(bones, man),
            "variants": variants_table(man)}


BLOCK = re.compile(r"(<!-- models_report:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /models_report:(?P=name) -->)", re.S)


def render(text: str, tables: dict[str, str], where: str = "MODELS.md") -> str:
    found = set()

    def sub(m: re.Match) -> str:
        name = m.group("name")
        if name not in tables:
            raise ModelsReportError(f"{where}: unknown generated block {name!r} (known: {', '.join(tables)})")
        found.add(name)
        return f"{m.group(1)}{tables[name]}\n{m.group(4)}"

    out = BLOCK.sub(sub, text)
    if found != set(tables):
        raise ModelsReportError(f"{where}: no marker for block(s) {', '.join(sorted(set(tables) - found))}; add "
                                f"'<!-- models_report:NAME -->' and '<!-- /models_report:NAME -->' lines")
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.models_report", description=__doc__.split("\n\n")[0])
    ap.add_argument("command", nargs="?", choices=["render", "measure"], default="render")
    ap.add_argument("--out", type=Path, default=MODELS_MD)
    ap.add_argument("--bones", type=Path, default=BONES_JSON)
    a = ap.parse_args(argv)
    if a.command == "measure":
        doc = measure()
        a.bones.parent.mkdir(parents=True, exist_ok=True)
        a.bones.write_text(json.dumps(doc, indent=1) + "\n")
        print(f"wrote {a.bones}")
        return 0
    man = mf.load(paths.MODELS_DIR)
    bones = load_bones(a.bones)
    stale = stale_rows(bones, man)
    if stale:
        print(f"{a.bones} is stale ({'; '.join(stale)}): run `python -m emdm.eval.models_report measure` first",
              file=sys.stderr)
        return 2
    text = render(a.out.read_text(), blocks(man, bones), str(a.out))
    write_text_atomic(a.out, text)
    print(f"wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
