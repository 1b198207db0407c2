"""The Python package as a new user gets it: the wheel built from this checkout (nothing written into the checkout),
installed into a fresh venv with only its declared dependencies from the package index (no torch), then used from
a folder outside the checkout: the console script, emdm.generate writing a BVH and a GLB, the models folder from an
argument or $EMDM_MODELS_DIR and one line of error without one. Needs the package index (pip's cache makes reruns
quick); about a minute here."""

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MODELS = REPO / "public" / "models"
BUILD_LITTER = ("build", "dist", "*.egg-info", "scripts/*.egg-info", "scripts/build/lib")


def litter() -> set[str]:
    return {str(p.relative_to(REPO)) for pattern in BUILD_LITTER for p in REPO.glob(pattern)} - {"scripts/build"}


def clean_env(**extra) -> dict:
    """The environment without anything that points Python at the checkout or a models folder."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "EMDM_MODELS_DIR", "VIRTUAL_ENV")}
    return {**env, **extra}


def run(cmd, cwd, env=None, timeout=600) -> subprocess.CompletedProcess:
    return subprocess.run([str(c) for c in cmd], cwd=cwd, env=env or clean_env(), capture_output=True, text=True,
                          timeout=timeout)


def ok(r: subprocess.CompletedProcess) -> subprocess.CompletedProcess:
    assert r.returncode == 0, f"{' '.join(r.args)} exited {r.returncode}:\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}"
    return r


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    before = litter()
    ok(run([sys.executable, "-m", "pip", "wheel", REPO, "--no-deps", "--disable-pip-version-check", "-q", "-w", out],
           cwd=out))
    assert litter() == before, f"building the wheel wrote into the checkout: {sorted(litter() - before)}"
    (whl,) = out.glob("emdm-*.whl")
    return whl


@pytest.fixture(scope="module")
def venv(wheel, tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("venv")
    ok(run([sys.executable, "-m", "venv", root / "v"], cwd=root))
    ok(run([root / "v" / "bin" / "python", "-m", "pip", "install", "--disable-pip-version-check", "-q", wheel],
           cwd=root))
    return root / "v"


def test_wheel_holds_code_not_models(wheel):
    with zipfile.ZipFile(wheel) as z:
        names = z.namelist()
        meta = z.read(next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
        scripts = z.read(next(n for n in names if n.endswith(".dist-info/entry_points.txt"))).decode()
    assert "emdm/generation.py" in names and any(n.endswith("licenses/LICENSE") for n in names)
    assert not [n for n in names if n.endswith((".onnx", ".pt", ".f32", ".pyc")) or "/tests/" in n]
    assert wheel.stat().st_size < 1_000_000
    requires = [line.split(": ", 1)[1] for line in meta.splitlines() if line.startswith("Requires-Dist: ")]
    assert sorted(r.split(">")[0] for r in requires if "extra ==" not in r) == ["numpy", "onnxruntime", "tokenizers"]
    assert any(r.startswith("torch") and "extra == 'train'" in r for r in requires)
    for name in ("emdm-sample", "emdm-prepare", "emdm-train", "emdm-export", "emdm-eval"):
        assert f"{name} = emdm." in scripts


def test_console_script_help(venv, tmp_path):
    r = ok(run([venv / "bin" / "emdm-sample", "--help"], cwd=tmp_path))
    assert "--models-dir" in r.stdout and "EMDM_MODELS_DIR" in r.stdout


GENERATE = """
import importlib.util, json, sys
import emdm
m = emdm.generate("a person walks forward", seconds=2, seed=1, models_dir=sys.argv[1])
print(json.dumps({"file": emdm.__file__, "shape": list(m.joints.shape), "bvh": str(m.write_bvh("walk.bvh")),
                  "glb": str(m.write_glb("walk.glb")), "torch_loaded": "torch" in sys.modules,
                  "torch_installed": importlib.util.find_spec("torch") is not None}))
"""


def test_generate_outside_the_checkout(venv, tmp_path):
    r = ok(run([venv / "bin" / "python", "-c", GENERATE, MODELS], cwd=tmp_path))
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).is_relative_to(venv), out["file"]          # the installed copy, not the checkout's
    assert out["shape"] == [40, 22, 3] and not out["torch_loaded"] and not out["torch_installed"]
    assert (tmp_path / "walk.bvh").read_text().startswith("HIERARCHY")
    assert (tmp_path / "walk.glb").read_bytes()[:4] == b"glTF"


def test_prepare_needs_no_extra(venv, tmp_path):
    """Installed, its folders are the working folder's (data/dataset, data/raw), not inside the environment."""
    assert "--sources" in ok(run([venv / "bin" / "emdm-prepare", "--help"], cwd=tmp_path)).stdout
    code = "from emdm import paths; print(paths.DATASET_DIR, paths.DATA_DIR / 'raw', paths.RUNS_DIR, paths.shared_data_dir())"
    out = ok(run([venv / "bin" / "python", "-c", code], cwd=tmp_path)).stdout.split()
    assert out == ["data/dataset", "data/raw", "runs", "shared/data"], out


@pytest.mark.parametrize("command", ["emdm-train", "emdm-export", "emdm-eval"])
def test_pipeline_commands_name_the_extra(venv, tmp_path, command):
    r = run([venv / "bin" / command, "--help"], cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert f"{command} needs" in r.stderr and "pip install 'emdm[train]'" in r.stderr


def test_models_folder_from_the_environment(venv, tmp_path):
    cmd = [venv / "bin" / "emdm-sample", "--model", "emdm-t2m-web", "--text", "a person waves", "--frames", "20",
           "--variant", "int8", "--out", tmp_path / "w"]
    r = run(cmd, cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "no models folder" in r.stderr and "EMDM_MODELS_DIR" in r.stderr
    ok(run(cmd, cwd=tmp_path, env=clean_env(EMDM_MODELS_DIR=str(MODELS))))
    assert (tmp_path / "w.metres.bvh").is_file()


EDITOR = """
import sys
from emdm.model.open import open_model
from emdm.motion.edit import Editor
ed = Editor.open(open_model("emdm-t2m-web", models_dir=sys.argv[1], variant="int8"), steps=2)
print(list(ed.sample("a person waves", 20, seed=1).shape))
"""


def test_editor_encodes_prompts_from_the_models_folder_it_opened(venv, tmp_path):
    """Editor.open of a model from models_dir encodes its prompts with that folder's text encoder (no
    $EMDM_MODELS_DIR, no public/models beside the installed package)."""
    r = ok(run([venv / "bin" / "python", "-c", EDITOR, MODELS], cwd=tmp_path))
    assert r.stdout.strip().splitlines()[-1] == "[20, 263]"


def test_the_documented_loop_runs_as_written(venv, tmp_path):
    """docs/PYTHON.md's loop example, verbatim, from a folder whose models/ is the shipped folder (its settings once
    lacked the mean and std the model's speed cap needs, and the example raised)."""
    doc = (REPO / "docs" / "PYTHON.md").read_text()
    (block,) = [b.split("\n", 1)[1] for b in doc.split("```")[1::2] if b.startswith("python") and ".settings(" in b]
    (tmp_path / "models").symlink_to(MODELS)
    r = ok(run([venv / "bin" / "python", "-c", block + "\nprint(list(features.shape), settings.speed_cap > 0)"],
               cwd=tmp_path))
    assert r.stdout.strip().splitlines()[-1] == "[120, 263] True"
