"""The console scripts of the pipeline (pyproject.toml ``[project.scripts]``): ``emdm-prepare``, ``emdm-train``,
``emdm-export`` and ``emdm-eval`` run ``python -m emdm.data.prepare``, ``emdm.train``, ``emdm.export`` and
``emdm.eval.suite``. Training, export and evaluation need the ``[train]`` extra (torch and the rest); without it,
one line says so (exit status 2) instead of an import traceback. Preparing data needs numpy only, and
``emdm-sample`` is ``emdm.sample:main`` itself."""

from __future__ import annotations

import importlib
import sys

EXTRA = "pip install 'emdm[train]'"


def run(module: str, command: str) -> int:
    try:        # imported here on purpose: the module's own imports are what may be missing
        main = importlib.import_module(module).main
    except ModuleNotFoundError as e:
        if not e.name or e.name.split(".")[0] == "emdm":
            raise
        print(f"error: {command} needs {e.name.split('.')[0]}, which comes with the [train] extra: {EXTRA}",
              file=sys.stderr)
        return 2
    return main()


def prepare() -> int:
    return run("emdm.data.prepare", "emdm-prepare")


def train() -> int:
    return run("emdm.train", "emdm-train")


def export() -> int:
    return run("emdm.export", "emdm-export")


def evaluate() -> int:
    return run("emdm.eval.suite", "emdm-eval")
