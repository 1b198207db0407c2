"""The sampling loop and CLI (the loop the browser runs) on a tiny exported model."""

import numpy as np
import pytest

from emdm import skeleton as sk
from emdm.export import main as export_main
from emdm.mocap.bvh import forward_kinematics as bvh_fk, read_bvh
from emdm.writers.bvh import write_bvh
from emdm.motion.ik import forward_kinematics, solve_ik
from emdm.model.open import onnx_step
from emdm.sample import main as sample_main
from emdm.sampler import SampleError, SamplingSettings, make_condition, sample_features
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress"]


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    ds = write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)
    run = tmp_path_factory.mktemp("run")
    train_main(["--data", str(ds), "--task", "action", "--out", str(run), "--steps", "2", *TINY])
    out = tmp_path_factory.mktemp("models")
    export_main(["--ckpt", str(run / "ckpt.pt"), "--name", "m", "--out", str(out), "--variants", ""])
    return out


class CountingStep:
    def __init__(self, step):
        self.step, self.calls, self.batches = step, 0, []

    def __call__(self, x, z, c, t, mask):
        self.calls += 1
        self.batches.append(x.shape[0])
        assert np.all(t == t[0]) and mask.shape == x.shape[:2]
        return self.step(x, z, c, t, mask)


def test_seeds(models):
    step = onnx_step(models / "m.onnx")
    c = np.eye(3, dtype=np.float32)[0]
    a = sample_features(step, c, 30, SamplingSettings(steps=4, guidance=2.5), seed=1)
    b = sample_features(step, c, 30, SamplingSettings(steps=4, guidance=2.5), seed=1)
    d = sample_features(step, c, 30, SamplingSettings(steps=4, guidance=2.5), seed=2)
    assert a.shape == (1, 30, 263) and np.isfinite(a).all()
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - d).mean() > 1e-3


def test_guidance_batches_conditional_and_unconditional_in_one_call(models):
    counting = CountingStep(onnx_step(models / "m.onnx"))
    guided = SamplingSettings(steps=5, guidance=2.5)
    sample_features(counting, np.eye(3, dtype=np.float32)[1], 20, guided, seed=0, num=2)
    assert counting.calls == 5 and counting.batches == [4] * 5
    counting = CountingStep(onnx_step(models / "m.onnx"))
    sample_features(counting, np.zeros(3, np.float32), 20, guided, seed=0)      # unconditional
    assert counting.batches == [1] * 5


def test_one_step_is_the_generator_output(models):
    """T = 1: x = coef1·G(x_T) with coef1 = 1 and no noise."""
    step = onnx_step(models / "m.onnx")
    out = sample_features(step, np.zeros(3, np.float32), 12, SamplingSettings(steps=1, guidance=1.0), seed=5)
    rng = np.random.default_rng(5)
    x = rng.standard_normal((1, 12, 263), dtype=np.float32)
    z = rng.standard_normal((1, 64), dtype=np.float32)
    direct = step(x, z, np.zeros((1, 3), np.float32), np.array([1.0], np.float32), np.ones((1, 12), np.float32))
    np.testing.assert_allclose(out, direct, atol=1e-6)


def test_cli_writes_joints_features_and_bvh(models, tmp_path):
    out = tmp_path / "s" / "wave"
    assert sample_main(["--model", "m", "--models-dir", str(models), "--action", "wave", "--frames", "40",
                        "--steps", "4", "--seed", "3", "--out", str(out)]) == 0
    joints = np.load(out.with_suffix(".npy"))
    assert joints.shape == (40, 22, 3) and np.isfinite(joints).all()
    assert not out.with_suffix(".bvh").exists()                    # the file name says the unit
    bvh = read_bvh(out.with_suffix(".metres.bvh"))
    assert bvh.num_frames == 40 and abs(bvh.fps - 20) < 1e-6
    assert sorted(n for n, end in zip(bvh.names, bvh.end_site) if not end) == sorted(sk.JOINT_NAMES)
    # metres by default (Blender imports BVH at scale 1.0): the project's reader puts the pelvis where the
    # joints have it; --bvh-units cm gives 100× that, one file per sample
    pelvis = bvh_fk(bvh)[:, bvh.index("pelvis")]
    np.testing.assert_allclose(pelvis, joints[:, 0], atol=1e-3)
    cm = tmp_path / "s" / "wave2"
    assert sample_main(["--model", "m", "--models-dir", str(models), "--action", "wave", "--frames", "40",
                        "--steps", "4", "--seed", "3", "--num", "2", "--bvh-units", "cm", "--out", str(cm)]) == 0
    joints2 = np.load(cm.with_suffix(".npy"))
    for i in range(2):
        b = read_bvh(tmp_path / "s" / f"wave2_{i}.centimetres.bvh")
        np.testing.assert_allclose(bvh_fk(b)[:, b.index("pelvis")], 100 * joints2[i, :, 0], atol=0.1)


def test_bad_condition_is_explained():
    spec = {"type": "action", "labels": ["walk", "wave"], "dim": 2}
    with pytest.raises(SampleError, match="unknown action 'fly'"):
        make_condition(spec, None, "fly", False)
    with pytest.raises(SampleError, match="exactly one"):
        make_condition(spec, None, "walk", True)


def test_bvh_round_trip_through_the_project_reader(tmp_path):
    """Joints on the reference skeleton → IK → BVH (metres, the default) → reader + FK gives the same joints."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    local = Rotation.from_rotvec(rng.normal(size=(12 * 22, 3)) * 0.6).as_matrix().reshape(12, 22, 3, 3)
    joints = forward_kinematics(rng.normal(size=(12, 3)), local)
    r, l2, _ = solve_ik(joints)
    np.testing.assert_allclose(forward_kinematics(r, l2), joints, atol=1e-9)
    path = write_bvh(joints, tmp_path / "x.bvh")
    bvh = read_bvh(path)
    from emdm import skeleton as sk

    pos = bvh_fk(bvh)[:, [bvh.index(n) for n in sk.JOINT_NAMES]]
    np.testing.assert_allclose(pos, joints, atol=2e-4)      # 4 decimals of degrees


# --- bad arguments: one line naming the argument and what is allowed, exit status 2, nothing written ---

def _cli(models, out, *extra):
    return ["--model", "m", "--models-dir", str(models), "--action", "wave", "--frames", "12", "--out", str(out),
            *extra]


@pytest.mark.parametrize("extra, expected", [
    (["--steps", "0"], r"--steps: 0 is not supported by model 'm'; use one of \[1, 2, 4, 5, 8, 10\]"),
    (["--steps", "3"], r"--steps: 3 is not supported by model 'm'; use one of \[1, 2, 4, 5, 8, 10\]"),
    (["--guidance", "nan"], r"--guidance must be a finite number ≥ 0, got nan"),
    (["--guidance", "inf"], r"--guidance must be a finite number ≥ 0, got inf"),
    (["--guidance", "-1"], r"--guidance must be a finite number ≥ 0, got -1"),
    (["--guidance-min-time", "-0.5"], r"--guidance-min-time must be a finite time ≥ 0, got -0.5"),
    (["--x0-smoothing", "-1"], r"--x0-smoothing must be a finite σ ≥ 0 in frames \(0 = off\), got -1"),
    (["--x0-smoothing", "nan"], r"--x0-smoothing must be a finite σ ≥ 0 in frames \(0 = off\), got nan"),
    (["--guidance-min-time", "nan"], r"--guidance-min-time must be a finite time ≥ 0, got nan"),
    (["--num", "0"], r"--num must be in 1\.\.256, got 0"),
    (["--num", "100000"], r"--num must be in 1\.\.256, got 100000"),
    (["--steps", "100000"], r"--steps must be in 1\.\.1000, got 100000"),
    (["--x0-smoothing", "1e9"], r"--x0-smoothing must be a finite σ ≥ 0 in frames \(0 = off\), got 1000000000\.0 "
                                r"\(at most 50\)"),
    (["--frames", "100000"], r"--frames must be in 1\.\.1000 \(the model's maxFrames, at most\), got 100000"),
    (["--threads", "100000"], r"--threads must be in 1\.\.256, got 100000"),
    (["--variant", "int4"], r"--variant: model 'm' has no variant 'int4'; use one of fp32"),
    (["--seed", "-1"], r"--seed must be in 0\.\.4294967295, got -1"),
    (["--threads", "0"], r"--threads must be in 1\.\.256, got 0"),
    (["--frames", "0"], r"--frames must be in 1\.\.196, got 0"),
])
def test_bad_argument_is_one_line_and_exit_2(models, tmp_path, capsys, extra, expected):
    import re

    out = tmp_path / "o" / "x"
    assert sample_main(_cli(models, out, *extra)) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.fullmatch(r"error: " + expected + r".*", err[0]), err
    assert not (tmp_path / "o").exists()


def _manifest_with(models, tmp_path, **fields):
    """A copy of the models folder whose model 'm' has ``fields`` changed."""
    import json
    import shutil

    d = tmp_path / "models"
    shutil.copytree(models, d)
    man = json.loads((d / "manifest.json").read_text())
    man["models"]["m"].update(fields)
    (d / "manifest.json").write_text(json.dumps(man))
    return d


@pytest.mark.parametrize("fields, expected", [
    ({"supportedSteps": [1, 100000]}, r"field 'models\.m\.supportedSteps' is \[1, 100000\]; it must be a list of step "
                                      r"counts in 1\.\.1000"),
    ({"defaultSteps": 5000}, r"field 'models\.m\.defaultSteps' is 5000; it must be an integer in 1\.\.1000"),
    ({"x0Smoothing": 1e9}, r"field 'models\.m\.x0Smoothing' is 1000000000\.0; it must be a σ ≥ 0 in frames, at most 50"),
    ({"maxFrames": 10**9}, r"field 'models\.m\.maxFrames' is 1000000000; it must be an integer in 1\.\.1000"),
    ({"zDim": 10**9}, r"field 'models\.m\.zDim' is 1000000000; it must be an integer in 1\.\.4096"),
    ({"condition": {"type": "action", "dim": 10**9, "labels": []}}, r"field 'models\.m\.condition' is .*1\.\.4096"),
    ({"meanStd": "../../../../etc/passwd"}, r"field 'models\.m\.meanStd' is \"\.\./\.\./\.\./\.\./etc/passwd\"; it must "
                                             r"be a relative path inside the models folder"),
    ({"onnx": "/etc/passwd"}, r"field 'models\.m\.onnx' is \"/etc/passwd\"; it must be a relative path"),
])
def test_manifest_sizes_and_paths_are_bounded(models, tmp_path, capsys, fields, expected):
    """A manifest cannot make sampling allocate without bound (a huge step count with --steps to match grew to 23.5 GB)
    or read a file outside its folder: one line naming the field, exit 2."""
    import re

    d = _manifest_with(models, tmp_path, **fields)
    steps = fields.get("supportedSteps", [1])[-1]
    out = tmp_path / "o" / "x"
    assert sample_main(["--model", "m", "--models-dir", str(d), "--action", "wave", "--frames", "12",
                        "--steps", str(min(steps, 1000)), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(expected, err[0]), err
    assert not (tmp_path / "o").exists()


def test_a_linked_manifest_file_outside_the_folder_is_refused(models, tmp_path, capsys):
    d = _manifest_with(models, tmp_path)
    outside = tmp_path / "elsewhere.f32"
    (d / "m.meanstd.f32").rename(outside)
    (d / "m.meanstd.f32").symlink_to(outside)
    out = tmp_path / "o" / "x"
    assert sample_main(["--model", "m", "--models-dir", str(d), "--action", "wave", "--frames", "12", "--steps", "1",
                        "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "field 'models.m.meanStd' names 'm.meanstd.f32', which resolves outside" in err[0], err


@pytest.mark.parametrize("text, expected", [
    ('[{"prompt": "wave", "seconds": 1e308}]', r"segment 1 \('wave'\): 1e\+308 s is too long; a timeline lasts at most 60 s"),
    ('[{"prompt": "wave", "seconds": ' + "9" * 400 + '}]', r"segment 1 \('wave'\): over 1e300 s is too long"),
    ('[{"prompt": "wave", "seconds": -' + "9" * 400 + '}]', r"segment 1 \('wave'\): under -1e300 s is too short"),
    ("[" * 100000 + "]" * 100000, r"not valid JSON \(nested too deeply"),
    ("[" + ",".join(['{"prompt": "wave", "seconds": 0.05}'] * 1201) + "]", r"the timeline has 1201 segments; at most 60 s"),
])
def test_timeline_json_out_of_bounds_is_one_line(models, tmp_path, capsys, text, expected):
    import re

    f = tmp_path / "t.json"
    f.write_text(text)
    out = tmp_path / "o" / "x"
    assert sample_main(["--model", "m", "--models-dir", str(models), "--timeline-json", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and re.search(expected, err[0]) and "Traceback" not in err[0], err


def test_empty_prompt_is_refused_like_the_page():
    spec = {"type": "text", "encoder": "all-MiniLM-L6-v2", "dim": 384}
    with pytest.raises(SampleError, match=r"--text is empty"):
        make_condition(spec, "   ", None, False)


def test_long_prompt_says_it_was_truncated(capsys):
    from emdm.text import fixtures as fx

    spec = {"type": "text", "encoder": "all-MiniLM-L6-v2", "dim": 384}
    make_condition(spec, "a person walks forward", None, False)
    assert capsys.readouterr().err == ""
    a = make_condition(spec, fx.LONG_PROMPT, None, False)
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("prompt truncated to 128 tokens"), err
    np.testing.assert_array_equal(a, make_condition(spec, fx.LONG_PROMPT + " then he jumps", None, False))


def test_unwritable_out_is_found_before_sampling(models, tmp_path, capsys, monkeypatch):
    """A path under a regular file cannot be written: refused before the model runs."""
    import emdm.model.open as opener            # where emdm.sample opens its model

    calls = []
    real = opener.onnx_step
    monkeypatch.setattr(opener, "onnx_step", lambda *a, **k: (calls.append(1), real(*a, **k))[1])
    blocker = tmp_path / "file.txt"
    blocker.write_text("not a folder")
    assert sample_main(_cli(models, blocker / "sub" / "x")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: --out: ") and "file.txt is a file, not a folder" in err[0], err
    assert calls == [], "the model was opened before --out was checked"
    (tmp_path / "dir.npy").mkdir()
    assert sample_main(_cli(models, tmp_path / "dir")) == 2
    assert "dir.npy is a folder" in capsys.readouterr().err


def test_out_is_a_prefix_its_dots_kept_and_a_folder_refused(models, tmp_path, capsys):
    """--out run.v2 and run.v3 are two prefixes (with_suffix once made both run.npy); --out walk.npy stands for walk;
    a folder, or a path ending in a separator, names no file and is refused before sampling."""
    def names():
        return sorted(p.name for p in (tmp_path / "o").iterdir())

    for given in ("run.v2", "run.v3"):
        assert sample_main(_cli(models, tmp_path / "o" / given, "--steps", "2")) == 0
    assert names() == [f"run.v{i}{s}" for i in (2, 3) for s in (".features.npy", ".metres.bvh", ".npy")]
    said = capsys.readouterr().out
    assert "run.v3.npy" in said and "run.v3.features.npy" in said and "run.v3.metres.bvh" in said, said
    for given in ("walk.npy", "walk.metres.bvh", "walk.features.npy"):
        assert sample_main(_cli(models, tmp_path / "o" / given, "--steps", "2")) == 0
    assert [n for n in names() if n.startswith("walk")] == ["walk.features.npy", "walk.metres.bvh", "walk.npy"]
    assert not list((tmp_path / "o").glob(".*tmp*"))                        # written whole, through a rename
    capsys.readouterr()
    for given in (str(tmp_path / "o"), str(tmp_path / "new") + "/"):
        assert sample_main(_cli(models, given, "--steps", "2")) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"--out {given}: a folder; give a path prefix such as out/walk" in err[0], err
    assert not (tmp_path / "new").exists()


def test_non_finite_motion_is_an_error_and_not_written(models, tmp_path, capsys, monkeypatch):
    import emdm.model.open as opener            # where emdm.sample opens its model

    def nan_step(path, threads=1):
        return lambda x, z, c, t, mask: np.full_like(x, np.nan)
    monkeypatch.setattr(opener, "onnx_step", nan_step)
    out = tmp_path / "o" / "nan"
    assert sample_main(_cli(models, out, "--steps", "2")) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "non-finite" in err[0], err
    assert not (tmp_path / "o").exists()


def test_guidance_interval_skips_the_unconditional_row_below_its_time_and_keeps_the_draws():
    """guidance_min_time: 2 rows only at steps with t > it, 1 below; the same random draws (the committed tiny
    parity model, against the fixture reference that feeds the noise in emdm.sample's order); 0 = today's loop."""
    from emdm import fixtures as fx
    from emdm.sampler.schedule import make_schedule

    path = fx.PARITY_DIR / "tiny-step.onnx"
    cond = np.random.default_rng(3).standard_normal(fx.TINY_COND_DIM).astype(np.float32)
    sched, seed = make_schedule(10), 11
    counting = CountingStep(onnx_step(path))
    interval = SamplingSettings(steps=10, guidance=2.5, guidance_min_time=0.55)
    x = sample_features(counting, cond, 12, interval, seed=seed)[0]
    assert counting.batches == [2] * 5 + [1] * 5            # t = 1 … 0.6004 guided, 0.5005 … 0.1009 not
    x_T, zs, epss = fx.draw_noise(np.random.default_rng(seed), 10, 12, 263, 64, sched)
    ref = fx.reference_sample(fx.step_session(path), x_T, zs, epss, cond, 2.5, sched, guidance_min_time=0.55)
    np.testing.assert_allclose(x, ref, atol=1e-4)
    full = sample_features(onnx_step(path), cond, 12, SamplingSettings(steps=10, guidance=2.5), seed=seed)[0]
    assert np.abs(x - full).max() > 1e-6
    every = SamplingSettings(steps=10, guidance=2.5, guidance_min_time=0.0)
    np.testing.assert_array_equal(full, sample_features(onnx_step(path), cond, 12, every, seed=seed)[0])
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(SampleError, match="guidance_min_time must be a finite time"):
            sample_features(onnx_step(path), cond, 12, SamplingSettings(steps=2, guidance=2.5, guidance_min_time=bad))


def test_cli_guidance_min_time_defaults_to_the_manifest_entry(models, tmp_path):
    """--guidance-min-time changes the motion; without it the entry's guidanceMinTime is used (absent: every step)."""
    import json
    import shutil

    def run(models_dir, name, *extra):
        out = tmp_path / name
        args = ["--model", "m", "--models-dir", str(models_dir), "--action", "0", "--frames", "12", "--steps", "10",
                "--guidance", "2.5", "--no-bvh", "--out", str(out), *extra]
        assert sample_main(args) == 0
        return np.load(out.with_suffix(".features.npy"))

    plain, interval = run(models, "plain"), run(models, "interval", "--guidance-min-time", "0.55")
    np.testing.assert_array_equal(plain, run(models, "zero", "--guidance-min-time", "0"))
    assert np.abs(plain - interval).max() > 1e-6
    other = tmp_path / "models"
    shutil.copytree(models, other)
    manifest = json.loads((other / "manifest.json").read_text())
    manifest["models"]["m"]["guidanceMinTime"] = 0.55
    (other / "manifest.json").write_text(json.dumps(manifest))
    np.testing.assert_array_equal(interval, run(other, "from-manifest"))
    np.testing.assert_array_equal(plain, run(other, "override", "--guidance-min-time", "0"))


def test_x0_smoothing_smooths_every_x0_but_the_last_and_keeps_the_draws():
    """x0_smoothing σ: x̂0's pose channels are smoothed along time at every step but the last (a spy sees the
    smoothed estimate in the x it is given next; root, velocity and contact channels the model's own), the result
    equals the fixture reference fed the same noise; 0 = today's loop bit for bit."""
    from emdm import fixtures as fx
    from emdm.sampler.schedule import make_schedule
    from emdm.motion.smooth import POSE_CHANNELS, smooth_frames

    path = fx.PARITY_DIR / "tiny-step.onnx"
    cond = np.random.default_rng(4).standard_normal(fx.TINY_COND_DIM).astype(np.float32)
    sched, seed = make_schedule(4), 5
    smoothed = SamplingSettings(steps=4, guidance=2.5, x0_smoothing=1.0)
    x = sample_features(onnx_step(path), cond, 12, smoothed, seed=seed)[0]
    x_T, zs, epss = fx.draw_noise(np.random.default_rng(seed), 4, 12, 263, 64, sched)
    ref = fx.reference_sample(fx.step_session(path), x_T, zs, epss, cond, 2.5, sched, x0_smoothing=1.0)
    np.testing.assert_allclose(x, ref, atol=1e-4)
    plain = sample_features(onnx_step(path), cond, 12, SamplingSettings(steps=4, guidance=2.5), seed=seed)[0]
    assert np.abs(x - plain).max() > 1e-3
    off = SamplingSettings(steps=4, guidance=2.5, x0_smoothing=0.0)
    np.testing.assert_array_equal(plain, sample_features(onnx_step(path), cond, 12, off, seed=seed)[0])

    # a step returning a spike train: the last x̂0 (the result) is the model's own, the others are smoothed
    spikes = np.zeros((1, 12, 263), np.float32)
    spikes[0, ::2] = 1.0

    def spiky(x, z, c, t, mask):
        return np.repeat(spikes, x.shape[0], 0)

    out = sample_features(spiky, cond, 12, SamplingSettings(steps=1, x0_smoothing=1.0), seed=0)
    np.testing.assert_array_equal(out, spikes)               # one step: nothing before the last
    seen = []

    def spy(x, z, c, t, mask):
        seen.append(x.copy())
        return np.repeat(spikes, x.shape[0], 0)

    sched2 = make_schedule(2)
    out = sample_features(spy, cond, 12, SamplingSettings(steps=2, guidance=1.0, x0_smoothing=1.0), seed=0)
    np.testing.assert_array_equal(out, spikes)
    # the second call's x = coef1·smooth(x̂0) + coef2·x_T + σ·ε: remove the known parts and compare
    rng = np.random.default_rng(0)
    x_T = rng.standard_normal((1, 12, 263), dtype=np.float32)
    rng.standard_normal((1, 64), dtype=np.float32)
    eps = rng.standard_normal((1, 12, 263), dtype=np.float32)
    smoothed = spikes.copy()
    a, b = POSE_CHANNELS
    smoothed[..., a:b] = smooth_frames(spikes, 1.0)[..., a:b]
    assert (a, b) == (4, 193) and np.abs(smoothed - spikes).max() > 0.1
    want = np.float32(sched2.coef1[1]) * smoothed + np.float32(sched2.coef2[1]) * x_T \
        + np.float32(sched2.sigma[1]) * eps
    np.testing.assert_allclose(seen[1], want, atol=1e-6)
    for bad in (-0.1, float("nan"), float("inf")):
        with pytest.raises(SampleError, match="x0_smoothing must be a finite σ ≥ 0 in frames"):
            sample_features(onnx_step(path), cond, 12, SamplingSettings(steps=2, guidance=2.5, x0_smoothing=bad))


def test_smooth_frames_is_the_pages_kernel_and_keeps_rows_within_their_length():
    from emdm.motion.smooth import smooth_frames

    x = np.zeros((2, 15, 1), np.float32)
    x[:, 7] = 1.0
    y = smooth_frames(x, 1.0)
    w = np.exp(-np.arange(-3, 4) ** 2 / 2.0)
    np.testing.assert_allclose(y[0, 4:11, 0], w / w.sum(), rtol=1e-6)   # interior: the whole kernel (r = 3), normalised
    assert y[0, 3, 0] == 0 and y[0, 11, 0] == 0
    # at the ends the kernel is renormalised over the frames inside the clip (frame 0 sees frames 0..3)
    x = np.zeros((9, 1), np.float32)
    x[0] = 1.0
    np.testing.assert_allclose(smooth_frames(x, 1.0)[0, 0], w[3] / w[3:].sum(), rtol=1e-6)
    # a padded row is smoothed over its own frames only; its padding is left alone
    x = np.random.default_rng(0).standard_normal((2, 9, 3)).astype(np.float32)
    y = smooth_frames(x, 1.0, lengths=np.array([9, 5]))
    np.testing.assert_array_equal(y[1, :5], smooth_frames(x[1, :5], 1.0))
    np.testing.assert_array_equal(y[1, 5:], x[1, 5:])
    np.testing.assert_array_equal(y[0], smooth_frames(x[0], 1.0))
    np.testing.assert_array_equal(smooth_frames(x, 0.0), x)


def test_cli_x0_smoothing_defaults_to_the_manifest_entry(models, tmp_path):
    """--x0-smoothing changes the motion; without it the entry's x0Smoothing is used (absent: none); the edit modes
    take it too."""
    import json
    import shutil

    def run(models_dir, name, *extra):
        out = tmp_path / name
        args = ["--model", "m", "--models-dir", str(models_dir), "--action", "0", "--frames", "12", "--steps", "10",
                "--guidance", "2.5", "--no-bvh", "--out", str(out), *extra]
        assert sample_main(args) == 0
        return np.load(out.with_suffix(".features.npy"))

    plain, smooth = run(models, "plain"), run(models, "smooth", "--x0-smoothing", "1")
    np.testing.assert_array_equal(plain, run(models, "zero", "--x0-smoothing", "0"))
    assert np.abs(plain - smooth).max() > 1e-6
    other = tmp_path / "models"
    shutil.copytree(models, other)
    manifest = json.loads((other / "manifest.json").read_text())
    manifest["models"]["m"]["x0Smoothing"] = 1.0
    (other / "manifest.json").write_text(json.dumps(manifest))
    np.testing.assert_array_equal(smooth, run(other, "from-manifest"))
    np.testing.assert_array_equal(plain, run(other, "override", "--x0-smoothing", "0"))
    loop_plain = run(models, "loop-plain", "--loop", "--frames", "30")
    loop_smooth = run(models, "loop-smooth", "--loop", "--frames", "30", "--x0-smoothing", "1")
    assert np.abs(loop_plain - loop_smooth).max() > 1e-6
