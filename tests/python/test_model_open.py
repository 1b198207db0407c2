"""emdm.model.open, the one opener of models for sampling (emdm.sample, emdm.export, the evaluation), and how the
four CLIs answer a model or --out they cannot use: one line naming the file and what is wrong, exit status 2,
nothing written, no traceback."""

import json
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

sys.path.insert(0, str(Path(__file__).parent))
from model_synth_data import write_synthetic_dataset  # noqa: E402

from emdm import manifest as mf  # noqa: E402
from emdm import paths  # noqa: E402

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A tiny action model: its checkpoint, its export (models/), and broken copies of both."""
    from emdm import export, train

    root = tmp_path_factory.mktemp("open")
    ds = write_synthetic_dataset(root / "ds", n_clips=12)
    train.main(["--data", str(ds), "--task", "action", "--out", str(root / "run"), "--steps", "2", "--preset", "tiny",
                "--d-width", "16", "--batch", "4", "--threads", "1", "--no-progress", "--supported-steps", "1,2"])
    assert export.main(["--ckpt", str(root / "run" / "ckpt.pt"), "--name", "m", "--out", str(root / "models"),
                        "--variants", ""]) == 0
    bad = root / "bad"
    bad.mkdir()
    (bad / "corrupt.pt").write_bytes(b"garbage, not a torch file")
    (bad / "blocker").write_text("a file where a folder should be")
    for name in ("corrupt_onnx", "missing", "sha"):
        shutil.copytree(root / "models", bad / name)
    (bad / "corrupt_onnx" / "m.onnx").write_bytes(b"not an onnx file")
    mf.save(mf.load(bad / "corrupt_onnx"), bad / "corrupt_onnx")          # listed with its (corrupt) sha256
    (bad / "missing" / "m.onnx").unlink()
    man = json.loads((bad / "sha" / mf.MANIFEST_NAME).read_text())
    man["files"]["m.onnx"]["sha256"] = "0" * 64
    (bad / "sha" / mf.MANIFEST_NAME).write_text(json.dumps(man))
    prompts = {a: {"plain": f"a person does {a}", "paraphrases": [f"{a} one", f"{a} two", f"{a} three"]}
               for a in ("walk", "wave", "turn")}
    (root / "prompts.json").write_text(json.dumps({"actions": prompts}))
    return root


# ----------------------------------------------------------------------------- the CLIs' answers

# case: (model arguments, what the one line must say); "unwritable_out" uses the good model
CASES = {
    "corrupt_ckpt": (lambda r: ["--ckpt", str(r / "bad" / "corrupt.pt")],
                     r"corrupt\.pt: cannot read as a checkpoint .*corrupt or not a torch file"),
    "corrupt_onnx": (lambda r: ["--model", "m", "--models-dir", str(r / "bad" / "corrupt_onnx")],
                     r"corrupt_onnx/m\.onnx: cannot load as an ONNX model"),
    "unknown_model": (lambda r: ["--model", "nope", "--models-dir", str(r / "models")],
                      r"models/manifest\.json: no model 'nope'"),
    "ckpt_typo": (lambda r: ["--model", str(r / "run" / "ckpt.ptt"), "--models-dir", str(r / "models")],
                  r"run/ckpt\.ptt: no such checkpoint file .*; did you mean .*run/ckpt\.pt\?$"),
    "missing_file": (lambda r: ["--model", "m", "--models-dir", str(r / "bad" / "missing")],
                     r"missing/m\.onnx: missing \(model 'm' names it as its ONNX step file"),
    "sha_mismatch": (lambda r: ["--model", "m", "--models-dir", str(r / "bad" / "sha")],
                     r"sha/m\.onnx: sha256 differs from .*sha/manifest\.json"),
    "unwritable_out": (lambda r: ["--model", "m", "--models-dir", str(r / "models")],
                       r"--out.*blocker is a file, not a folder"),
}


def _argv(cli: str, root: Path, src: list[str], out: Path) -> list[str]:
    ds, none = str(root / "ds"), str(root / "no-classifier.pt")
    if cli == "sample":
        return [*src, "--action", "walk", "--frames", "12", "--steps", "2", "--out", str(out)]
    if cli == "export":
        return [*src, "--name", "m2", "--variants", "", "--out", str(out)]
    if cli == "evaluate":
        return ["action", *src, "--steps", "2", "--dataset", ds, "--classifier", none, "--repeats", "1",
                "--plaus-n", "2", "--out", str(out) + ".json"]
    return [*src, "--steps", "1", "--seeds", "1", "--dataset", ds, "--classifier", none,
            "--prompts", str(root / "prompts.json"), "--out", str(out) + ".json"]


def _main(cli: str):
    if cli == "sample":
        from emdm.sample import main
    elif cli == "export":
        from emdm.export import main
    elif cli == "evaluate":
        from emdm.eval.evaluate import main
    else:
        from emdm.eval.coverage import main
    return main


PARAMS = [(cli, case) for case in CASES for cli in ("sample", "export", "evaluate", "coverage")
          if cli != "export" or case in ("corrupt_ckpt", "unwritable_out")]     # export reads a checkpoint only


@pytest.mark.parametrize("cli, case", PARAMS, ids=[f"{c}-{k}" for c, k in PARAMS])
def test_cli_answers_a_bad_model_or_out_with_one_line(world, tmp_path, capsys, cli, case):
    src_of, expected = CASES[case]
    src = src_of(world)
    if cli == "export" and case == "unwritable_out":
        src = ["--ckpt", str(world / "run" / "ckpt.pt")]
    out = world / "bad" / "blocker" / "sub" / "x" if case == "unwritable_out" else tmp_path / "o" / "x"
    rc = _main(cli)(_argv(cli, world, src, out))
    cap = capsys.readouterr()
    lines = cap.err.strip().splitlines()
    assert rc == 2 and "Traceback" not in cap.err, (rc, cap.err[-2000:])
    assert len(lines) == 1 and lines[0].startswith("error: ") and re.search(expected, lines[0]), lines
    assert not (tmp_path / "o").exists(), "something was written"


# ----------------------------------------------------------------------------- the opener itself

def test_checkpoint_and_shipped_model_open_to_the_same_network(world):
    from emdm.model.open import open_model

    ck = open_model(world / "run" / "ckpt.pt")
    sh = open_model("m", models_dir=world / "models")
    assert (ck.kind, sh.kind, sh.variant) == ("checkpoint", "shipped", "fp32")
    for m in (ck, sh):
        assert (m.task, m.objective, m.z_dim, m.max_frames, m.supported_steps) == ("action", "ddgan", 64, 196, [1, 2])
        assert m.condition["labels"] == ["walk", "wave", "turn"]
        assert m.info["train_steps"] == 2 and m.flags["geo_weight"] == ck.checkpoint_meta["args"]["geo_weight"]
    assert ck.info["runtime"] == "pytorch" and sh.info["runtime"] == "onnxruntime" and sh.info["onnx"] == "m.onnx"
    assert ck.meta["guidance"] == 2.5 and ck.meta["defaultSteps"] == 10 and "supportedSteps" not in ck.meta
    np.testing.assert_allclose(sh.mean, ck.mean, rtol=1e-6)
    np.testing.assert_allclose(sh.std, ck.std, rtol=1e-6)
    rng = np.random.default_rng(0)
    args = (rng.standard_normal((2, 17, 263), dtype=np.float32), rng.standard_normal((2, 64), dtype=np.float32),
            np.eye(3, dtype=np.float32)[:2], np.array([0.3, 0.9], np.float32), np.ones((2, 17), np.float32))
    np.testing.assert_allclose(sh.step(*args), ck.step(*args), atol=1e-4)


def test_sample_cli_is_the_loop_over_the_opened_model_bit_for_bit(world, tmp_path):
    """emdm.sample's output is sample_features over open_model's step, de-normalised by its mean/std, exactly."""
    from emdm.model.open import open_model
    from emdm.sample import main
    from emdm.sampler import SamplingSettings, sample_features

    for src, opened in ((["--model", "m", "--models-dir", str(world / "models")], open_model("m", models_dir=world / "models")),
                        (["--ckpt", str(world / "run" / "ckpt.pt")], open_model(world / "run" / "ckpt.pt"))):
        out = tmp_path / "s"
        assert main([*src, "--action", "turn", "--frames", "20", "--steps", "2", "--seed", "4", "--num", "2",
                     "--out", str(out), "--no-bvh"]) == 0
        settings = SamplingSettings(steps=2, guidance=2.5, z_dim=opened.z_dim)
        x = sample_features(opened.step, np.eye(3, dtype=np.float32)[2], 20, settings, seed=4, num=2)
        np.testing.assert_array_equal(np.load(out.with_suffix(".features.npy")), x * opened.std + opened.mean)


def test_shipped_model_refusals_name_the_file(world, tmp_path):
    import onnx
    from onnx import TensorProto, helper

    from emdm.model.open import ModelError, open_model

    models = tmp_path / "models"
    shutil.copytree(world / "models", models)
    with pytest.raises(ModelError, match=r"^--variant: model 'm' has no variant 'int8'; use one of fp32$"):
        open_model("m", models_dir=models, variant="int8")
    with pytest.raises(ModelError, match=r"--device cuda needs a checkpoint"):
        open_model("m", models_dir=models, device="cuda")
    with pytest.raises(ModelError, match=r"--variant 'int8' needs a shipped model"):
        open_model(world / "run" / "ckpt.pt", variant="int8")
    with pytest.raises(ModelError, match=r": has no manifest\.json \(models folder from models_dir / --models-dir\)"):
        open_model("m", models_dir=tmp_path)
    # a file the manifest does not list is not used (as the page: no unverified file)
    man = json.loads((models / mf.MANIFEST_NAME).read_text())
    listed = man["files"].pop("m.meanstd.f32")
    (models / mf.MANIFEST_NAME).write_text(json.dumps(man))
    with pytest.raises(ModelError, match=r"m\.meanstd\.f32: model 'm' names it as its meanStd, but .* does not list it"):
        open_model("m", models_dir=models)
    man["files"]["m.meanstd.f32"] = listed
    # a truncated mean/std file, listed with its new size and sha256
    (models / "m.meanstd.f32").write_bytes(np.zeros(10, "<f4").tobytes())
    mf.save(mf.load(models), models)
    with pytest.raises(ModelError, match=r"m\.meanstd\.f32: expected 526 float32 values .*got 10"):
        open_model("m", models_dir=models)
    shutil.copy(world / "models" / "m.meanstd.f32", models / "m.meanstd.f32")
    # a valid ONNX file that is not a step model
    graph = helper.make_graph([helper.make_node("Identity", ["ids"], ["out"])], "g",
                              [helper.make_tensor_value_info("ids", TensorProto.INT64, [1])],
                              [helper.make_tensor_value_info("out", TensorProto.INT64, [1])])
    onnx.save(helper.make_model(graph, opset_imports=[helper.make_opsetid("", 18)]), str(models / "m.onnx"))
    mf.save(mf.load(models), models)
    with pytest.raises(ModelError, match=r"m\.onnx: not an EMDM step model \(inputs \['ids'\]"):
        open_model("m", models_dir=models)


def test_checkpoint_refusals_name_the_file(world, tmp_path):
    from emdm.model.open import ModelError, open_model

    with pytest.raises(ModelError, match=r"nope\.pt: checkpoint not found"):
        open_model(tmp_path / "nope.pt")
    from emdm.checkpoints import atomic_save

    st = torch.load(world / "run" / "ckpt.pt", weights_only=True)
    st["G_ema"].pop(sorted(st["G_ema"])[-1])                                   # a tensor short
    atomic_save(st, tmp_path / "short.pt")              # with its checksum: a file written so, not a corrupt one
    with pytest.raises(ModelError, match=r"short\.pt: 'G_ema' does not fit this model"):
        open_model(tmp_path / "short.pt")
    del st["meta"]["generator"]
    atomic_save(st, tmp_path / "nogen.pt")
    with pytest.raises(ModelError, match=r"nogen\.pt: not an emdm.train checkpoint \(meta lacks the generator"):
        open_model(tmp_path / "nogen.pt")


def test_a_reference_that_reads_as_a_path_is_refused_as_one(world, tmp_path, monkeypatch):
    """A text reference with a separator, a suffix or naming an existing path is a checkpoint's: an existing .pt
    file opens as one, anything else is refused naming it (not looked up as a manifest name); plain names are."""
    from emdm.model.open import ModelError, open_model

    models, run = world / "models", world / "run"
    ckpt = re.escape(str(run / "ckpt.pt"))
    refused = {str(run / "ckpt.ptt"): r"no such checkpoint file \(a checkpoint is an existing \.pt file: "
                                      rf"emdm\.train's ckpt\.pt or a --weights-out file\); did you mean {ckpt}\?$",
               str(tmp_path / "none" / "x.pt"): r"no such checkpoint file \(.*\)$",
               str(run): rf"is a folder, not a checkpoint file; did you mean {ckpt}\?$",
               str(world / "prompts.json"): r"not a \.pt file \(a checkpoint is emdm\.train's ckpt\.pt or a "
                                            r"--weights-out file\)$",
               str(run / "log.csv"): r"not a \.pt file"}
    for ref, says in refused.items():
        for device in ("cpu", "cuda"):
            with pytest.raises(ModelError, match=rf"^{re.escape(ref)}: {says}"):
                open_model(ref, models_dir=models, device=device)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelError, match=r"^ckpt\.ptt: no such checkpoint file .*, nor a model of .*manifest\.json "
                                         r"\(have: m\)$"):
        open_model("ckpt.ptt", models_dir=models)
    with pytest.raises(ModelError, match=r"manifest\.json: no model 'nope' \(have: m\)$"):
        open_model("nope", models_dir=models)
    (tmp_path / "m").mkdir()                       # a folder named as a shipped model does not hide it
    assert open_model("m", models_dir=models).kind == "shipped"
    shutil.copy(run / "ckpt.pt", tmp_path / "c.pt")
    for ref in (str(run / "ckpt.pt"), "c.pt"):
        assert open_model(ref, models_dir=models).kind == "checkpoint"


def test_only_the_opener_opens_models():
    """sample, export and the evaluation open models through emdm.model.open only: none of them builds an
    onnxruntime session, unpickles a file, reads a mean/std file or builds a Generator itself."""
    emdm = paths.REPO_ROOT / "scripts" / "emdm"
    files = [emdm / "sample.py", emdm / "export.py", *sorted((emdm / "eval").glob("*.py"))]
    opening = re.compile(r"InferenceSession|torch\.load\(|np\.fromfile\(|(?<![.\w])Generator\(|load_file\(")
    found = [f"{f.relative_to(paths.REPO_ROOT)}:{i}: {line.strip()}" for f in files
             for i, line in enumerate(f.read_text().splitlines(), 1) if opening.search(line)]
    assert not found, found
