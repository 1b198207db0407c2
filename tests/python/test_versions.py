"""One release version: package.json, pyproject.toml, emdm.__version__ and the models manifest agree; every shipped
model says its terms of use (license, card) and the card it points at exists; re-exporting keeps them."""

import json
import re
import tomllib

import emdm
from emdm import manifest as mf
from emdm import paths

ROOT = paths.REPO_ROOT


def test_one_version():
    npm = json.loads((ROOT / "package.json").read_text())["version"]
    py = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    man = json.loads((ROOT / "public" / "models" / "manifest.json").read_text()).get("version")
    assert re.fullmatch(r"\d+\.\d+\.\d+", npm)
    assert {"package.json": npm, "pyproject.toml": py, "emdm.__version__": emdm.__version__, "manifest": man} == \
        dict.fromkeys(("package.json", "pyproject.toml", "emdm.__version__", "manifest"), npm)
    assert f"## {npm} " in (ROOT / "CHANGELOG.md").read_text()


def test_models_state_their_terms():
    models = mf.load(paths.MODELS_DIR)["models"]
    cards = (ROOT / "docs" / "MODELS.md").read_text()
    assert models
    for name, entry in models.items():
        assert entry.get("license") == "CC-BY-NC-4.0", name          # trained on CC BY-NC 4.0 data (Bandai Namco)
        doc, _, anchor = entry["card"].partition("#")
        assert doc == "docs/MODELS.md" and anchor == "model-card" and "\n## Model card\n" in cards
        assert f"`{name}`" in cards.split("\n## Model card\n")[1].split("\n## ")[0], f"{name}: no card entry"


def test_re_export_keeps_the_terms(tmp_path):
    mf.save(mf.empty_manifest(), tmp_path)
    terms = {"license": "CC-BY-NC-4.0", "card": "docs/MODELS.md#model-card"}
    mf.update_entry("models", "m", {"task": "action", "files": [], **terms}, tmp_path)
    mf.update_entry("models", "m", {"task": "text", "files": []}, tmp_path)          # what emdm.export writes
    assert mf.load(tmp_path)["models"]["m"] == {"task": "text", "files": [], **terms}
