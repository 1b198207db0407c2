"""RESULTS.md is generated from result JSONs only: the numbers in its tables are those of the files,
missing comparisons are listed, plots are written, and a bad file is named."""

import json

import numpy as np
import pytest

from emdm.eval import report as R


def _write(d, name, obj):
    (d / "json").mkdir(parents=True, exist_ok=True)
    (d / "json" / name).write_text(json.dumps(obj))


def _text(name, variant, steps, fid, kind="model"):
    return {"schema": 1, "task": "text", "name": name, "kind": kind,
            "info": {"variant": variant, "steps": steps, "train_steps": 1234},
            "dataset": {"name": "ours", "split": "test", "description": "3 sources"}, "n": 96, "repeats": 3,
            "hardware": "2-core CPU", "evaluator": {"summary": "matcher 30 epochs"},
            "metrics": {"top1": [0.5, 0.52, 0.54], "top2": [0.6] * 3, "top3": [0.7] * 3, "fid": fid,
                        "mm_dist": [0.8] * 3, "diversity": [1.1] * 3,
                        **({} if kind == "real" else {"multimodality": [0.3] * 3})},
            "plausibility": {"penetration_mm": [1.0, 3.0], "floating_mm": [10.0, 20.0], "skate_cm_s": [5.0, 7.0],
                             "skate_ratio": [0.1, 0.2], "phys_err_mm": [12.0, 24.0]}}


def test_report_tables_carry_the_numbers_of_the_json_files(tmp_path):
    _write(tmp_path, "real.json", _text("Real motion", "real", None, [0.01, 0.02, 0.03], kind="real"))
    _write(tmp_path, "emdm10.json", _text("EMDM", "emdm", 10, [0.4, 0.5, 0.6]))
    _write(tmp_path, "ddim10.json", _text("DDIM", "diffusion", 10, [0.9, 1.0, 1.1]))
    _write(tmp_path, "time.json", {"schema": 1, "task": "timing", "runtime": "python-cpu", "hardware": "cpu",
                                  "rows": [{"variant": "emdm", "steps": 10, "frames": 196, "ms_per_motion": [392.0]},
                                           {"variant": "diffusion", "steps": 100, "frames": 196,
                                            "ms_per_motion": [3920.0, 3920.0]}]})
    out = tmp_path / "RESULTS.md"
    assert R.main(["--results", str(tmp_path), "--out", str(out)]) == 0
    md = out.read_text()
    m, h = np.mean([0.4, 0.5, 0.6]), 1.96 * np.std([0.4, 0.5, 0.6]) / np.sqrt(3)
    assert f"{m:.3f} ±{h:.3f}" in md                     # EMDM's FID with its interval
    assert "0.520 ±" in md                                # R-precision top-1 mean
    assert "10.0×" in md and "2.000" in md                # DDIM-100 / EMDM-10 per frame; 392/196 ms
    assert "text, EMDM, 96 clips × 3 repeat(s): R-precision top-1 0.520 (real 0.520), FID 0.500 (real 0.020)" in md
    assert "Tab. D3: naive DDGAN" in md                   # not measured → listed
    assert "Tab. D2: diffusion + DDIM at 10 steps" not in md.split("## Not measured yet")[1]
    assert "timing: Diffusion (same transformer) + DDIM on python-cuda" in md
    assert (tmp_path / "fid_vs_steps.png").stat().st_size > 1000
    assert (tmp_path / "time_vs_steps.png").stat().st_size > 1000
    # real row has no multimodality: shown as a dash, not a number
    real_line = next(line for line in md.splitlines() if line.startswith("| Real motion | – "))
    assert real_line.split("|")[11].strip() == "–"            # MModality (after the Clips column)


def test_no_results_yet_lists_everything_as_missing(tmp_path):
    (tmp_path / "json").mkdir()
    out = tmp_path / "RESULTS.md"
    R.main(["--results", str(tmp_path), "--out", str(out)])
    md = out.read_text()
    assert "_no text-to-motion results yet_" in md
    assert md.count("\n- ") >= len(R.EXPECTED) + len(R.EXPECTED_TIMING)


def test_bad_json_is_named(tmp_path):
    (tmp_path / "json").mkdir()
    (tmp_path / "json" / "broken.json").write_text('{"schema": 1,\n "task": }')
    with pytest.raises(R.ReportError, match=r"broken.json:2: not valid JSON"):
        R.load_results(tmp_path / "json")
    (tmp_path / "json" / "broken.json").write_text('{"schema": 1, "task": "text", "name": "x"}')
    with pytest.raises(R.ReportError, match="broken.json: missing field 'kind'"):
        R.load_results(tmp_path / "json")


def test_setup_line_states_the_clips_of_each_row_and_models_json_is_left_out(tmp_path):
    _write(tmp_path, "real.json", _text("Real motion", "real", None, [0.01] * 3, kind="real"))
    _write(tmp_path, "real-subset.json", {**_text("Real motion", "real", None, [0.1] * 3, kind="real"), "n": 32})
    _write(tmp_path, "emdm10.json", {**_text("EMDM", "emdm", 10, [0.4] * 3), "n": 32})
    _write(tmp_path, "models-bones.json", {"schema": 1, "task": "models-bones", "rows": []})   # MODELS.md's input
    out = tmp_path / "RESULTS.md"
    assert R.main(["--results", str(tmp_path), "--out", str(out)]) == 0
    setup = out.read_text().split("## Setup")[1].split("\n\n")[1]
    assert "clips evaluated (≥ 40 frames): 96 (Real motion); 32 (Real motion, EMDM)" in setup
