"""The one reader/writer of ``public/models/manifest.json`` (schema: docs/MANIFEST.md).

Every file a runtime fetches is listed under ``files`` with its size and sha256; the TypeScript
loader refuses a file whose hash differs. Writes are atomic (temp file + rename), so a crash never
leaves a half-written manifest.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import tempfile
from pathlib import Path
from typing import Any

from emdm import skeleton as sk

SCHEMA_VERSION = 1
REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_MODELS_DIR = REPO_ROOT / "public" / "models"
MANIFEST_NAME = "manifest.json"
KEPT_ON_UPDATE = ("license", "card")      # an entry's fields that re-exporting it keeps (update_entry)
# Bounds on every size a manifest can set (what sampling allocates follows from them): a step count, a model's frames,
# its noise and condition widths, x̂0 smoothing σ (frames). The page's validateManifest (src/manifest.ts) has the same.
MAX_STEPS = 1000
MAX_MODEL_FRAMES = 1000
MAX_DIM = 4096
MAX_X0_SMOOTHING = 50.0
FEATURE_DIM = 263
_SHA256 = re.compile(r"[0-9a-f]{64}")


class ManifestError(ValueError):
    """A manifest is missing, malformed, or names a file that is absent."""


def sha256_file(path: Path | str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def skeleton_entry() -> dict[str, Any]:
    """The reference skeleton and motion format, as both runtimes need them."""
    return {
        "joints": list(sk.JOINT_NAMES),
        "parents": [int(p) for p in sk.PARENTS],
        "offsets": [[round(float(v), 6) for v in o] for o in sk.REFERENCE_OFFSETS],
        "chains": [list(map(int, c)) for c in sk.KINEMATIC_CHAINS],
        "footJoints": [int(j) for j in sk.FOOT_JOINTS],
        "fps": int(sk.FPS),
        "maxFrames": int(sk.MAX_FRAMES),
        "featureDim": int(sk.FEATURE_DIM),
    }


def empty_manifest() -> dict[str, Any]:
    return {"schema": SCHEMA_VERSION, "skeleton": {}, "textEncoders": {}, "models": {}, "files": {}}


def _no_constant(name: str):
    raise ValueError(f"{name} is not a JSON number")


def read_json(path: Path) -> Any:
    """The JSON value of ``path``; anything but UTF-8 JSON text (NaN/Infinity included, as in JSON.parse, or nested
    too deeply to read) is a ManifestError naming the file."""
    try:
        text = path.read_bytes().decode("utf-8")
    except OSError as e:
        raise ManifestError(f"{path}: cannot read it ({e.strerror or e})") from None
    except UnicodeDecodeError as e:
        raise ManifestError(f"{path}: not UTF-8 text (byte {e.start}); a manifest is a JSON file") from None
    try:
        return json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as e:
        raise ManifestError(f"{path}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}") from None
    except ValueError as e:     # NaN/Infinity, an integer of more than 4300 digits
        raise ManifestError(f"{path}: invalid JSON: {str(e).splitlines()[0][:120]}") from None
    except RecursionError:
        raise ManifestError(f"{path}: invalid JSON: nested too deeply to be a manifest") from None


def check_rel_path(rel: Any, field: str, where: Path | str) -> str:
    """``rel`` if it is a relative path inside the models folder ('/'-separated names, none of them '', '.' or '..',
    no drive, scheme or backslash), else a ManifestError naming ``field``: a manifest never reaches outside its folder."""
    parts = rel.split("/") if isinstance(rel, str) else []
    if (not parts or any(p in ("", ".", "..") for p in parts) or "\\" in rel or ":" in rel or "\0" in rel
            or len(rel) > 1024):
        raise ManifestError(f"{where}: field '{field}' is {str(json.dumps(rel))[:100]}; it must be a relative path "
                            "inside the models folder (names separated by '/', no '..', '.', leading '/' or ':')")
    return rel


def file_path(models_dir: Path | str, rel: Any, field: str) -> Path:
    """``models_dir / rel`` for a path a manifest names: relative (``check_rel_path``) and, with links resolved, still
    inside ``models_dir``; else a ManifestError naming the field."""
    where = Path(models_dir) / MANIFEST_NAME
    check_rel_path(rel, field, where)
    root = Path(models_dir).resolve()
    path = Path(models_dir) / rel
    if not path.resolve().is_relative_to(root):
        raise ManifestError(f"{where}: field '{field}' names {rel!r}, which resolves outside {models_dir} (a link); "
                            "a manifest's files stay inside its folder")
    return path


def verified_file(manifest: dict, models_dir: Path | str, rel: str, what: str, field: str = "files",
                  remedy: str = "restore the file or re-export the model") -> Path:
    """``models_dir / rel`` if it lies inside ``models_dir`` (``field``: the manifest field naming it), the manifest
    lists it under ``files`` and it has that size and sha256; else a ManifestError naming the file and ``remedy``."""
    path = file_path(models_dir, rel, field)      # relative, and inside models_dir once links are resolved
    man = Path(models_dir) / MANIFEST_NAME
    listed = manifest.get("files", {}).get(rel)
    if not isinstance(listed, dict):
        raise ManifestError(f"{path}: {what}, but {man} does not list it under 'files'; refusing an unverified file "
                            f"({remedy})")
    if not path.is_file():
        raise ManifestError(f"{path}: missing ({what} in {man}); {remedy}")
    size = path.stat().st_size
    if size != listed.get("bytes"):
        raise ManifestError(f"{path}: {size} bytes, {man} lists {listed.get('bytes')} (a changed or truncated file); "
                            f"{remedy}")
    if sha256_file(path) != listed.get("sha256"):
        raise ManifestError(f"{path}: sha256 differs from {man} (a changed or corrupt file); {remedy}")
    return path


def _check_structure(data: Any, path: Path) -> dict[str, Any]:
    """The manifest's shape: an object of schema 1 whose sections are objects, whose 'files' table maps relative
    paths to {bytes, sha256}, and whose entries' paths (files, onnx, meanStd, variants, trainingWeights, dir) are
    relative paths inside the folder. The first bad field is a ManifestError."""
    if not isinstance(data, dict):
        raise ManifestError(f"{path}: expected a JSON object, got a {type(data).__name__}")
    if data.get("schema") != SCHEMA_VERSION:
        raise ManifestError(f"{path}: field 'schema' is {str(data.get('schema'))[:40]!s}, expected {SCHEMA_VERSION}")
    for key in ("textEncoders", "models", "files"):
        data.setdefault(key, {})
        if not isinstance(data[key], dict):
            raise ManifestError(f"{path}: field '{key}' must be an object, got a {type(data[key]).__name__}")
    for rel, meta in data["files"].items():
        check_rel_path(rel, f"files[{rel!r}]", path)
        if (not isinstance(meta, dict) or isinstance(meta.get("bytes"), bool) or not isinstance(meta.get("bytes"), int)
                or meta["bytes"] < 0 or not isinstance(meta.get("sha256"), str) or not _SHA256.fullmatch(meta["sha256"])):
            raise ManifestError(f"{path}: field 'files[{rel!r}]' must be {{\"bytes\": a size ≥ 0, \"sha256\": 64 "
                                "lower-case hex digits}")
    for section in ("textEncoders", "models"):
        for name, entry in data[section].items():
            if not isinstance(entry, dict):
                raise ManifestError(f"{path}: field '{section}.{name}' must be an object")
            files = entry.get("files", [])
            if not isinstance(files, list):
                raise ManifestError(f"{path}: field '{section}.{name}.files' must be a list of paths")
            for i, rel in enumerate(files):
                check_rel_path(rel, f"{section}.{name}.files[{i}]", path)
            for key in ("onnx", "meanStd", "trainingWeights", "dir"):
                if key in entry:
                    check_rel_path(entry[key], f"{section}.{name}.{key}", path)
            variants = entry.get("variants", {})
            if not isinstance(variants, dict):
                raise ManifestError(f"{path}: field '{section}.{name}.variants' must be an object of files")
            for v, rel in variants.items():
                check_rel_path(rel, f"{section}.{name}.variants.{v}", path)
    return data


def load(models_dir: Path | str = DEFAULT_MODELS_DIR, *, missing_ok: bool = False) -> dict[str, Any]:
    """The manifest of ``models_dir``, checked for shape and safe paths (``_check_structure``); ManifestError (one line
    naming the file and field) for anything else."""
    path = Path(models_dir) / MANIFEST_NAME
    if not path.exists():
        if missing_ok:
            return empty_manifest()
        raise ManifestError(f"{path}: manifest not found; run `python -m emdm.export` or the encoder export first")
    return _check_structure(read_json(path), path)


def _field(where: Path | str, name: str, key: str, v: Any, want: str) -> ManifestError:
    return ManifestError(f"{where}: field 'models.{name}.{key}' is {str(json.dumps(v))[:80]}; it must be {want}")


def _int_in(v: Any, lo: int, hi: int) -> bool:
    return isinstance(v, int) and not isinstance(v, bool) and lo <= v <= hi


def _number_in(v: Any, lo: float, hi: float) -> bool:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return False
    return (isinstance(v, int) or math.isfinite(v)) and lo <= v <= hi    # an int past float's range: no isfinite


def check_model_entry(entry: dict[str, Any], name: str, where: Path | str) -> dict[str, Any]:
    """A model entry that sampling can use: every field it reads has the right type and a bounded size (steps ≤
    MAX_STEPS, maxFrames ≤ MAX_MODEL_FRAMES, zDim and condition.dim ≤ MAX_DIM, x0Smoothing ≤ MAX_X0_SMOOTHING frames,
    speedCap ≥ 0), else a ManifestError naming the field."""
    for key in ("task", "condition", "onnx", "meanStd"):
        if key not in entry:
            raise ManifestError(f"{where}: models.{name} lacks {key!r}")
    checks = [
        ("task", lambda v: isinstance(v, str), "a task name"),
        ("objective", lambda v: v in ("ddgan", "diffusion"), '"ddgan" or "diffusion"'),
        ("zDim", lambda v: _int_in(v, 1, MAX_DIM), f"an integer in 1..{MAX_DIM}"),
        ("featureDim", lambda v: v == FEATURE_DIM, f"{FEATURE_DIM}"),
        ("maxFrames", lambda v: _int_in(v, 1, MAX_MODEL_FRAMES), f"an integer in 1..{MAX_MODEL_FRAMES}"),
        ("guidance", lambda v: _number_in(v, 0, 1e6), "a finite scale ≥ 0"),
        ("guidanceMinTime", lambda v: _number_in(v, 0, 1e6), "a finite time ≥ 0"),
        ("x0Smoothing", lambda v: _number_in(v, 0, MAX_X0_SMOOTHING), f"a σ ≥ 0 in frames, at most {MAX_X0_SMOOTHING:g}"),
        ("speedCap", lambda v: _number_in(v, 0, 1e6), "a finite multiple ≥ 0 of the first step's root speed (0 = off)"),
        ("defaultSteps", lambda v: _int_in(v, 1, MAX_STEPS), f"an integer in 1..{MAX_STEPS}"),
        ("supportedSteps", lambda v: isinstance(v, list) and 0 < len(v) <= MAX_STEPS
         and all(_int_in(s, 1, MAX_STEPS) for s in v), f"a list of step counts in 1..{MAX_STEPS}"),
        ("defaultVariant", lambda v: isinstance(v, str) and v in (entry.get("variants") or {}), "one of its variants"),
        ("training", lambda v: isinstance(v, dict), "an object"),
    ]
    for key, ok, want in checks:
        if key in entry and not ok(entry[key]):
            raise _field(where, name, key, entry[key], want)
    cond = entry["condition"]
    if not isinstance(cond, dict) or cond.get("type") not in ("text", "action") or not _int_in(cond.get("dim"), 1, MAX_DIM):
        raise _field(where, name, "condition", cond, f'{{"type": "text" or "action", "dim": 1..{MAX_DIM}, ...}}')
    if cond["type"] == "text" and not isinstance(cond.get("encoder"), str):
        raise _field(where, name, "condition.encoder", cond.get("encoder"), "a text encoder id")
    labels = cond.get("labels")
    if cond["type"] == "action" and not (isinstance(labels, list) and len(labels) == cond["dim"]
                                         and all(isinstance(x, str) for x in labels)):
        raise _field(where, name, "condition.labels", labels, f"a list of {cond['dim']} action names (condition.dim)")
    tr = entry.get("training", {})
    for key, ok, want in (("steps", lambda v: v is None or _int_in(v, 0, 10**15), "a step count"),
                          ("wallSeconds", lambda v: _number_in(v, 0, 1e15), "seconds ≥ 0"),
                          ("flags", lambda v: isinstance(v, dict), "an object"),
                          ("continuedFrom", lambda v: isinstance(v, dict) and _int_in(v.get("steps", 0), 0, 10**15),
                           '{"steps": a step count, ...}')):
        if key in tr and not ok(tr[key]):
            raise _field(where, name, f"training.{key}", tr[key], want)
    return entry


def referenced_files(manifest: dict[str, Any]) -> list[str]:
    """All files named by text encoders and models (relative to the models dir)."""
    out: list[str] = []
    for section in ("textEncoders", "models"):
        for name, entry in manifest.get(section, {}).items():
            files = entry.get("files")
            if not isinstance(files, list):
                raise ManifestError(f"manifest {section}.{name}: field 'files' must be a list of paths")
            out.extend(files)
    return sorted(set(out))


def refresh_files(manifest: dict[str, Any], models_dir: Path | str) -> dict[str, Any]:
    """Recompute size + sha256 of every referenced file; fail (naming it) if one is missing."""
    models_dir = Path(models_dir)
    table = {}
    for rel in referenced_files(manifest):
        p = file_path(models_dir, rel, "files")
        if not p.is_file():
            raise ManifestError(f"{p}: listed in the manifest but missing")
        table[rel] = {"bytes": p.stat().st_size, "sha256": sha256_file(p)}
    manifest["files"] = table
    return manifest


def save(manifest: dict[str, Any], models_dir: Path | str = DEFAULT_MODELS_DIR) -> Path:
    """Refresh the skeleton and file table, then write atomically."""
    models_dir = Path(models_dir)
    models_dir.mkdir(parents=True, exist_ok=True)
    manifest["schema"] = SCHEMA_VERSION
    manifest["skeleton"] = skeleton_entry()
    refresh_files(manifest, models_dir)
    text = json.dumps(manifest, indent=1, sort_keys=False) + "\n"
    fd, tmp = tempfile.mkstemp(dir=models_dir, prefix=".manifest.", suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(tmp, 0o644)  # mkstemp creates 0600; the manifest is a public, served file
        os.replace(tmp, models_dir / MANIFEST_NAME)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
    return models_dir / MANIFEST_NAME


def update_entry(section: str, name: str, entry: dict[str, Any], models_dir: Path | str = DEFAULT_MODELS_DIR) -> Path:
    """Add or replace ``manifest[section][name]`` (section: 'textEncoders' or 'models') and save."""
    if section not in ("textEncoders", "models"):
        raise ManifestError(f"unknown manifest section {section!r}")
    manifest = load(models_dir, missing_ok=True)
    old = manifest[section].get(name) or {}
    # the terms of use and the model card are written by hand (docs/MODELS.md "Model card"): a re-export keeps them
    manifest[section][name] = {**{k: old[k] for k in KEPT_ON_UPDATE if k in old}, **entry}
    return save(manifest, models_dir)


def verify(models_dir: Path | str = DEFAULT_MODELS_DIR) -> list[str]:
    """Return a list of problems (empty when every listed file matches its size and sha256)."""
    models_dir = Path(models_dir)
    manifest = load(models_dir)
    problems = []
    for rel in referenced_files(manifest):
        if rel not in manifest["files"]:
            problems.append(f"{rel}: referenced but not in 'files'")
    for rel, meta in manifest["files"].items():
        p = file_path(models_dir, rel, f"files[{rel!r}]")
        if not p.is_file():
            problems.append(f"{p}: missing")
            continue
        if p.stat().st_size != meta["bytes"]:
            problems.append(f"{p}: size {p.stat().st_size} != manifest {meta['bytes']}")
        elif sha256_file(p) != meta["sha256"]:
            problems.append(f"{p}: sha256 differs from the manifest")
    return problems
