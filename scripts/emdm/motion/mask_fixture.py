"""The inpainting parity fixture: the tiny step model sampled by ``emdm.sampler.sample_features`` with a known
motion and a keep mask (frames 0..5 of everything, plus the legs on every frame), which the TypeScript sampler
must reproduce with the same noise (tests/unit/coreMask.test.ts, ≤ 1e-4), and the feature groups' channels,
which ``src/sampler/mask.ts`` must compute alike:

    .venv/bin/python -m emdm.motion.mask_fixture        # writes tests/fixtures/parity/tiny-mask.{json,bin}

Arrays: ``known`` (16, 263) normalised (the first 16 frames of the recover fixture's real clip through
tiny.meanstd.f32), ``keep`` (16, 263) 0/1, ``cond``; the DDGAN run (4 steps, guidance 2.5): ``x_T``, ``z_k``,
``eps_k``, ``final_x``; the DDIM run (5 steps, guidance 2.5): the same keys prefixed ``ddim_``.
tests/python/test_fixtures_current.py regenerates it and compares (``emdm.fixture_drift``: the fixture must be current).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emdm import paths
from emdm.fixtures import TINY_COND_DIM, draw_noise, noise_arrays, write_case
from emdm.model.open import onnx_step
from emdm.motion.ik_fixture import read_case_array
from emdm.motion.mask import GROUP_JOINTS, GROUPS, group_channels, keep_mask, parse_keep
from emdm.sampler import SamplingSettings, sample_features
from emdm.sampler.schedule import make_schedule
from emdm.sampler.settings import method_of

PARITY_DIR = paths.FIXTURES_DIR / "parity"
NAME = "tiny-mask"
FRAMES = 16
SPECS = ("frames:0-5", "group:legs")
RUNS = {"ddgan": ("", "ddgan", 4, 5151), "ddim": ("ddim_", "diffusion", 5, 6262)}   # (key prefix, objective, steps, seed)
GUIDANCE = 2.5


def known_motion(parity_dir: Path = PARITY_DIR) -> np.ndarray:
    """(16, 263) normalised: a real clip's features through the tiny model's mean/std."""
    feats = read_case_array(parity_dir, "recover", "features")[:FRAMES].astype(np.float32)
    ms = np.fromfile(parity_dir / "tiny.meanstd.f32", "<f4")
    return ((feats - ms[:263]) / ms[263:]).astype(np.float32)


def make(out_dir: Path = PARITY_DIR, parity_dir: Path = PARITY_DIR) -> Path:
    """Sample the committed ``tiny-step.onnx`` (in ``parity_dir``) with the mask and write ``tiny-mask.*``."""
    step = onnx_step(parity_dir / "tiny-step.onnx")
    known = known_motion(parity_dir)
    keep = keep_mask(FRAMES, [parse_keep(s) for s in SPECS])
    cond = np.random.default_rng(20251124).standard_normal(TINY_COND_DIM).astype(np.float32)
    arrays: dict[str, np.ndarray] = {"known": known, "keep": keep, "cond": cond}
    runs = {}
    for name, (prefix, objective, steps, seed) in RUNS.items():
        settings = SamplingSettings(method_of(objective), steps, GUIDANCE, known=known, keep=keep)
        x = sample_features(step, cond, FRAMES, settings, seed)[0]
        kept = keep.astype(bool)
        if not np.array_equal(x[kept], known[kept]):
            raise AssertionError(f"mask_fixture: {objective} run does not return the known motion on kept entries")
        noise = noise_arrays(*draw_noise(np.random.default_rng(seed), steps, FRAMES, 263, 64, make_schedule(steps),
                                         objective))
        arrays.update({prefix + k: v for k, v in noise.items()})
        arrays[prefix + "final_x"] = x
        runs[name] = {"prefix": prefix, "objective": objective, "steps": steps, "seed": seed}
    meta = {"model": "tiny-step.onnx", "frames": FRAMES, "featureDim": 263, "zDim": 64, "condDim": TINY_COND_DIM,
            "guidance": GUIDANCE, "specs": list(SPECS), "runs": runs,
            "groups": {g: group_channels(g) for g in GROUPS}, "groupJoints": {g: list(j) for g, j in GROUP_JOINTS.items()}}
    return write_case(out_dir, NAME, meta, arrays)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.motion.mask_fixture", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PARITY_DIR)
    path = make(ap.parse_args(argv).out)
    print(f"mask_fixture: wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
