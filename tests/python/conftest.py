"""Shared fixtures of the Python tests."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from emdm import paths

# The archives `emdm.data.prepare` reads from the shared data folder (../shared/data beside the checkout,
# or $EMDM_SHARED_DATA); see its README.
SHARED_ARCHIVES = ("bandai-namco-motion.tar.xz", "hdm05-subset.tar.xz", "cmu-mocap-subset.tar.xz")
REAL_LIMIT = 2          # takes per source: a few dozen real clips, in seconds once the archives are unpacked


@pytest.fixture(scope="session")
def real_dataset(tmp_path_factory) -> Path:
    """A small real dataset (HumanML3D layout) that `python -m emdm.data.prepare` makes from the first
    REAL_LIMIT takes of each shared source. Archives are unpacked into data/raw (the cache every run of prepare
    shares, git-ignored); the dataset goes to a temporary folder. Skips only when the shared folder is absent."""
    shared = paths.shared_data_dir()
    missing = [a for a in SHARED_ARCHIVES if not (shared / a).is_file()]
    if missing:
        pytest.skip(f"real mocap not available: {', '.join(missing)} not in {shared} (put the shared data folder at "
                    f"../shared/data beside the checkout or set EMDM_SHARED_DATA)")
    out = tmp_path_factory.mktemp("real") / "dataset"
    cmd = [sys.executable, "-m", "emdm.data.prepare", "--sources", "bandai,hdm05,cmu", "--limit", str(REAL_LIMIT),
           "--shared", str(shared), "--out", str(out), "--workers", "1"]
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=paths.REPO_ROOT)
    if r.returncode != 0:
        pytest.fail(f"`{' '.join(cmd[1:])}` exited {r.returncode}:\n{r.stdout[-3000:]}\n{r.stderr[-3000:]}")
    return out
