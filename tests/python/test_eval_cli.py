"""The evaluation commands end to end on a tiny synthetic dataset: train both evaluators, evaluate the
real data and a (barely trained) generator checkpoint, time it, and regenerate the report."""

import json
import sys
from pathlib import Path

import pytest
import torch

sys.path.insert(0, str(Path(__file__).parent))
from model_synth_data import fake_text_encoder, write_synthetic_dataset  # noqa: E402

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    mp = pytest.MonkeyPatch()
    fake_text_encoder(mp)
    root = tmp_path_factory.mktemp("evalcli")
    ds = write_synthetic_dataset(root / "ds", n_clips=48, seed=1)
    ids = (ds / "train.txt").read_text().split()
    (ds / "test.txt").write_text("\n".join(ids[:36]) + "\n")
    mp.setenv("EMDM_EVAL_CACHE", str(root / "cache"))
    from emdm import train

    train.main(["--data", str(ds), "--out", str(root / "run"), "--preset", "tiny", "--steps", "2", "--batch", "8",
                "--d-width", "16", "--threads", "1", "--no-progress", "--supported-steps", "1,2"])
    yield root, ds
    mp.undo()


def test_commands_write_results_and_report(world):
    from emdm.eval import evaluate, evaluators, report

    root, ds = world
    small = ["--epochs", "2", "--hidden", "16", "--emb-dim", "16", "--batch-size", "8", "--dataset", str(ds)]
    assert evaluators._main(["matcher", "--out", str(root / "m.pt"), *small]) == 0
    assert evaluators._main(["classifier", "--out", str(root / "c.pt"), *small]) == 0
    res = root / "results"
    common = ["--dataset", str(ds), "--matcher", str(root / "m.pt"), "--classifier", str(root / "c.pt"),
              "--repeats", "2", "--plaus-n", "10"]
    evaluate.main(["text", "--source", "real", *common, "--out", str(res / "json" / "real.json")])
    evaluate.main(["text", "--ckpt", str(root / "run" / "ckpt.pt"), "--steps", "2", "--mm-texts", "3",
                   "--mm-repeats", "10", *common, "--out", str(res / "json" / "emdm.json")])
    evaluate.main(["action", "--source", "real", *common, "--out", str(res / "json" / "areal.json")])
    evaluate.main(["timing", "--model", f"{root / 'run' / 'ckpt.pt'}=1,2", "--runs", "1", "--frames", "40",
                   "--out", str(res / "json" / "timing.json")])
    emdm = json.loads((res / "json" / "emdm.json").read_text())
    assert emdm["info"]["variant"] == "emdm" and emdm["info"]["steps"] == 2 and emdm["info"]["train_steps"] == 2
    assert len(emdm["metrics"]["fid"]) == 2 and len(emdm["plausibility"]["skate_cm_s"]) == 10
    assert emdm["n"] == 36 and emdm["dataset"]["ids"]["test"] == 36
    assert report.main(["--results", str(res), "--out", str(root / "RESULTS.md")]) == 0
    md = (root / "RESULTS.md").read_text()
    assert "| EMDM (2 steps) | 2 | 36 | 2 |" in md
    assert "| python-cpu |" in md and "Tab. D3: naive DDGAN" in md


@pytest.fixture(scope="module")
def judges(world):
    """The tiny matcher and classifier (m.pt, c.pt) the tests below judge with."""
    from emdm.eval import evaluators

    root, ds = world
    small = ["--epochs", "2", "--hidden", "16", "--emb-dim", "16", "--batch-size", "8", "--dataset", str(ds)]
    for kind, f in (("matcher", "m.pt"), ("classifier", "c.pt")):
        if not (root / f).exists():
            assert evaluators._main([kind, "--out", str(root / f), *small]) == 0
    return world


def test_a_trial_run_does_not_replace_a_larger_committed_result(judges, monkeypatch, tmp_path, capsys):
    """A run on fewer clips or repeats, or of a model trained fewer steps, than the result already at the default
    path stops with one line (the committed row stays); --out-dir writes beside it, --replace replaces it."""
    from emdm.eval import evaluate

    root, ds = judges
    monkeypatch.setattr(evaluate, "RESULTS_DIR", tmp_path)
    committed = tmp_path / "json" / "text-real.json"
    committed.parent.mkdir()
    committed.write_text(json.dumps({"name": "Real motion", "n": 892, "repeats": 20, "info": {"variant": "real"}}))
    common = ["--dataset", str(ds), "--matcher", str(root / "m.pt"), "--repeats", "1", "--plaus-n", "4"]
    assert evaluate.main(["text", "--source", "real", *common]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "text-real.json holds a larger measurement (892 clips (this run 36); 20 repeats" in err
    assert "--out-dir DIR (suite: --results DIR), or pass --replace" in err
    assert json.loads(committed.read_text())["n"] == 892
    assert evaluate.main(["text", "--source", "real", *common, "--out-dir", str(tmp_path / "trial")]) == 0
    assert json.loads((tmp_path / "trial" / "text-real.json").read_text())["n"] == 36
    assert json.loads(committed.read_text())["n"] == 892
    # a model trained longer: the tiny checkpoint (2 steps) does not replace it
    longer = {"n": 36, "repeats": 1, "info": {"train_steps": 3685}}
    (tmp_path / "json" / "text-emdm-2.json").write_text(json.dumps(longer))
    assert evaluate.main(["text", "--ckpt", str(root / "run" / "ckpt.pt"), "--steps", "2", *common]) == 2
    assert "a model trained 3685 steps (this one 2)" in capsys.readouterr().err
    assert evaluate.main(["text", "--source", "real", *common, "--replace"]) == 0
    assert json.loads(committed.read_text())["n"] == 36


def test_too_few_clips_and_another_dataset_build_are_one_line(judges, tmp_path, capsys):
    from emdm.eval import evaluate

    root, ds = judges
    assert evaluate.main(["text", "--source", "real", "--dataset", str(ds), "--max-items", "16",
                          "--out", str(tmp_path / "r.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "test.txt: 16 clips (--max-items 16); R-precision needs at least 32" in err
    # a classifier trained on another build of the dataset (its vocabulary differs): named, with how to retrain it
    c = torch.load(root / "c.pt", weights_only=False)
    c["meta"]["labels"] = list(reversed(c["meta"]["labels"]))
    torch.save(c, tmp_path / "other.pt")
    assert evaluate.main(["action", "--source", "real", "--dataset", str(ds), "--classifier",
                          str(tmp_path / "other.pt"), "--repeats", "1", "--out", str(tmp_path / "a.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "other.pt: the action classifier (retrain it: python -m emdm.eval.evaluators" in err
    assert "orders them otherwise: it was trained on another dataset build" in err
    assert not (tmp_path / "a.json").exists() and not (tmp_path / "r.json").exists()


def test_action_model_rejected_for_text(world):
    from emdm.eval import evaluate

    root, ds = world
    with pytest.raises(SystemExit, match="is a text model, not action"):
        evaluate.main(["action", "--ckpt", str(root / "run" / "ckpt.pt"), "--dataset", str(ds), "--repeats", "1",
                       "--classifier", str(root / "c.pt")])


@pytest.fixture(scope="module")
def exported(world):
    from emdm import export

    root, _ = world
    models = root / "models"
    export.main(["--ckpt", str(root / "run" / "ckpt.pt"), "--name", "tiny-t2m", "--out", str(models), "--variants", ""])
    return models


def test_shipped_onnx_source_generates_what_the_checkpoint_does(world, exported):
    """--model (the exported ONNX step through onnxruntime, as shipped) and --ckpt (PyTorch) make
    the same motions for the same conditions and seed."""
    import numpy as np

    from emdm.eval.protocol import Conditions
    from emdm.eval.sources import ModelSource

    root, ds = world
    models = exported
    onnx_src = ModelSource(model="tiny-t2m", models_dir=models, steps=2)
    pt_src = ModelSource(ckpt=root / "run" / "ckpt.pt", steps=2)
    assert onnx_src.info["variant"] == pt_src.info["variant"] == "emdm"
    assert onnx_src.info["train_steps"] == pt_src.info["train_steps"] == 2
    rng = np.random.default_rng(0)
    emb = rng.normal(size=(5, pt_src.cond_spec["dim"])).astype(np.float32)
    cond = Conditions(lengths=np.array([40, 52, 47, 60, 41]), text_emb=emb)
    a, b = onnx_src.generate(cond, 3), pt_src.generate(cond, 3)
    assert [m.shape for m in a] == [(n, 263) for n in cond.lengths]
    for x, y in zip(a, b):
        np.testing.assert_allclose(x, y, atol=2e-3 * float(np.abs(y).max()))
    with pytest.raises(ValueError, match="has no variant 'int8'"):
        ModelSource(model="tiny-t2m", models_dir=models, onnx_variant="int8")


def test_max_items_is_a_seeded_random_subset_of_raw_features(world):
    import numpy as np

    from emdm.eval import data as evdata

    _, ds = world
    full = evdata.load_split(ds, "test")
    sub = evdata.load_split(ds, "test", max_items=10)
    assert len(sub) == 10 and sub.names == evdata.load_split(ds, "test", max_items=10).names
    assert sub.names != full.names[:10]
    i = full.names.index(sub.names[3])
    np.testing.assert_allclose(sub.motions[3], full.motions[i])
    # raw = the file on disk (the reader's normalisation is undone)
    on_disk = np.load(ds / "new_joint_vecs" / f"{sub.names[3]}.npy")
    np.testing.assert_allclose(sub.motions[3], on_disk[: len(sub.motions[3])], atol=1e-4)


def test_browser_benchmark_json_becomes_timing_rows(world, exported, tmp_path):
    from emdm.eval import evaluate, report

    bench = {"frames": 196, "reps": 3, "rows": [
        {"env": "chromium", "model": "tiny-t2m", "threads": 1, "guidance": 2.5,
         "results": [{"steps": 1, "modelCalls": 1, "msPerStep": 50.0, "msPerMotion": 60.0},
                     {"steps": 2, "modelCalls": 2, "msPerStep": 50.0, "msPerMotion": 110.0}]},
        {"env": "node", "model": "tiny-t2m", "threads": 2, "guidance": 2.5,
         "results": [{"steps": 2, "modelCalls": 2, "msPerStep": 40.0, "msPerMotion": 90.0}]}]}
    (tmp_path / "bench.json").write_text(json.dumps(bench))
    evaluate.main(["import-bench", str(tmp_path / "bench.json"), "--models-dir", str(exported),
                   "--out-dir", str(tmp_path / "json")])
    rows = report.timing_rows(report.load_results(tmp_path / "json"))
    chromium = sorted((r["steps"], r["ms_per_frame"]) for r in rows if r["runtime"] == "browser-wasm")
    assert chromium == [(1, 60.0 / 196), (2, 110.0 / 196)]
    assert {r["variant"] for r in rows} == {"emdm"} and {r["runtime"] for r in rows} == {"browser-wasm", "node-wasm"}
    bench["rows"][0]["model"] = "nope"
    (tmp_path / "bench.json").write_text(json.dumps(bench))
    with pytest.raises(SystemExit, match=r"rows\[0\].model 'nope' is not in the manifest"):
        evaluate.main(["import-bench", str(tmp_path / "bench.json"), "--models-dir", str(exported)])


def test_suite_plans_every_row_of_the_comparisons(monkeypatch):
    from emdm.eval import suite

    cmds = []
    monkeypatch.setattr(suite.evaluate, "main", lambda argv: cmds.append(argv))
    monkeypatch.setattr(suite.report, "main", lambda argv=None: 0)
    suite.main(["--text", "t.pt", "--action", "emdm-a2m-web", "--diffusion", "d.pt", "--naive", "n.pt",
                "--repeats", "2", "--timing-runs", "1"])
    rows = [(c[0], c[2] if c[1] in ("--ckpt", "--model", "--source") else None,
             c[c.index("--steps") + 1] if "--steps" in c else None) for c in cmds if c[0] != "timing"]
    assert ("text", "real", None) in rows and ("action", "real", None) in rows
    assert {("text", "d.pt", s) for s in ("10", "50", "100")} <= set(rows)
    assert ("text", "t.pt", "10") in rows and ("text", "n.pt", "10") in rows and ("action", "emdm-a2m-web", "10") in rows
    timing = next(c for c in cmds if c[0] == "timing")
    assert "t.pt=1,2,4,5,8,10" in timing and "d.pt=10,50,100" in timing


def test_suite_results_elsewhere_and_its_refusals(monkeypatch, tmp_path, capsys):
    """--results DIR: every evaluation writes to DIR/json and the report to DIR/RESULTS.md (a trial run leaves the
    committed results alone); --replace is passed on; a --results that is a file is one line, before anything runs."""
    from emdm.eval import suite

    cmds, reports = [], []
    monkeypatch.setattr(suite.evaluate, "main", lambda argv: cmds.append(argv))
    monkeypatch.setattr(suite.report, "main", lambda argv=None: reports.append(argv))
    assert suite.main(["--text", "t.pt", "--action", "a.pt", "--repeats", "1", "--timing-runs", "1",
                       "--results", str(tmp_path / "trial"), "--replace"]) == 0
    assert all(c[c.index("--out-dir") + 1] == str(tmp_path / "trial" / "json") for c in cmds)
    assert all("--replace" in c for c in cmds if c[0] != "timing")
    assert reports == [["--results", str(tmp_path / "trial"), "--out", str(tmp_path / "trial" / "RESULTS.md")]]
    (tmp_path / "afile").write_text("x")
    cmds.clear()
    assert suite.main(["--text", "t.pt", "--results", str(tmp_path / "afile")]) == 2
    err = capsys.readouterr().err
    assert cmds == [] and err.startswith("error: --results") and "is a file" in err


def test_page_benchmark_json_with_a_diffusion_model_becomes_ddim_rows(world, exported, tmp_path):
    """The demo page's EMDM-vs-DDIM benchmark (tests/e2e/page-bench.spec.ts, EMDM_BENCH_JSON): rows of a
    diffusion-objective model are DDIM rows of the 'diffusion' variant; its source and load are kept."""
    import shutil

    from emdm import manifest as mf
    from emdm.eval import evaluate, report

    models = tmp_path / "models"
    shutil.copytree(exported, models)
    man = mf.load(models)
    man["models"]["tiny-ddim"] = {**man["models"]["tiny-t2m"], "objective": "diffusion"}
    (models / mf.MANIFEST_NAME).write_text(json.dumps(man))
    bench = {"frames": 196, "reps": 3, "source": "tests/e2e/page-bench.spec.ts (window.emdm.generate)",
             "loadAverage": [1.25, 1.5], "rows": [
                 {"env": "chromium (demo page)", "model": "tiny-t2m", "threads": 2, "guidance": 2.5, "sampler": "ddgan",
                  "results": [{"steps": 10, "modelCalls": 10, "msPerStep": 9.0, "msPerMotion": 98.0}]},
                 {"env": "chromium (demo page)", "model": "tiny-ddim", "threads": 2, "guidance": 2.5, "sampler": "ddim",
                  "results": [{"steps": 50, "modelCalls": 50, "msPerStep": 9.0, "msPerMotion": 490.0}]}]}
    (tmp_path / "bench.json").write_text(json.dumps(bench))
    out = evaluate.import_bench(evaluate.build_parser().parse_args(
        ["import-bench", str(tmp_path / "bench.json"), "--models-dir", str(models), "--out-dir", str(tmp_path / "json")]))
    doc = json.loads(out.read_text())
    assert doc["runtime"] == "browser-wasm" and doc["load_avg_1min"] == [1.25, 1.5]
    assert "page-bench.spec.ts" in doc["note"]
    rows = report.timing_rows(report.load_results(tmp_path / "json"))
    assert sorted((r["variant"], r["sampler"], r["steps"]) for r in rows) == [("diffusion", "DDIM", 50), ("emdm", "DDGAN", 10)]
    table, ratios = report.timing_table(report.load_results(tmp_path / "json"))
    assert any("diffusion + DDIM at 50 steps takes 5.0× the time per frame of EMDM at 10 steps" in r for r in ratios)
