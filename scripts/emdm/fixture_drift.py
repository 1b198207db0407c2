"""Is a regenerated parity fixture the committed one, up to what another CPU changes? (tests/fixtures/parity/)

The committed fixtures were made on one CPU. onnxruntime's kernels follow the CPU's instruction set (AVX2,
AVX-512, …; no switch turns that off), so on another CPU every model output differs in its last bits, and a
sampling chain amplifies that: guidance multiplies a conditional output's error by 2.5 at each step, later windows of a timeline start from
earlier ones, and recovering joints integrates heading and root velocity over the frames. A fixed tolerance is
either too tight for another CPU or too loose to see a change in our code, so each array gets its own:

    tolerance = max(ARRAY_RTOL, MARGIN × AMPLIFICATION[case][array]) × the array's largest value (at least 1)

``AMPLIFICATION`` is measured: every model output of a regeneration multiplied by (1 + 1e-6 N(0, 1)) (``step_noise``,
4 to 8 float32 ulps, more than AVX2 and AVX-512 kernels differ by), the largest relative difference each array
shows against the clean regeneration, worst of ``SEEDS`` seeds. Arrays a model output never reaches (inputs, noise,
metadata-like arrays) keep ``ARRAY_RTOL``. Re-measure after a change to a fixture writer or the sampler:

    .venv/bin/python -m emdm.fixture_drift              # prints AMPLIFICATION as measured on this CPU
    .venv/bin/python -m emdm.fixture_drift --check      # regenerate every case and compare with the committed one

tests/python/test_fixtures_current.py runs the comparison for every case, checks the table still covers today's
amplification, and shows that one schedule coefficient × 1.001 (``moved_schedule``) is reported as drift.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import hashlib
import json
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Callable, Iterator

import numpy as np

from emdm import fixtures as fx
from emdm import manifest as mf
from emdm import paths
from emdm.sampler import schedule as schedule_mod
from emdm.motion import edit_fixture, live_fixture, mask_fixture

COMMITTED = fx.PARITY_DIR
ARRAY_RTOL = 3e-5          # float32 arrays no chain amplifies (one model call, inputs, closed-form arrays)
META_RTOL = 1e-9           # schedule coefficients etc., float64 in JSON
NOISE = 1e-6               # relative noise of step_noise
SEEDS = (1, 2, 3)
MARGIN = 2                 # tolerance ÷ the measured amplification of NOISE (see AMPLIFICATION)

# Largest relative difference (÷ the array's largest value, at least 1) that NOISE in every model output makes,
# worst of SEEDS; measured with `python -m emdm.fixture_drift` on an AMD EPYC (AVX-512), 2 significant digits rounded
# up. Noise in 1e-6 → out 2e-6…5e-6 for one step or a short chain; 9e-6…1.5e-4 for the shipped models' 10 guided
# steps (DDIM's the most); 3.4e-4 for tiny-edit's joints (three timeline windows, each continuing the one before,
# then recover_joints integrating 48 frames' heading and root velocity at up to 17 m from the origin; re-measured
# at 2.3e-4 before a seam's last kept frame took the step before it: every later window's context changed).
# How big is a real CPU's difference? tiny-edit, committed from an AVX2 machine and regenerated on the AVX-512 one,
# differs by 0.04–0.21 of these (its joints by up to 3.4e-5 of their largest value); the diffusion-t2m-web case,
# once committed from another CPU, differed from the AVX-512 run by 1.3e-5 (0.09 of 1.5e-4): another CPU is about
# 2e-7 relative per model output, and MARGIN 2 leaves about 10× that. On the AMD EPYC ATEN_CPU_CAPABILITY
# (avx2, default), OPENBLAS_CORETYPE (Haswell, Sandybridge), NPY_DISABLE_CPU_FEATURES="X86_V4 AVX512_ICL", 1 or 2
# OMP/OpenBLAS threads and 2 onnxruntime threads leave every array bit for bit the same: only onnxruntime's
# kernels, which follow the instruction set, move them.
AMPLIFICATION: dict[str, dict[str, float]] = {
    "tiny": {"final_x": 4.8e-6, "final_x_cap": 4.8e-6, "final_x_smooth": 3.8e-6, "step_x0": 2.6e-6, "final_x_interval": 2.3e-6,
             "final_x_uncond": 2.0e-6},
    "tiny-ddim": {"final_x": 4.3e-6, "final_x_uncond": 3.4e-6},
    "tiny-mask": {"final_x": 5.0e-6, "ddim_final_x": 4.3e-6},
    "tiny-edit": {"timeline_joints": 3.4e-4, "body_joints": 3.2e-4, "inbetween_joints": 3.2e-4, "loop_in_place_joints": 3.0e-4,
                  "loop_joints": 2.5e-4, "loop_long_joints": 2.2e-4, "regen_joints": 1.7e-4,
                  "loop_long_features": 1.6e-5, "inbetween_features": 8.0e-6, "loop_features": 7.9e-6,
                  "timeline_features": 7.6e-6, "body_features": 7.6e-6, "regen_features": 6.3e-6, "ease_out": 6.2e-6},
    "tiny-live": {"played_joints": 4.7e-4, "buffer_features": 6.6e-6},   # played: the page decode since live-soak
    "model-emdm-t2m-web": {"features": 2.8e-5, "final_x": 2.2e-5, "joints": 1.3e-5, "step_x0": 2.1e-6,
                           "step_cond": 1.2e-7, "cond": 1.2e-7},       # cond: the text encoder's output
    "model-emdm-a2m-web": {"final_x": 9.2e-6, "features": 3.8e-6, "step_x0": 2.8e-6, "joints": 1.5e-6},
    "model-diffusion-t2m-web": {"final_x": 1.5e-4, "features": 8.7e-5, "joints": 2.1e-6, "step_x0": 1.3e-6,
                                "step_cond": 1.2e-7, "cond": 1.2e-7},
}


# ----------------------------------------------------------------------------------------- regenerating a case

def _tiny_dir(out: Path) -> Path:
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(COMMITTED / "tiny-step.onnx", out / "tiny-step.onnx")
    return out


def _regen_tiny(out: Path) -> None:
    fx.make_tiny(_tiny_dir(out), export=False)


def _regen_tiny_ddim(out: Path) -> None:
    fx.make_tiny_ddim(_tiny_dir(out))


def _regen_mask(out: Path) -> None:
    mask_fixture.make(out)


def _regen_edit(out: Path) -> None:
    edit_fixture.make(out)


def _regen_live(out: Path) -> None:
    live_fixture.make(out)


def shipped_models() -> dict[str, dict]:
    """The manifest's models (name → entry); none when public/models has no readable manifest."""
    try:
        return dict(mf.load(paths.MODELS_DIR, missing_ok=True)["models"])
    except mf.ManifestError:
        return {}


def _regen_model(name: str, check_schedule: bool = True) -> Callable[[Path], None]:
    def regen(out: Path) -> None:
        manifest = mf.load(paths.MODELS_DIR)
        entry = manifest["models"][name]
        if not check_schedule:     # the manifest's schedule would refuse a moved one before anything is sampled
            entry = {k: v for k, v in entry.items() if k != "schedules"}
        fx.make_model(out, name, entry, manifest, paths.MODELS_DIR)
    return regen


def regenerators(check_schedule: bool = True) -> dict[str, Callable[[Path], None]]:
    """Case name → a function that writes that case, made by today's code, into a folder."""
    out = {"tiny": _regen_tiny, "tiny-ddim": _regen_tiny_ddim, "tiny-mask": _regen_mask, "tiny-edit": _regen_edit,
           "tiny-live": _regen_live}
    out.update({f"model-{n}": _regen_model(n, check_schedule) for n in shipped_models()})
    return out


def regenerate(name: str, out: Path, check_schedule: bool = True) -> Path:
    """Write case ``name`` into ``out`` (created) with today's code; returns ``out``."""
    regen = regenerators(check_schedule).get(name)
    if regen is None:
        raise KeyError(f"no parity case {name!r}; cases: {', '.join(regenerators())}")
    out.mkdir(parents=True, exist_ok=True)
    with contextlib.redirect_stdout(sys.stderr):          # make_model prints its self-check
        regen(out)
    return out


# ----------------------------------------------------------------------------------------- what another CPU does

@contextlib.contextmanager
def step_noise(rel: float = NOISE, seed: int = 0) -> Iterator[None]:
    """Every float output of every onnxruntime session run inside multiplied by (1 + rel·N(0, 1)): what another
    CPU's kernels do to a model output, a little more. Like a CPU, a fixed function of the call: the noise is
    drawn from ``seed`` and the inputs other than ``x_t`` (time, z, condition) and every input's shape, so two paths
    that make the same call with x_t equal to rounding (``reference_sample`` and ``sample_features``, which the
    writers check against each other) see the same noise."""
    from onnxruntime.capi.onnxruntime_inference_collection import Session

    real = Session.run

    def noisy(self, output_names, input_feed, *a, **k):
        outs = real(self, output_names, input_feed, *a, **k)
        h = hashlib.sha256(str(seed).encode())
        for name in sorted(input_feed):
            v = np.ascontiguousarray(input_feed[name])
            h.update(f"{name}{v.shape}{v.dtype}".encode())
            if name != "x_t":
                h.update(v.tobytes())
        rng = np.random.default_rng(int.from_bytes(h.digest()[:8], "little"))
        return [(o * (1 + rel * rng.standard_normal(o.shape))).astype(o.dtype)
                if isinstance(o, np.ndarray) and o.dtype.kind == "f" else o for o in outs]

    Session.run = noisy
    try:
        yield
    finally:
        Session.run = real


@contextlib.contextmanager
def moved_schedule(key: str = "coef1", index: int = -1, factor: float = 1.001) -> Iterator[None]:
    """``make_schedule`` (everywhere emdm imported it) with one coefficient, ``Schedule.<key>[index]``, × ``factor``:
    a change in our code as small as a real one."""
    real = schedule_mod.make_schedule

    def moved(*a, **k):
        s = real(*a, **k)
        values = getattr(s, key).copy()
        if -len(values) <= index < len(values):     # a shorter schedule (fewer steps) keeps its values
            values[index] *= factor
        return dataclasses.replace(s, **{key: values})

    def emdm_modules(holding):
        return [m for m in list(sys.modules.values())
                if getattr(m, "__name__", "").startswith("emdm") and getattr(m, "make_schedule", None) is holding]

    for m in emdm_modules(real):
        m.make_schedule = moved
    try:
        yield
    finally:
        for m in emdm_modules(moved):      # those imported meanwhile too
            m.make_schedule = real


# ----------------------------------------------------------------------------------------- comparing

def read_case(folder: Path, name: str) -> tuple[dict, dict[str, np.ndarray]]:
    meta = json.loads((folder / f"{name}.json").read_text())
    raw = (folder / meta["bin"]).read_bytes()
    arrays = {}
    for key, a in meta["arrays"].items():
        n = int(np.prod(a["shape"], dtype=np.int64))
        arrays[key] = np.frombuffer(raw, "<f4", count=n, offset=a["offset"]).reshape(a["shape"])
    return meta, arrays


def scale_of(a: np.ndarray) -> float:
    return max(1.0, float(np.max(np.abs(a))) if a.size else 1.0)


def rel_diff(want: np.ndarray, got: np.ndarray) -> float:
    """Largest |want − got| ÷ want's largest value (at least 1)."""
    return float(np.max(np.abs(want - got))) / scale_of(want) if want.size else 0.0


def tolerance(case: str, key: str) -> float:
    """Relative tolerance of array ``key`` of ``case`` (÷ its largest value, at least 1)."""
    return max(ARRAY_RTOL, MARGIN * AMPLIFICATION.get(case, {}).get(key, 0.0))


def _meta_diffs(path: str, want, got) -> list[str]:
    if isinstance(want, dict) and isinstance(got, dict):
        out = [f"{path}.{k}: missing in the regenerated fixture" for k in want.keys() - got.keys()]
        out += [f"{path}.{k}: new in the regenerated fixture" for k in got.keys() - want.keys()]
        for k in sorted(want.keys() & got.keys()):
            out += _meta_diffs(f"{path}.{k}", want[k], got[k])
        return out
    if isinstance(want, list) and isinstance(got, list):
        if len(want) != len(got):
            return [f"{path}: {len(want)} entries committed, {len(got)} regenerated"]
        if all(isinstance(v, (int, float)) for v in want + got):
            w, g = np.asarray(want, float), np.asarray(got, float)
            bad = np.abs(w - g) > META_RTOL * np.maximum(1.0, np.abs(w))
            if bad.any():
                i = int(np.argmax(bad))
                return [f"{path}[{i}]: committed {want[i]!r}, regenerated {got[i]!r}"]
            return []
        return [d for i, (a, b) in enumerate(zip(want, got)) for d in _meta_diffs(f"{path}[{i}]", a, b)]
    if isinstance(want, float) or isinstance(got, float):
        if isinstance(want, (int, float)) and isinstance(got, (int, float)) and abs(want - got) <= META_RTOL * max(1.0, abs(want)):
            return []
    elif want == got:
        return []
    return [f"{path}: committed {want!r}, regenerated {got!r}"]


def compare_case(committed: Path, fresh: Path, name: str) -> list[str]:
    """What differs between the committed case ``name`` and the regenerated one beyond ``tolerance`` (empty: they
    match)."""
    want_meta, want = read_case(committed, name)
    got_meta, got = read_case(fresh, name)
    problems = _meta_diffs(name, {k: v for k, v in want_meta.items() if k != "arrays"},
                           {k: v for k, v in got_meta.items() if k != "arrays"})
    for key in want.keys() - got.keys():
        problems.append(f"{name}.bin {key}: committed, not regenerated")
    for key in got.keys() - want.keys():
        problems.append(f"{name}.bin {key}: regenerated, not in the committed file")
    for key in sorted(want.keys() & got.keys()):
        w, g = want[key], got[key]
        if w.shape != g.shape:
            problems.append(f"{name}.bin {key}: shape {list(w.shape)} committed, {list(g.shape)} regenerated")
            continue
        d, tol = rel_diff(w, g), tolerance(name, key)
        if not d <= tol:
            problems.append(f"{name}.bin {key}: max abs diff {d * scale_of(w):.3g} = {d:.3g} × {scale_of(w):.3g} (its "
                            f"largest value) > {tol:.3g} × it (another CPU moves it by up to {tol:.3g})")
    return problems


# ----------------------------------------------------------------------------------------- measuring

def amplification(name: str, work: Path, seeds=SEEDS, rel: float = NOISE) -> dict[str, float]:
    """Per array of case ``name``: the largest ``rel_diff`` between its clean regeneration and one with
    ``step_noise(rel, seed)``, worst over ``seeds`` (arrays that do not move are left out)."""
    clean = regenerate(name, work / "clean")
    _, base = read_case(clean, name)
    worst: dict[str, float] = {}
    for seed in seeds:
        with step_noise(rel, seed):
            noisy = regenerate(name, work / f"noise{seed}")
        _, arrays = read_case(noisy, name)
        for key, a in arrays.items():
            worst[key] = max(worst.get(key, 0.0), rel_diff(base[key], a))
    return {k: v for k, v in worst.items() if v > 0}


def _round_up(v: float) -> float:
    """Two significant digits, rounded up."""
    e = 10.0 ** (np.floor(np.log10(v)) - 1)
    return float(np.ceil(v / e - 1e-9) * e)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.fixture_drift", description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", action="store_true", help="regenerate every case and compare it with the committed one")
    ap.add_argument("--cases", nargs="*", default=None, help="only these cases (default: all)")
    args = ap.parse_args(argv)
    names = args.cases or list(regenerators())
    unknown = [n for n in names if n not in regenerators()]
    if unknown:
        print(f"fixture_drift: --cases: no parity case {', '.join(map(repr, unknown))}; "
              f"cases: {', '.join(regenerators())}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        if args.check:
            problems = [p for n in names for p in compare_case(COMMITTED, regenerate(n, Path(tmp) / n), n)]
            print("\n".join(problems) or f"fixture_drift: {len(names)} cases current")
            return 1 if problems else 0
        print(f"# relative difference out for {NOISE:g} relative noise in every model output (worst of seeds {SEEDS}):")
        for n in names:
            amp = amplification(n, Path(tmp) / n)
            body = ", ".join(f'"{k}": {_round_up(v):.1e}' for k, v in sorted(amp.items(), key=lambda kv: -kv[1]))
            print(f'    "{n}": {{{body}}},')
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
