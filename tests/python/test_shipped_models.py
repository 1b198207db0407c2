"""Sanity checks on the models shipped in public/models (the files the browser downloads).

Each model generates with the exact browser loop (emdm.sample) from its ONNX file and mean/std:
no NaN, bone lengths close to the reference skeleton, feet on the floor on contact frames, different
seeds give different motions and the same seed gives the same motion. The same checks run on every
variant the manifest lists (int8, fp16: files the page loads when asked), not only on the fp32 file.
"""

import numpy as np
import pytest

from emdm import manifest as mf
from emdm import paths
from emdm import skeleton as sk
from emdm.eval import models_report
from emdm.motion.features import recover_joints
from emdm.model.open import onnx_step, read_meanstd, torch_step
from emdm.sampler import SamplingSettings, denormalise, sample_features
from emdm.sampler.settings import method_of

MODELS = ["emdm-t2m-web", "emdm-a2m-web", "diffusion-t2m-web"]
FRAMES = 120
FOOT_BALLS = (10, 11)                  # l_foot, r_foot: at floor height (y = 0) in the rest pose
FOOT_CONTACT = {10: 260, 11: 262}      # their contact channels

# Every shipped model meets every bar. Until L_bone (train --w-bone, docs/MODELS.md) their bone lengths did
# not (worst bone median 24-78% off, the forearms). A model found below a bar that is known and being worked on
# goes in this table with the measurement in the note: its check then xfails, and once the model passes the
# test FAILS and asks to remove it, so the table cannot silently outlive the problem. Entries are labels:
# the model's name for its fp32 file, "<name>.<variant>" for a variant (e.g. "emdm-t2m-web.int8").
KNOWN_BELOW_BAR: dict[str, set[str]] = {"bones": set(), "feet": set()}


def check(name: str, bar: str, ok: bool, message: str) -> None:
    if name in KNOWN_BELOW_BAR[bar]:
        if ok:
            pytest.fail(f"{name} now passes the {bar!r} bar: remove it from KNOWN_BELOW_BAR")
        pytest.xfail(f"{name} below the {bar!r} bar (known, under-trained): {message}")
    assert ok, message


def _model_variants() -> list[tuple[str, str]]:
    """(model, variant) pairs to check: fp32 for every model, plus each variant its manifest entry lists."""
    try:
        models = mf.load(paths.MODELS_DIR)["models"]
    except mf.ManifestError:
        models = {}
    return [(m, v) for m in MODELS for v in ["fp32", *models.get(m, {}).get("variants", {})]]


def entry_file(label: str, entry: dict) -> str:
    """The ONNX file a label ("<name>" or "<name>.<variant>"; model names have no dot) stands for."""
    return models_report.onnx_files(entry)[label.split(".", 1)[1] if "." in label else "fp32"]


def shipped(name: str) -> dict:
    try:
        man = mf.load(paths.MODELS_DIR)
    except mf.ManifestError as e:
        pytest.skip(f"no manifest: {e}")
    if name not in man["models"]:
        pytest.skip(f"{name} not shipped yet in {paths.MODELS_DIR / mf.MANIFEST_NAME}")
    return man["models"][name]


# the conditions the bone check samples (the first is the one every other check uses): walking, and the two
# kinds of motion whose arms were furthest off before L_bone; the measure of docs/MODELS.md's bone table
PROMPTS = models_report.PROMPTS
assert models_report.FRAMES == FRAMES


def condition(entry: dict, i: int = 0) -> np.ndarray:
    return models_report.condition(entry, i)


@pytest.fixture(scope="module", params=MODELS)
def model(request):
    return request.param, shipped(request.param)


@pytest.fixture(scope="module", params=_model_variants(), ids=lambda p: p[0] if p[1] == "fp32" else f"{p[0]}.{p[1]}")
def generated(request):
    """(label, entry, run, condition) for one ONNX file of a model: its fp32 file or one of its variants."""
    name, variant = request.param
    entry = shipped(name)
    onnx = entry["onnx"] if variant == "fp32" else entry["variants"][variant]
    label = name if variant == "fp32" else f"{name}.{variant}"
    step = onnx_step(paths.MODELS_DIR / onnx, threads=1)
    mean, std = read_meanstd(paths.MODELS_DIR / entry["meanStd"])
    c = condition(entry)
    settings = SamplingSettings(method_of(entry.get("objective", "ddgan")), entry["defaultSteps"], entry["guidance"],
                                z_dim=entry["zDim"])      # guided at every step, no x̂0 smoothing

    done: dict[tuple[int, bytes], tuple[np.ndarray, np.ndarray]] = {}

    def run(seed: int, cond=c, fresh: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """(features, joints); a (seed, condition) already generated for another check is reused unless fresh."""
        key = (seed, np.asarray(cond, np.float32).tobytes())
        if fresh or key not in done:
            x = sample_features(step, cond, FRAMES, settings, seed)
            feats = denormalise(x[0], mean, std)
            done[key] = (feats, recover_joints(feats))
        return done[key]

    return label, entry, run, c


def test_manifest_files_match(model):
    name, entry = model
    problems = [p for p in mf.verify(paths.MODELS_DIR) if any(f in p for f in entry["files"])]
    assert not problems, problems
    assert entry["training"]["steps"] > 0


def test_no_nan_and_right_shape(generated):
    _, _, run, _ = generated
    feats, joints = run(0)
    assert feats.shape == (FRAMES, 263) and joints.shape == (FRAMES, 22, 3)
    assert np.isfinite(feats).all() and np.isfinite(joints).all()


def test_bone_lengths_match_the_reference_skeleton(generated):
    name, entry, run, _ = generated
    worst_rel, msg = 0.0, ""
    for i in range(len(PROMPTS)):
        cond = condition(entry, i)
        for seed in models_report.SEEDS:
            _, joints = run(seed, cond)
            rel = models_report.bone_errors(joints)                  # (21,) median over frames
            if rel.max() > worst_rel:
                worst = int(np.argmax(rel)) + 1
                worst_rel, msg = rel.max(), (f"condition {i}, seed {seed}: bone to {sk.JOINT_NAMES[worst]} off by "
                                             f"{rel.max():.1%} (median over frames)")
    check(name, "bones", worst_rel <= 0.05, msg)
    # docs/MODELS.md's bone table (docs/results/json/models-bones.json) is this measurement of the shipped files
    row = next((r for r in models_report.load_bones()["rows"] if r["file"] == entry_file(name, entry)), None)
    fix = "run `python -m emdm.eval.models_report measure` then `python -m emdm.eval.models_report`"
    assert row is not None, f"{name}: not in {models_report.BONES_JSON.name}; {fix}"
    # an int8 file's matmuls run on CPU-specific kernels (onnxruntime's u8s8 GEMM: AVX2's saturating multiply-add
    # vs AVX-512/VNNI), so its motions differ from machine to machine: measured on an AVX2-only AMD EPYC against the
    # table made elsewhere, the worst bone moved by up to 0.23 points (3.13 % → 2.90 %); fp32 agrees within 1e-6
    tol = 5e-3 if name.endswith(".int8") else 1e-6
    assert abs(row["worst"] - worst_rel) < tol, (f"{name}: {models_report.BONES_JSON.name} says worst bone "
                                                  f"{row['worst']:.2%}, measured {worst_rel:.2%}; {fix}")


def test_feet_on_the_floor_on_contact_frames(generated):
    name, _, run, _ = generated
    heights = []
    for seed in (0, 1):
        feats, joints = run(seed)
        for j, ch in FOOT_CONTACT.items():
            heights.append(joints[feats[:, ch] > 0.5, j, 1])
    h = np.abs(np.concatenate(heights))
    if h.size == 0:
        check(name, "feet", False, "the model never predicts a foot contact")
    check(name, "feet", bool(np.median(h) <= 0.05 and np.mean(h <= 0.05) >= 0.8),
          f"foot height on contact frames: median {np.median(h):.3f} m, {np.mean(h <= 0.05):.0%} within 5 cm")


def test_seeds_differ_and_repeat(generated):
    _, _, run, _ = generated
    _, a = run(3, fresh=True)
    _, b = run(3, fresh=True)
    _, c = run(4, fresh=True)
    np.testing.assert_array_equal(a, b)
    assert np.abs(a - c).mean() > 0.01          # more than 1 cm on average


def test_unconditional_generation_works(generated):
    _, entry, run, c = generated
    feats, joints = run(0, np.zeros_like(c))
    assert np.isfinite(joints).all()


def test_shipped_training_weights_carry_no_machine_paths(model):
    # the meta of a shipped weights file names its run's files by name only (emdm.checkpoints.portable_meta)
    name, entry = model
    if "trainingWeights" not in entry:
        pytest.skip(f"{name} ships no training weights")
    import torch

    meta = torch.load(paths.MODELS_DIR / entry["trainingWeights"], weights_only=True)["meta"]

    def strings(o):
        if isinstance(o, dict):
            for v in o.values():
                yield from strings(v)
        elif isinstance(o, (list, tuple)):
            for v in o:
                yield from strings(v)
        elif isinstance(o, str):
            yield o
    found = [s for s in strings(meta) if "/" in s or "\\" in s]
    assert not found, f"{entry['trainingWeights']}: paths in its meta: {found[:5]}"


def test_shipped_training_weights_are_the_onnx_model(model):
    # <name>.weights.f16.pt lets training continue from the shipped model (train --init-weights): it must be
    # the same network as the ONNX file, up to float16 rounding of the weights
    name, entry = model
    if "trainingWeights" not in entry:
        pytest.skip(f"{name} ships no training weights")
    import torch

    from emdm.export import load_generator

    path = paths.MODELS_DIR / entry["trainingWeights"]
    assert torch.load(path, weights_only=True)["meta"]["weights_dtype"] == "float16"
    G, meta, _ = load_generator(path)
    assert meta["task"] == entry["task"] and meta.get("objective", "ddgan") == entry["objective"]
    rng = np.random.default_rng(0)
    x, z = rng.standard_normal((2, 40, 263), dtype=np.float32), rng.standard_normal((2, 64), dtype=np.float32)
    c = rng.standard_normal((2, entry["condition"]["dim"]), dtype=np.float32)
    t, m = np.array([0.9, 0.3], np.float32), np.ones((2, 40), np.float32)
    ref = onnx_step(paths.MODELS_DIR / entry["onnx"])(x, z, c, t, m)
    got = torch_step(G)(x, z, c, t, m)
    assert np.abs(got - ref).max() < 0.05 * ref.std()
