"""Parity fixtures for the TypeScript core (tests/fixtures/parity/), regenerated in one command:

    .venv/bin/python -m emdm.fixtures            # everything that its inputs allow
    .venv/bin/python -m emdm.fixtures --only tiny recover

What it writes (each case = ``<name>.json`` index + ``<name>.bin`` float32 little-endian arrays):

* ``tiny-step.onnx`` + ``tiny``: a tiny random step model with the real ONNX contract
  (x_t, z, cond, t, mask -> x0), one step and a guided 4-step run with supplied noise, so the
  runtime and sampler are tested without the shipped models; the same run with guidance in a limited
  interval (``guidanceMinTime``: guided only at t > 0.6, one conditional row below) and the same noise; the same
  guided run with x̂0 smoothed along time at every step but the last (``x0Smoothing`` σ = 1 frame).
* ``tiny-ddim``: the same step model sampled as a diffusion-objective model with DDIM
  (``emdm.sampler.sample_features`` with method "ddim", guided and unconditional, 5 steps) with
  the noise it drew, and the DDIM marginals a_cum / s_cum of ``emdm.sampler.schedule`` for the step
  counts a diffusion model ships (1 … 100), which the TypeScript schedule must reproduce.
* ``recover``: features of a real clip from the prepared dataset and the joints
  ``emdm.motion.features.recover_joints`` gives for them (the TypeScript port must match).
* ``model-<name>`` for every model in ``public/models/manifest.json``: one step (x_t, z, cond, t
  -> x0) and a whole ``defaultSteps`` run with classifier-free guidance and supplied noise
  (-> final normalised x, de-normalised features, joints; guided only above the entry's
  ``guidanceMinTime`` when it has one, x̂0 smoothed by its ``x0Smoothing`` when it has one), computed with onnxruntime (CPU) by
  ``reference_sample``, the numpy transcription of docs/ARCHITECTURE.md "Sampling" (DDIM for a
  model whose ``objective`` is ``"diffusion"``).

Model files are read through the manifest (paths, sha256 checked), so fixtures follow whatever is
shipped; ``index.json`` lists the cases and the sha256 of the model each was made from, so a test
can tell a stale fixture from a real mismatch.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm.model.open import onnx_step
from emdm.model.quiet import quiet_onnx_tools
from emdm.sampler import SamplingSettings, sample_features
from emdm.sampler.sampler import cap_root_speed, root_speeds
from emdm.sampler.schedule import make_schedule
from emdm.sampler.settings import method_of, root_norm_of
from emdm.mocap.jointmap import load_joint_map
from emdm.mocap.load import load_bvh_clip
from emdm.motion.features import extract_features, recover_joints
from emdm.motion.retarget import normalize_clip, prepare_take
from emdm.motion.smooth import smooth_pose
from emdm.text.minilm import MiniLMEncoder

PARITY_DIR = paths.FIXTURES_DIR / "parity"
FRAMES = 40          # fixture motion length (the models take any L <= 196)
TINY_COND_DIM = 8
TINY_DDIM_STEPS = 5
TINY_GUIDANCE_MIN_TIME = 0.6   # of the tiny 4-step grid (0.25, 0.5005, 0.75, 1): guided at 1 and 0.75 only
TINY_X0_SMOOTHING = 1.0        # σ (frames) of the tiny smoothed run
TINY_SPEED_CAP = 0.8           # the tiny capped run: held to 0.8 × its first conditional x̂0's root speed
TINY_ROOT_NORM = (0.0, 0.0, 1.0, 1.0)   # tiny.meanstd's root velocity channels (mean 0, std 1)
DDIM_STEP_COUNTS = (1, 2, 4, 5, 8, 10, 20, 50, 100)   # the diffusion baseline's supportedSteps


# ---------------------------------------------------------------------------------------------
# fixture files

def write_case(out_dir: Path, name: str, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """``<name>.json`` (meta + array table) and ``<name>.bin`` (float32 LE, concatenated)."""
    out_dir.mkdir(parents=True, exist_ok=True)
    table = {}
    offset = 0
    blobs = []
    for key, arr in arrays.items():
        a = np.ascontiguousarray(np.asarray(arr, dtype="<f4"))
        if not np.all(np.isfinite(a)):
            raise ValueError(f"fixture {name}: array {key!r} has non-finite values")
        table[key] = {"offset": offset, "shape": list(a.shape)}
        blobs.append(a.tobytes())
        offset += a.nbytes
    (out_dir / f"{name}.bin").write_bytes(b"".join(blobs))
    doc = {"name": name, "bin": f"{name}.bin", "dtype": "float32-le", **meta, "arrays": table}
    path = out_dir / f"{name}.json"
    path.write_text(json.dumps(doc, indent=1) + "\n")
    return path


# ---------------------------------------------------------------------------------------------
# the reference sampler (numpy + onnxruntime), docs/ARCHITECTURE.md "Sampling"

def step_session(onnx_path: Path):
    import onnxruntime as ort

    so = ort.SessionOptions()
    so.intra_op_num_threads = 1
    so.log_severity_level = 3
    return ort.InferenceSession(str(onnx_path), so, providers=["CPUExecutionProvider"])


def run_step(sess, x: np.ndarray, z: np.ndarray, cond: np.ndarray, t: np.ndarray) -> np.ndarray:
    B, L, _ = x.shape
    feeds = {"x_t": x.astype(np.float32), "z": z.astype(np.float32), "cond": cond.astype(np.float32),
             "t": t.astype(np.float32), "mask": np.ones((B, L), np.float32)}
    return sess.run(["x0"], feeds)[0]


def reference_sample(sess, x_T: np.ndarray, zs: list[np.ndarray], epss: list[np.ndarray | None],
                     cond: np.ndarray, guidance: float, sched, objective: str = "ddgan",
                     guidance_min_time: float = 0.0, x0_smoothing: float = 0.0, speed_cap: float = 0.0,
                     root_norm=None) -> np.ndarray:
    """x_T (L, D); zs[k] (zDim,), epss[k] (L, D) or None, indexed by step k; cond (C,) -> x_0 (L, D).

    Guidance (s != 1 and a non-zero condition) at the steps whose time is above ``guidance_min_time`` (all
    of them for 0): one batched call with rows [cond, 0], same x and z, x0 = x0_u + s (x0_c - x0_u); at the
    other steps one conditional call. ``speed_cap`` c > 0 (with ``root_norm``): the result's root speed held to c times
    the first step's conditional x̂0's (``emdm.sampler.sampler`` "Root speed cap"). ``x0_smoothing`` σ > 0: at every step but the last (k > 0), x0's pose channels ← the
    Gaussian along frames of ``emdm.motion.smooth.smooth_pose`` (src/motion/smooth.ts smoothPose). ``objective="diffusion"``: z = 0 (the drawn z is ignored) and the
    DDIM update (η = 0) of docs/ARCHITECTURE.md "DDIM sampling", in float32 like emdm.sampler."""
    x = x_T.astype(np.float32)[None]
    guided = bool(np.any(cond != 0)) and guidance != 1.0
    first = None
    for k in range(sched.steps - 1, -1, -1):
        t = np.float32(sched.time[k])
        z = np.zeros_like(zs[k]) if objective == "diffusion" else zs[k]
        if guided and sched.time[k] > guidance_min_time:
            out = run_step(sess, np.concatenate([x, x]), np.stack([z, z]),
                           np.stack([cond, np.zeros_like(cond)]), np.array([t, t], np.float32))
            x0 = out[1:2] + np.float32(guidance) * (out[0:1] - out[1:2])
            first = out[0:1] if first is None else first
        else:
            x0 = run_step(sess, x, z[None], cond[None], np.array([t], np.float32))
            first = x0 if first is None else first
        if x0_smoothing > 0 and k > 0:
            x0 = smooth_pose(x0, x0_smoothing)
        if objective == "diffusion":
            if k == 0:
                x = x0.astype(np.float32)
            else:
                eps = (x - np.float32(sched.a_cum[k + 1]) * x0) / np.float32(sched.s_cum[k + 1])
                x = (np.float32(sched.a_cum[k]) * x0 + np.float32(sched.s_cum[k]) * eps).astype(np.float32)
            continue
        x_new = sched.coef1[k] * x0.astype(np.float64) + sched.coef2[k] * x.astype(np.float64)
        if sched.sigma[k] != 0:
            x_new = x_new + sched.sigma[k] * epss[k][None].astype(np.float64)
        x = x_new.astype(np.float32)
    if speed_cap > 0:
        ref = root_speeds(first, root_norm, first.shape[1])
        x = cap_root_speed(x, speed_cap * ref, root_norm, x.shape[1], None)
    return x[0]


def draw_noise(rng: np.random.Generator, steps: int, frames: int, dim: int, z_dim: int, sched,
               objective: str = "ddgan"):
    """Noise in emdm.sampler's order and dtype (x_T, then per step k = T-1..0: z, then eps when
    sigma[k] > 0; DDIM draws z (then zeroes it) and no eps), so a fixture run equals
    ``emdm.sampler.sample_features`` with the same rng."""
    x_T = rng.standard_normal((1, frames, dim), dtype=np.float32)[0]
    zs: list = [None] * steps
    epss: list = [None] * steps
    for k in range(steps - 1, -1, -1):
        zs[k] = rng.standard_normal((1, z_dim), dtype=np.float32)[0]
        if objective != "diffusion" and sched.sigma[k] > 0:
            epss[k] = rng.standard_normal((1, frames, dim), dtype=np.float32)[0]
    return x_T, zs, epss


def noise_arrays(x_T, zs, epss) -> dict[str, np.ndarray]:
    """Noise in the documented draw order: x_T, then for k = T-1..0: z[k], eps[k] (when drawn)."""
    arrays = {"x_T": x_T}
    for k in range(len(zs) - 1, -1, -1):
        arrays[f"z_{k}"] = zs[k]
        if epss[k] is not None:
            arrays[f"eps_{k}"] = epss[k]
    return arrays


def schedule_meta(sched) -> dict[str, list[float]]:
    return {"time": sched.time.tolist(), "coef1": sched.coef1.tolist(), "coef2": sched.coef2.tolist(),
            "sigma": sched.sigma.tolist()}


# ---------------------------------------------------------------------------------------------
# tiny model

def export_tiny_model(path: Path, cond_dim: int = TINY_COND_DIM) -> Path:
    """A small random step model with the real I/O contract (dynamic batch and length)."""
    import torch

    class TinyStep(torch.nn.Module):
        def __init__(self):
            super().__init__()
            g = torch.Generator().manual_seed(1234)
            d = 16
            def lin(i, o):
                m = torch.nn.Linear(i, o)
                with torch.no_grad():
                    m.weight.copy_(torch.randn(o, i, generator=g) / i ** 0.5)
                    m.bias.copy_(torch.randn(o, generator=g) * 0.1)
                return m
            self.inp, self.zp, self.cp, self.tp = lin(263, d), lin(64, d), lin(cond_dim, d), lin(1, d)
            self.q, self.k, self.v, self.out = lin(d, d), lin(d, d), lin(d, d), lin(d, 263)

        def forward(self, x_t, z, cond, t, mask):
            h = self.inp(x_t) + (self.zp(z) + self.cp(cond) + self.tp(t[:, None]))[:, None, :]
            att = self.q(h) @ self.k(h).transpose(1, 2) / 4.0
            att = att.masked_fill(mask[:, None, :] < 0.5, -1e9).softmax(-1)
            h = torch.tanh(h + att @ self.v(h))
            return x_t * 0.5 + self.out(h) * mask[..., None]

    model = TinyStep().eval()
    B, L = 2, 12
    ex = (torch.randn(B, L, 263), torch.randn(B, 64), torch.randn(B, cond_dim), torch.rand(B), torch.ones(B, L))
    bd, ld = torch.export.Dim("batch", min=1, max=64), torch.export.Dim("frames", min=1, max=196)
    dyn = {"x_t": {0: bd, 1: ld}, "z": {0: bd}, "cond": {0: bd}, "t": {0: bd}, "mask": {0: bd, 1: ld}}
    path.parent.mkdir(parents=True, exist_ok=True)
    with quiet_onnx_tools():
        prog = torch.onnx.export(model, ex, dynamo=True, opset_version=18, dynamic_shapes=dyn,
                                 input_names=["x_t", "z", "cond", "t", "mask"], output_names=["x0"])
    prog.save(str(path), external_data=False)
    return path


def make_tiny(out_dir: Path, export: bool = True) -> dict[str, Any]:
    """``export=False`` samples the ``tiny-step.onnx`` already in ``out_dir`` (the committed one, so a test can
    re-run the sampler without re-exporting: the exporter's bytes vary between runs, its outputs do not)."""
    onnx_path = out_dir / "tiny-step.onnx"
    if export:
        export_tiny_model(onnx_path)
    elif not onnx_path.is_file():
        raise FileNotFoundError(f"{onnx_path}: absent; call make_tiny with export=True (or copy the committed model there)")
    sess = step_session(onnx_path)
    rng = np.random.default_rng(20251122)
    sched = make_schedule(4)
    L, D, Z, C = 16, 263, 64, TINY_COND_DIM
    step_x = rng.standard_normal((2, L, D)).astype(np.float32)
    step_z = rng.standard_normal((2, Z)).astype(np.float32)
    step_c = rng.standard_normal((2, C)).astype(np.float32)
    step_t = np.array([0.3, 0.9], np.float32)
    step_x0 = run_step(sess, step_x, step_z, step_c, step_t)
    cond = rng.standard_normal(C).astype(np.float32)
    x_T, zs, epss = draw_noise(rng, sched.steps, L, D, Z, sched)
    x = reference_sample(sess, x_T, zs, epss, cond, 2.5, sched)
    x_u = reference_sample(sess, x_T, zs, epss, np.zeros(C, np.float32), 2.5, sched)
    x_i = reference_sample(sess, x_T, zs, epss, cond, 2.5, sched, guidance_min_time=TINY_GUIDANCE_MIN_TIME)
    x_s = reference_sample(sess, x_T, zs, epss, cond, 2.5, sched, x0_smoothing=TINY_X0_SMOOTHING)
    x_c = reference_sample(sess, x_T, zs, epss, cond, 2.5, sched, speed_cap=TINY_SPEED_CAP, root_norm=TINY_ROOT_NORM)
    if np.array_equal(x_c, x):
        raise AssertionError("fixtures tiny: the capped run was not capped; choose another TINY_SPEED_CAP")
    arrays = {"step_x_t": step_x, "step_z": step_z, "step_cond": step_c, "step_t": step_t, "step_x0": step_x0,
              "cond": cond, **noise_arrays(x_T, zs, epss), "final_x": x, "final_x_uncond": x_u, "final_x_interval": x_i,
              "final_x_smooth": x_s, "final_x_cap": x_c}
    meta = {"model": "tiny-step.onnx", "frames": L, "featureDim": D, "zDim": Z, "condDim": C,
            "steps": sched.steps, "guidance": 2.5, "intervalGuidanceMinTime": TINY_GUIDANCE_MIN_TIME,
            "smoothX0Smoothing": TINY_X0_SMOOTHING, "capSpeedCap": TINY_SPEED_CAP, "capRootNorm": list(TINY_ROOT_NORM),
            "schedule": schedule_meta(sched)}
    write_case(out_dir, "tiny", meta, arrays)
    # mean/std file in the manifest layout (float32 LE mean[263] then std[263]) for the browser harness
    ms = np.concatenate([np.zeros(D, "<f4"), np.ones(D, "<f4")])
    ms[3] = 0.9
    (out_dir / "tiny.meanstd.f32").write_bytes(ms.astype("<f4").tobytes())
    return {"case": "tiny", "model": "tiny-step.onnx"}


def make_tiny_ddim(out_dir: Path) -> dict[str, Any]:
    """The tiny step model as a diffusion-objective model: DDIM runs of ``emdm.sampler.sample_features``
    (the Python pipeline itself) with the noise they drew, plus the DDIM marginals for every step count."""
    onnx_path = out_dir / "tiny-step.onnx"
    if not onnx_path.is_file():
        raise FileNotFoundError(f"{onnx_path}: run `python -m emdm.fixtures --only tiny` first")
    sess = step_session(onnx_path)
    step = onnx_step(onnx_path)
    T, L, D, Z, C = TINY_DDIM_STEPS, 16, 263, 64, TINY_COND_DIM
    sched = make_schedule(T)
    cond = np.random.default_rng(20251123).standard_normal(C).astype(np.float32)
    seed = 77
    x_T, zs, epss = draw_noise(np.random.default_rng(seed), T, L, D, Z, sched, objective="diffusion")
    ddim = SamplingSettings(method="ddim", steps=T, guidance=2.5, z_dim=Z, feature_dim=D)
    x = sample_features(step, cond, L, ddim, seed)[0]
    x_u = sample_features(step, np.zeros(C, np.float32), L, ddim, seed)[0]
    # the supplied noise reproduces the Python run (so the TypeScript loop can be fed exactly this noise)
    for got, c in ((x, cond), (x_u, np.zeros(C, np.float32))):
        ref = reference_sample(sess, x_T, zs, epss, c, 2.5, sched, objective="diffusion")
        if np.max(np.abs(ref - got)) > 1e-5:
            raise AssertionError(f"fixtures: DDIM reference_sample differs from sample_features by {np.max(np.abs(ref - got)):.2e}")
    arrays = {"cond": cond, **noise_arrays(x_T, zs, epss), "final_x": x, "final_x_uncond": x_u}
    marginals = {str(n): {"a_cum": make_schedule(n).a_cum.tolist(), "s_cum": make_schedule(n).s_cum.tolist()}
                 for n in DDIM_STEP_COUNTS}
    meta = {"model": "tiny-step.onnx", "objective": "diffusion", "sampler": "ddim", "seed": seed, "frames": L,
            "featureDim": D, "zDim": Z, "condDim": C, "steps": T, "guidance": 2.5,
            "schedule": {**schedule_meta(sched), "a_cum": sched.a_cum.tolist(), "s_cum": sched.s_cum.tolist()},
            "marginals": marginals}
    write_case(out_dir, "tiny-ddim", meta, arrays)
    return {"case": "tiny-ddim", "model": "tiny-step.onnx"}


# ---------------------------------------------------------------------------------------------
# recover_joints on a real clip

RAW_CLIP = ("bandai-namco-motion/dataset/Bandai-Namco-Research-Motiondataset-2/data/"
            "dataset-2_walk-turn-left_normal_001.bvh")


def real_clip_features(max_frames: int = 120) -> tuple[np.ndarray, str]:
    """Features of a real clip: from the prepared dataset (data/dataset/new_joint_vecs, the clip
    that turns and travels most among the first 200), else one Bandai walk-turn-left take from
    data/raw (unpacked by ``emdm.data.prepare``), run through mocap -> retarget -> features."""
    vec_dir = paths.DATASET_DIR / "new_joint_vecs"
    files = sorted(vec_dir.glob("*.npy")) if vec_dir.is_dir() else []
    best = None
    for f in files[:200]:
        feats = np.load(f)
        if feats.ndim != 2 or feats.shape[1] != 263 or feats.shape[0] < 40:
            continue
        score = abs(float(feats[:, 0].sum())) + float(np.abs(feats[:, 1:3]).sum()) * 0.05
        if best is None or score > best[0]:
            best = (score, f, feats)
    if best is not None:
        _, f, feats = best
        return feats[:max_frames].astype(np.float32), f"{paths.DATASET_DIR.name}/new_joint_vecs/{f.name}"
    raw = paths.DATA_DIR / "raw" / RAW_CLIP
    if not raw.is_file():
        raise FileNotFoundError(f"{vec_dir}: no prepared clips and {raw} absent; run `python -m emdm.data.prepare` first")

    clip = load_bvh_clip(raw, load_joint_map("bandai"))
    joints = normalize_clip(prepare_take(clip.joints, clip.fps))[: max_frames + 1]
    return extract_features(joints), f"data/raw/{RAW_CLIP}"


def make_recover(out_dir: Path) -> dict[str, Any]:
    feats, source = real_clip_features()
    joints = recover_joints(feats)
    write_case(out_dir, "recover", {"source": source, "frames": int(feats.shape[0])},
               {"features": feats, "joints": joints})
    return {"case": "recover", "source": source}


# ---------------------------------------------------------------------------------------------
# shipped models

def condition_vector(name: str, entry: dict[str, Any], manifest: dict[str, Any], models_dir: Path,
                     rng: np.random.Generator) -> tuple[np.ndarray, str]:
    cond = entry["condition"]
    dim = int(cond["dim"])
    if cond["type"] == "action":
        v = np.zeros(dim, np.float32)
        v[0] = 1.0
        return v, f"action {cond['labels'][0]!r} (one-hot 0)"
    prompt = "a person walks forward and then turns around"
    enc = manifest.get("textEncoders", {}).get(cond.get("encoder", ""))
    if enc and enc.get("kind") == "minilm":
        try:
            v = MiniLMEncoder(models_dir / enc["dir"]).encode([prompt])[0].astype(np.float32)
            if v.shape == (dim,):
                return v, f"text {prompt!r} ({enc['kind']})"
        except Exception as e:  # fall back to a fixed unit vector, but say so
            print(f"fixtures: {name}: text encoder unavailable ({e}); using a random unit condition", file=sys.stderr)
    v = rng.standard_normal(dim).astype(np.float32)
    return v / np.linalg.norm(v), "random unit vector"


def make_model(out_dir: Path, name: str, entry: dict[str, Any], manifest: dict[str, Any], models_dir: Path) -> dict[str, Any]:
    onnx_rel = entry["onnx"]
    onnx_path = models_dir / onnx_rel
    meta_file = manifest["files"].get(onnx_rel)
    if meta_file is None:
        raise mf.ManifestError(f"manifest models.{name}.onnx: {onnx_rel!r} is not listed in 'files'")
    if mf.sha256_file(onnx_path) != meta_file["sha256"]:
        raise mf.ManifestError(f"{onnx_path}: sha256 differs from the manifest; re-export or re-save the manifest")
    D, Z = int(entry["featureDim"]), int(entry["zDim"])
    steps = int(entry["defaultSteps"])
    guidance = float(entry["guidance"])
    gmin = float(entry.get("guidanceMinTime", 0.0))
    sigma = float(entry.get("x0Smoothing", 0.0))
    cap = float(entry.get("speedCap", 0.0))
    ms = np.fromfile(models_dir / entry["meanStd"], dtype="<f4")
    if ms.shape != (2 * D,):
        raise ValueError(f"{models_dir / entry['meanStd']}: {ms.size} floats, expected {2 * D}")
    mean, std = ms[:D], ms[D:]
    objective = entry.get("objective", "ddgan")
    sched = make_schedule(steps)
    m_sched = entry.get("schedules", {}).get(str(steps))
    if m_sched:
        for key in ("time", "coef1", "coef2", "sigma"):
            if np.max(np.abs(np.asarray(m_sched[key]) - getattr(sched, key))) > 1e-6:
                raise ValueError(f"manifest models.{name}.schedules[{steps}].{key} differs from emdm.sampler.schedule")
    sess = step_session(onnx_path)
    rng = np.random.default_rng(int.from_bytes(name.encode(), 'little') % (2 ** 32))  # stable per model name
    cond, cond_desc = condition_vector(name, entry, manifest, models_dir, rng)
    C = cond.shape[0]
    L = FRAMES
    step_x = rng.standard_normal((1, L, D)).astype(np.float32)
    step_z = rng.standard_normal((1, Z)).astype(np.float32)
    step_t = np.array([sched.time[steps // 2]], np.float32)
    step_x0 = run_step(sess, step_x, step_z, cond[None], step_t)
    seed = 1000 + len(name)
    x_T, zs, epss = draw_noise(np.random.default_rng(seed), steps, L, D, Z, sched, objective)
    norm = root_norm_of(mean, std)
    x = reference_sample(sess, x_T, zs, epss, cond, guidance, sched, objective, gmin, sigma, cap, norm)
    # the fixture run must be what the Python pipeline itself samples with this seed
    settings = SamplingSettings(method_of(objective), steps, guidance, gmin, sigma, cap, norm if cap else None,
                                z_dim=Z, feature_dim=D)
    x_py = sample_features(onnx_step(onnx_path), cond, L, settings, seed)[0]
    # float32 rounding (the reference updates x in float64) grows over the steps, amplified by guidance:
    # compare relative to the motion's scale
    scale = max(1.0, float(np.max(np.abs(x))))
    diff = float(np.max(np.abs(x_py - x)))
    print(f"{name}: reference vs sample_features max abs diff {diff:.2e}, scale {scale:.2f}")
    if diff > 1e-4 * scale:
        raise AssertionError(f"fixtures {name}: reference_sample differs from emdm.sampler.sample_features by "
                             f"{diff:.2e} (more than 1e-4 × {scale:.2f}, the motion's largest value)")
    feats = (x * std + mean).astype(np.float32)
    joints = recover_joints(feats).astype(np.float32)
    arrays = {"step_x_t": step_x, "step_z": step_z, "step_cond": cond[None], "step_t": step_t, "step_x0": step_x0,
              "cond": cond, **noise_arrays(x_T, zs, epss), "final_x": x, "features": feats, "joints": joints}
    case = f"model-{name}"
    meta = {"model": name, "onnx": onnx_rel, "sha256": meta_file["sha256"], "objective": objective,
            "sampler": "ddim" if objective == "diffusion" else "ddgan", "frames": L, "featureDim": D, "zDim": Z,
            "condDim": C, "condition": cond_desc, "seed": seed, "steps": steps, "guidance": guidance,
            **({"guidanceMinTime": gmin} if gmin else {}), **({"x0Smoothing": sigma} if sigma else {}),
            **({"speedCap": cap} if cap else {}), "schedule": schedule_meta(sched)}
    write_case(out_dir, case, meta, arrays)
    return {"case": case, "model": name, "sha256": meta_file["sha256"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.fixtures", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PARITY_DIR)
    ap.add_argument("--models-dir", type=Path, default=paths.MODELS_DIR)
    ap.add_argument("--only", nargs="*", choices=["tiny", "tiny-ddim", "recover", "models"], default=None)
    args = ap.parse_args(argv)
    want = set(args.only or ["tiny", "tiny-ddim", "recover", "models"])
    out: Path = args.out
    index_path = out / "index.json"
    index = json.loads(index_path.read_text()) if index_path.exists() else {"cases": {}}
    if "tiny" in want:
        index["cases"]["tiny"] = make_tiny(out)
        print(f"fixtures: wrote {out / 'tiny.json'}")
    if "tiny-ddim" in want:
        index["cases"]["tiny-ddim"] = make_tiny_ddim(out)
        print(f"fixtures: wrote {out / 'tiny-ddim.json'}")
    if "recover" in want:
        try:
            index["cases"]["recover"] = make_recover(out)
            print(f"fixtures: wrote {out / 'recover.json'} from {index['cases']['recover']['source']}")
        except FileNotFoundError as e:
            print(f"fixtures: recover skipped: {e}", file=sys.stderr)
    if "models" in want:
        manifest = mf.load(args.models_dir, missing_ok=True)
        for key in [k for k in index["cases"] if k.startswith("model-")]:
            if key[len("model-"):] not in manifest["models"]:
                del index["cases"][key]
                for ext in (".json", ".bin"):
                    (out / f"{key}{ext}").unlink(missing_ok=True)
        if not manifest["models"]:
            print(f"fixtures: no models in {args.models_dir / 'manifest.json'}; model parity skipped", file=sys.stderr)
        for name, entry in manifest["models"].items():
            index["cases"][f"model-{name}"] = make_model(out, name, entry, manifest, args.models_dir)
            print(f"fixtures: wrote {out / f'model-{name}.json'}")
    out.mkdir(parents=True, exist_ok=True)
    index_path.write_text(json.dumps(index, indent=1, sort_keys=True) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
