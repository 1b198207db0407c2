"""docs/MODELS.md's generated tables are what `python -m emdm.eval.models_report` makes of the committed inputs."""

import json

import pytest

from emdm import manifest as mf
from emdm import paths
from emdm.eval import models_report as mr


def test_models_md_tables_are_current():
    man = mf.load(paths.MODELS_DIR)
    bones = mr.load_bones()
    assert not mr.stale_rows(bones, man), "run `python -m emdm.eval.models_report measure` (models changed)"
    text = mr.MODELS_MD.read_text()
    assert mr.render(text, mr.blocks(man, bones)) == text, \
        "docs/MODELS.md differs from its inputs: run `python -m emdm.eval.models_report` and commit it"


def test_a_changed_input_changes_the_document():
    man = json.loads((paths.MODELS_DIR / mf.MANIFEST_NAME).read_text())
    bones = mr.load_bones()
    text = mr.MODELS_MD.read_text()
    bones["rows"][0]["worst"] += 0.01
    man["models"]["emdm-t2m-web"]["training"]["losses"]["bone"] *= 2
    out = mr.render(text, mr.blocks(man, bones))
    assert out != text and out.count("<!-- /models_report:") == text.count("<!-- /models_report:")


def test_stale_bones_and_missing_markers_are_reported():
    man = mf.load(paths.MODELS_DIR)
    bones = mr.load_bones()
    bones["rows"][1]["sha256"] = "0" * 64
    del bones["rows"][2]
    stale = mr.stale_rows(bones, man)
    assert len(stale) == 2 and "another file" in " ".join(stale) and "not measured" in " ".join(stale)
    with pytest.raises(mr.ModelsReportError, match="no marker for block"):
        mr.render("# no markers\n", mr.blocks(man, mr.load_bones()))
