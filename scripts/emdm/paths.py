"""Where things live. Nothing machine-specific is hard-coded: the shared data folder is
``$EMDM_SHARED_DATA`` or ``../shared/data`` beside the checkout."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
# run from a checkout (scripts/emdm), or installed (site-packages/emdm: REPO_ROOT is then inside the environment)
IN_CHECKOUT = (REPO_ROOT / "package.json").is_file()
MODELS_DIR = REPO_ROOT / "public" / "models"
# git-ignored in a checkout: unpacked sources, prepared datasets; installed: ./data of the folder it runs in
DATA_DIR = REPO_ROOT / "data" if IN_CHECKOUT else Path("data")
DATASET_DIR = DATA_DIR / "dataset"            # default output of `python -m emdm.data.prepare`
RUNS_DIR = REPO_ROOT / "runs" if IN_CHECKOUT else Path("runs")   # checkpoints and logs
FIXTURES_DIR = REPO_ROOT / "tests" / "fixtures"


MODELS_ENV = "EMDM_MODELS_DIR"


class ModelsDirError(ValueError):
    """The models folder to read has no manifest.json (the message is one line: which folder, where it came from)."""


def models_dir(given: Path | str | None = None) -> Path:
    """The models folder to read (manifest.json, the step models, the text encoder): ``given`` (``models_dir=``,
    ``--models-dir``), else ``$EMDM_MODELS_DIR``, else the repository's public/models. The models are not part of
    the Python package: an installed package is pointed at a copy of public/models by one of the first two."""
    if given is not None:
        return Path(given)
    env = os.environ.get(MODELS_ENV)
    return Path(env) if env else MODELS_DIR


def require_models_dir(given: Path | str | None = None) -> Path:
    """``models_dir(given)`` if it holds a manifest.json; else ModelsDirError saying which folder and from where."""
    d = models_dir(given)
    if (d / "manifest.json").is_file():
        return d
    if given is None and not os.environ.get(MODELS_ENV) and not IN_CHECKOUT:
        raise ModelsDirError(f"no models folder: the installed package does not include the models; pass "
                             f"models_dir= / --models-dir or set ${MODELS_ENV} to a copy of the repository's "
                             "public/models (docs/PYTHON.md)")
    source = ("models_dir / --models-dir" if given is not None else
              f"${MODELS_ENV}" if os.environ.get(MODELS_ENV) else "the default, the repository's public/models")
    what = "is not a folder" if not d.is_dir() else "has no manifest.json"
    raise ModelsDirError(f"{d}: {what} (models folder from {source}); point models_dir= / --models-dir or "
                         f"${MODELS_ENV} at a copy of the repository's public/models (docs/PYTHON.md)")


def shared_data_dir() -> Path:
    """The read-only folder of mocap archives and the CLIP tokenizer (see its README): $EMDM_SHARED_DATA, else
    ../shared/data beside the checkout (installed: ./shared/data of the working folder)."""
    env = os.environ.get("EMDM_SHARED_DATA")
    if env:
        return Path(env)
    return REPO_ROOT.parent / "shared" / "data" if IN_CHECKOUT else Path("shared") / "data"   # installed: ./shared/data


def shared_file(name: str) -> Path:
    """A file or folder inside the shared data folder; FileNotFoundError says where it looked."""
    p = shared_data_dir() / name
    if not p.exists():
        where = ("Put the shared data folder beside the checkout (../shared/data) or set EMDM_SHARED_DATA to its path."
                 if IN_CHECKOUT or os.environ.get("EMDM_SHARED_DATA") else
                 "Set EMDM_SHARED_DATA to the folder of mocap archives (the installed package has no checkout beside it).")
        raise FileNotFoundError(f"{p}: not found. {where}")
    return p


def display_path(p) -> str:
    """A path as results and logs record it: relative to the repository when inside it, else as given
    (so committed JSON carries no machine's folder names)."""
    p = Path(p)
    try:
        return p.resolve().relative_to(REPO_ROOT).as_posix()
    except ValueError:
        return str(p)
