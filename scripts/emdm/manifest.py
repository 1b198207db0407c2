"""The one reader/writer of ``public/models/manifest.json`` (schema: docs/MANIFEST.md).

Every file a runtime fetches is listed under ``files`` with its size and sha256; the TypeScript
loader refuses a file whose hash differs. Writes are atomic (temp file + rename), so a crash never
leaves a half-written manifest.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path
from typing import Any

SCHEMA_VERSION = 1
REPO_ROOT = Path(__file__).resolve().parents[2]
DEFAULT_MODELS_DIR = REPO_ROOT / "public" / "models"
MANIFEST_NAME = "manifest.json"


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
    from emdm import skeleton as sk

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


def load(models_dir: Path | str = DEFAULT_MODELS_DIR, *, missing_ok: bool = False) -> dict[str, Any]:
    path = Path(models_dir) / MANIFEST_NAME
    if not path.exists():
        if missing_ok:
            return empty_manifest()
        raise ManifestError(f"{path}: manifest not found; run `python -m emdm.export` or the encoder export first")
    try:
        data = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise ManifestError(f"{path}:{e.lineno}:{e.colno}: invalid JSON: {e.msg}") from e
    if data.get("schema") != SCHEMA_VERSION:
        raise ManifestError(f"{path}: field 'schema' is {data.get('schema')!r}, expected {SCHEMA_VERSION}")
    for key in ("textEncoders", "models", "files"):
        data.setdefault(key, {})
    return data


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
        p = models_dir / rel
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
    manifest[section][name] = entry
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
        p = models_dir / rel
        if not p.is_file():
            problems.append(f"{p}: missing")
            continue
        if p.stat().st_size != meta["bytes"]:
            problems.append(f"{p}: size {p.stat().st_size} != manifest {meta['bytes']}")
        elif sha256_file(p) != meta["sha256"]:
            problems.append(f"{p}: sha256 differs from the manifest")
    return problems
