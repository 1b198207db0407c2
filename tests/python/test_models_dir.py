"""The models folder (emdm.paths.models_dir): an argument, else $EMDM_MODELS_DIR, else public/models; honoured by
the step model and the text encoder alike; a folder without a manifest is one line of error (exit status 2).
emdm.generate runs the CLI's loop: the same prompt, seed and steps give the same joints."""

import json
import shutil

import numpy as np
import pytest

import emdm
from emdm import paths
from emdm.sample import main as sample_main
from emdm.sampler import SampleError

MODEL = "emdm-t2m-web"


@pytest.fixture(scope="module")
def models_copy(tmp_path_factory):
    """public/models with the t2m model's int8 file and meanStd but no text encoder folder."""
    src, out = paths.MODELS_DIR, tmp_path_factory.mktemp("models")
    entry = json.loads((src / "manifest.json").read_text())["models"][MODEL]
    for rel in ("manifest.json", entry["variants"]["int8"], entry["meanStd"]):
        shutil.copyfile(src / rel, out / rel)
    return out


def args(out, *extra):
    return ["--model", MODEL, "--variant", "int8", "--text", "a person walks forward", "--frames", "20",
            "--out", str(out / "m"), *extra]


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err, err
    return err


def test_text_encoder_reads_the_given_folder(models_copy, tmp_path, capsys):
    """The copy has no text encoder: it must not be read from the repository's folder instead."""
    assert sample_main(args(tmp_path, "--models-dir", str(models_copy))) == 2
    err = one_line_error(capsys)
    assert str(models_copy) in err and "text" in err


def test_missing_folder_is_one_line(tmp_path, capsys):
    missing = tmp_path / "nowhere"
    assert sample_main(args(tmp_path, "--models-dir", str(missing))) == 2
    err = one_line_error(capsys)
    assert str(missing) in err and "--models-dir" in err and "not a folder" in err
    assert not list(tmp_path.glob("m*"))


def test_environment_variable(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(paths.MODELS_ENV, str(tmp_path))      # a folder without manifest.json
    assert paths.models_dir() == tmp_path and paths.models_dir("x") == paths.Path("x")
    assert sample_main(args(tmp_path)) == 2
    err = one_line_error(capsys)
    assert "$EMDM_MODELS_DIR" in err and "no manifest.json" in err
    monkeypatch.setenv(paths.MODELS_ENV, str(paths.MODELS_DIR))
    assert sample_main(args(tmp_path)) == 0


def test_generate_is_the_cli(tmp_path):
    assert sample_main(args(tmp_path, "--seed", "3", "--steps", "4", "--models-dir", str(paths.MODELS_DIR))) == 0
    m = emdm.generate("a person walks forward", seconds=1, seed=3, steps=4, variant="int8",
                      models_dir=paths.MODELS_DIR)
    assert m.joints.shape == (20, 22, 3) and m.features.shape == (20, 263)
    np.testing.assert_array_equal(m.joints, np.load(tmp_path / "m.npy"))


@pytest.mark.parametrize("kw, what", [({"models_dir": "/nonexistent/models"}, "/nonexistent/models: is not a folder"),
                                      ({"seconds": 60}, "seconds must give 1..196 frames"),
                                      ({"steps": 7}, "not supported"), ({"seed": -1}, "seed must be")])
def test_generate_bad_input(kw, what):
    with pytest.raises(SampleError, match=what):
        emdm.generate("a person walks forward", **kw)


def test_generate_warns_of_a_prompt_the_model_does_not_do_as_the_page_does():
    """The page and the CLI say a prompt is far from what the model does well; a program calling emdm.generate got
    nothing: a PromptWarning with the same words (and the motion all the same)."""
    import warnings

    from emdm.generation import PromptWarning

    assert emdm.PromptWarning is PromptWarning and issubclass(PromptWarning, UserWarning)
    with pytest.warns(PromptWarning, match="does not read as English.*Closest prompts that work: 'a person"):
        m = emdm.generate("une personne marche en avant", seconds=1, seed=1, steps=1, models_dir=paths.MODELS_DIR)
    assert m.joints.shape == (20, 22, 3)
    with pytest.warns(PromptWarning, match="reads as kick, which the model does not do well yet"):
        emdm.generate("a person kicks", seconds=1, seed=1, steps=1, models_dir=paths.MODELS_DIR)
    with warnings.catch_warnings():
        warnings.simplefilter("error", PromptWarning)
        emdm.generate("a person walks forward", seconds=1, seed=1, steps=1, models_dir=paths.MODELS_DIR)


def test_generate_empty_prompt():
    with pytest.raises(SampleError, match="prompt must be"):
        emdm.generate("  ")


def test_python_m_runs_without_warnings(tmp_path):
    """`import emdm` must not import emdm.sample: `python -m emdm.sample` would then run a second copy of it and
    runpy warns on stderr."""
    import os
    import subprocess
    import sys

    env = {**os.environ, "PYTHONPATH": str(paths.REPO_ROOT / "scripts")}
    r = subprocess.run([sys.executable, "-m", "emdm.sample", "--help"], capture_output=True, text=True, env=env,
                       cwd=tmp_path)
    assert r.returncode == 0 and r.stderr == "", r.stderr
