"""Export one denoising step of a trained generator to ONNX, with a browser variant, mean/std and a
manifest entry (docs/ARCHITECTURE.md "ONNX step model", docs/MANIFEST.md).

    python -m emdm.export --ckpt runs/t2m-web/ckpt.pt --name emdm-t2m-web            # → public/models/
    python -m emdm.export --ckpt ... --name ... --out /tmp/models --variants int8,fp16

The exported weights are the EMA weights. Export uses the dynamo exporter (opset 18) with an example
batch of 2 so batch and length stay dynamic; parity against PyTorch is checked on several batch sizes and
lengths and the export fails if the max abs error exceeds ``--tolerance`` (1e-4).

The checkpoint is read by ``emdm.model.open`` (weights_only=True). A checkpoint that cannot be used, an ``--out``
that cannot be written, an unknown ``--variants`` entry or a malformed manifest in ``--out`` is answered with one
line naming it and exit status 2, before anything is exported.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import time
from pathlib import Path

import numpy as np
import torch

from emdm import manifest as mf
from emdm import paths
from emdm.checkpoints import first_non_finite, portable_meta, save_weights_file
from emdm.manifest import ManifestError
from emdm.model.generator import Generator
from emdm.model.open import INPUTS, ModelError, load_generator as open_generator, ort_session
from emdm.model.quiet import quiet_onnx_tools
from emdm.sampler.schedule import DEFAULT_STEPS, make_schedule
from emdm.outdir import OutputRefused, check_writable

PARITY_CASES = ((1, 1), (1, 60), (2, 17), (3, 120), (2, 196))
NAME = re.compile(r"[A-Za-z0-9._-]{1,100}")     # a model id: a file stem in --out and the manifest key
# the training flags a manifest entry records (its "training"."flags"; a flag the checkpoint predates is null)
TRAINING_FLAGS = ("geo_weight", "geo_weight_t1", "lambda_geo", "w_pos", "w_vel", "w_foot", "w_bone", "lr_g", "lr_d",
                  "lr_min", "warmup", "ema", "d_cond", "d_width", "cond_drop", "random_crop", "min_frames", "objective",
                  "steps")


class ExportError(RuntimeError):
    pass


def check_name(name: str) -> str:
    """A model id (``--name``): letters, digits, '.', '_', '-' (no path separator), not '.' or '..'."""
    if not NAME.fullmatch(name) or name in (".", ".."):
        raise ExportError(f"--name {name!r}: a model id is 1-100 letters, digits, '.', '_' or '-' (no '/' or '\\', "
                          "not '.' or '..'), e.g. emdm-t2m-web")
    return name


def check_finite_weights(G: Generator, ckpt: Path | str) -> None:
    """ExportError naming the first weight that holds NaN/Infinity: a broken model is never exported."""
    bad = first_non_finite(G)
    if bad is not None:
        raise ExportError(f"{ckpt}: weight {bad!r} holds NaN/Infinity; refusing to export a broken model (export an "
                          "earlier checkpoint)")


def load_generator(ckpt_path: Path | str, weights: str = "G_ema") -> tuple[Generator, dict, dict]:
    """(generator in eval mode with the chosen weights, meta, checkpoint summary), read by the one opener of models
    (``emdm.model.open.load_generator``, weights_only=True); a file that cannot be used is an ExportError."""
    try:
        return open_generator(ckpt_path, weights)
    except ModelError as e:
        raise ExportError(str(e)) from None


def example_inputs(G: Generator, batch: int, length: int, seed: int = 0, padded: bool = True) -> tuple[torch.Tensor, ...]:
    g = torch.Generator().manual_seed(seed)
    x = torch.randn(batch, length, G.feature_dim, generator=g)
    z = torch.randn(batch, G.z_dim, generator=g)
    c = torch.randn(batch, G.cond_dim, generator=g)
    t = torch.rand(batch, generator=g) * 0.999 + 0.001
    mask = torch.ones(batch, length)
    if padded and batch > 1 and length > 2:
        mask[-1, length // 2:] = 0.0           # one padded sequence in the batch
    return x, z, c, t, mask


def export_onnx(G: Generator, path: Path | str, opset: int = 18) -> Path:
    """Dynamo export of G's forward (one denoising step) with dynamic batch and length; one self-contained file."""
    import onnx

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    G = G.eval()
    ex = example_inputs(G, 2, 64)                  # batch ≥ 2, or the batch dimension gets baked in
    batch = torch.export.Dim("batch", min=1, max=1024)
    frames = torch.export.Dim("frames", min=1, max=G.max_frames)
    dyn = {"x_t": {0: batch, 1: frames}, "z": {0: batch}, "cond": {0: batch}, "t": {0: batch},
           "mask": {0: batch, 1: frames}}
    with quiet_onnx_tools():
        prog = torch.onnx.export(G, ex, dynamo=True, opset_version=opset, input_names=INPUTS, output_names=["x0"],
                                 dynamic_shapes=dyn, optimize=True, verbose=False)
    tmp = path.with_name(path.name + ".tmp")
    prog.save(str(tmp))
    model = onnx.load(str(tmp))                    # inline any external data → one file
    for f in tmp.parent.glob(tmp.name + "*.data"):
        f.unlink()
    tmp.unlink()
    model.doc_string = "EMDM generator: one denoising step x0 = G(x_t, z, cond, t, mask)"
    onnx.save(model, str(path), save_as_external_data=False)
    onnx.checker.check_model(str(path))
    return path


def parity(G: Generator, onnx_path: Path | str, cases=PARITY_CASES) -> dict[str, float]:
    """Max abs difference ONNX vs PyTorch per (batch, length) case."""
    sess = ort_session(onnx_path)
    out = {}
    for i, (b, length) in enumerate(cases):
        ex = example_inputs(G, b, length, seed=100 + i)
        with torch.no_grad():
            ref = G(*ex).numpy()
        got = sess.run(["x0"], {n: v.numpy() for n, v in zip(INPUTS, ex)})[0]
        out[f"{b}x{length}"] = float(np.abs(got - ref).max())
    return out


def make_int8(src: Path, dst: Path) -> Path:
    """Dynamic int8 quantisation of the MatMul/Gemm weights (per channel), 7-bit weight range: x86 CPUs
    without VNNI multiply u8×s8 pairs into saturating int16 sums (AVX2 vpmaddubsw), which full-range weights
    overflow (measured on an AVX2-only EPYC: max error / output std 1.2–3.0 instead of ~0.3)."""
    from onnxruntime.quantization import QuantType, quantize_dynamic

    with quiet_onnx_tools():
        quantize_dynamic(str(src), str(dst), weight_type=QuantType.QInt8, per_channel=True, reduce_range=True,
                         op_types_to_quantize=["MatMul", "Gemm"])
    return dst


def make_fp16(src: Path, dst: Path, min_elements: int = 1024) -> Path:
    """Half the download: large float32 weights stored as float16 and cast back to float32 in the graph
    (compute stays float32, so every backend runs it; ORT folds the casts at load time)."""
    import onnx
    from onnx import TensorProto, helper, numpy_helper

    model = onnx.load(str(src))
    g = model.graph
    casts, keep = [], []
    for init in g.initializer:
        if init.data_type == TensorProto.FLOAT and int(np.prod(init.dims)) >= min_elements:
            arr = numpy_helper.to_array(init).astype(np.float16)
            half = numpy_helper.from_array(arr, init.name + "__fp16")
            keep.append(half)
            casts.append(helper.make_node("Cast", [half.name], [init.name], to=TensorProto.FLOAT,
                                          name=init.name + "__cast"))
        else:
            keep.append(init)
    del g.initializer[:]
    g.initializer.extend(keep)
    nodes = list(g.node)
    del g.node[:]
    g.node.extend(casts + nodes)
    onnx.checker.check_model(model)
    onnx.save(model, str(dst), save_as_external_data=False)
    return dst


def variant_error(G: Generator, path: Path, cases=((1, 60), (2, 196))) -> float:
    """Max abs error of a quantised variant relative to PyTorch, divided by the output's std."""
    sess = ort_session(path)
    worst = 0.0
    for i, (b, length) in enumerate(cases):
        ex = example_inputs(G, b, length, seed=200 + i)
        with torch.no_grad():
            ref = G(*ex).numpy()
        got = sess.run(["x0"], {n: v.numpy() for n, v in zip(INPUTS, ex)})[0]
        worst = max(worst, float(np.abs(got - ref).max() / (ref.std() + 1e-8)))
    return worst


def time_step(path: Path | str, cond_dim: int, frames: int = 196, batch: int = 1, threads: int = 1,
              repeats: int = 10) -> float:
    """Median ms of one ORT CPU step (random inputs)."""
    sess = ort_session(path, threads)
    rng = np.random.default_rng(0)
    feed = {"x_t": rng.standard_normal((batch, frames, 263), dtype=np.float32),
            "z": rng.standard_normal((batch, 64), dtype=np.float32),
            "cond": rng.standard_normal((batch, cond_dim), dtype=np.float32),
            "t": np.full((batch,), 0.5, np.float32), "mask": np.ones((batch, frames), np.float32)}
    sess.run(None, feed)
    ts = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        sess.run(None, feed)
        ts.append((time.perf_counter() - t0) * 1000)
    return float(np.median(ts))


def write_meanstd(mean: np.ndarray, std: np.ndarray, path: Path) -> Path:
    """float32 little-endian: mean[263] then std[263]."""
    arr = np.concatenate([np.asarray(mean, "<f4"), np.asarray(std, "<f4")])
    if arr.shape != (526,):
        raise ExportError(f"mean/std must be 263 values each, got {np.shape(mean)} and {np.shape(std)}")
    path.write_bytes(arr.astype("<f4").tobytes())
    return path


def manifest_entry(name: str, meta: dict, summary: dict, files: dict[str, str], extra: dict) -> dict:
    steps = list(meta["supported_steps"])
    default = DEFAULT_STEPS if DEFAULT_STEPS in steps else max(steps)
    task = meta["task"]
    entry = {
        "task": task,
        "objective": meta.get("objective", "ddgan"),
        "condition": meta["condition"],
        "onnx": files["onnx"],
        "variants": {k: v for k, v in files.items() if k not in ("onnx", "meanStd", "weights")},
        **({"defaultVariant": extra["defaultVariant"]} if "defaultVariant" in extra else {}),
        **({"trainingWeights": files["weights"]} if "weights" in files else {}),
        "meanStd": files["meanStd"],
        "zDim": meta["generator"]["z_dim"], "featureDim": meta["generator"]["feature_dim"], "fps": 20,
        "maxFrames": meta["generator"]["max_frames"],
        "guidance": extra.get("guidance", 2.5), "defaultSteps": default, "supportedSteps": steps,
        "schedules": {str(T): make_schedule(T).as_manifest() for T in steps},
        "preset": {k: meta["generator"]["preset"][k] for k in ("d", "layers", "heads", "ff")},
        "training": {"steps": summary["steps"], "wallSeconds": round(summary["wall_s"], 1),
                     "dataset": meta["dataset"], "clips": meta.get("clips"), "device": meta["device"],
                     "batch": meta.get("batch"), "losses": summary["losses"],
                     **({"continuedFrom": meta["init"]} if meta.get("init") else {}),
                     "flags": {k: meta["args"].get(k) for k in TRAINING_FLAGS}},
        "files": sorted(files.values()),
    }
    entry.update(extra)
    return entry


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m emdm.export", description=__doc__.split("\n\n")[0])
    p.add_argument("--ckpt", type=Path, required=True)
    p.add_argument("--name", required=True, help="model name, e.g. emdm-t2m-web (file stem and manifest key)")
    p.add_argument("--out", type=Path, default=paths.MODELS_DIR, help="models folder (holds manifest.json)")
    p.add_argument("--weights", default="G_ema", choices=["G_ema", "G"])
    p.add_argument("--variants", default="int8,fp16", help="comma list of int8, fp16 (empty for none)")
    p.add_argument("--tolerance", type=float, default=1e-4)
    p.add_argument("--no-manifest", action="store_true")
    p.add_argument("--guidance", type=float, default=None, metavar="W",
                   help="the entry's guidance: classifier-free guidance scale the sampler uses unless asked otherwise "
                        "(choose it with the realism and coverage benchmarks' --guidance; default: keep the manifest's, "
                        "else 2.5)")
    p.add_argument("--guidance-min-time", type=float, default=None, metavar="T",
                   help="the entry's guidanceMinTime: guide only steps whose time is above T (choose T from "
                        "`python -m emdm.model.bench_steps --interval`; 0 = every step; default: keep the manifest's)")
    p.add_argument("--x0-smoothing", type=float, default=None, metavar="SIGMA",
                   help="the entry's x0Smoothing: smooth x̂0 along time (σ frames) at every step but the last (0 = off; "
                        "default: keep the manifest's)")
    p.add_argument("--default-variant", default=None, metavar="V",
                   help="the entry's defaultVariant: the file the page and createGenerator run unless asked otherwise "
                        "(one of --variants, or fp32); set it only where the variant's quality matches fp32 (docs/MODELS.md "
                        "'Speed in the browser'); default: keep the manifest's")
    p.add_argument("--bench", action="store_true", help="also time one step (196 frames) on ORT CPU, 1 and 2 threads")
    p.add_argument("--ship-weights", action="store_true",
                   help="also ship the EMA generator as float16 PyTorch tensors (<name>.weights.f16.pt, ~8 MB), so "
                        "training can continue from the shipped model: python -m emdm.train --init-weights FILE")
    return p


VARIANT_MAKERS = {"int8": make_int8, "fp16": make_fp16}


def main(argv: list[str] | None = None) -> int:
    """The CLI: an unusable --ckpt, --out or --variants is one line naming it, exit status 2."""
    a = build_parser().parse_args(argv)
    try:
        return run(a)
    except (ExportError, OutputRefused, ManifestError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


def run(a: argparse.Namespace) -> int:
    variants = [s.strip() for s in a.variants.split(",") if s.strip()]
    unknown = [v for v in variants if v not in VARIANT_MAKERS]
    check_name(a.name)
    if not (np.isfinite(a.tolerance) and a.tolerance > 0):
        raise ExportError(f"--tolerance must be a finite error > 0, got {a.tolerance:g}")
    if unknown:
        raise ExportError(f"--variants: unknown {', '.join(map(repr, unknown))}; use a comma list of "
                          f"{', '.join(VARIANT_MAKERS)} (empty for none)")
    if a.guidance is not None and not (np.isfinite(a.guidance) and 0 <= a.guidance <= 20):
        raise ExportError(f"--guidance must be a finite scale in 0..20 (1 = plain conditional), got {a.guidance:g}")
    g = a.guidance_min_time
    if g is not None and not (np.isfinite(g) and g >= 0):
        raise ExportError(f"--guidance-min-time must be a finite time ≥ 0 (0 = guide every step), got {g:g}")
    if a.x0_smoothing is not None and not (np.isfinite(a.x0_smoothing) and 0 <= a.x0_smoothing <= mf.MAX_X0_SMOOTHING):
        raise ExportError(f"--x0-smoothing must be a finite σ ≥ 0 in frames (0 = off), got {a.x0_smoothing:g} "
                          f"(at most {mf.MAX_X0_SMOOTHING:g})")
    dv = a.default_variant
    if dv is not None and dv != "fp32" and dv not in variants:
        raise ExportError(f"--default-variant {dv!r} is not among the exported files: use fp32 or one of --variants "
                          f"({', '.join(variants) or 'none'})")
    out = check_writable(a.out, folder=True)               # before the checkpoint is read or anything exported
    if not a.no_manifest:
        mf.load(out, missing_ok=True)                      # a malformed manifest there is found now, not at the end
    G, meta, summary = load_generator(a.ckpt, a.weights)
    check_finite_weights(G, a.ckpt)
    out.mkdir(parents=True, exist_ok=True)
    stage = out / f".{a.name}.export.tmp"          # the files are made here, moved into --out once all pass
    shutil.rmtree(stage, ignore_errors=True)
    stage.mkdir()
    try:
        files, extra = make_files(a, G, meta, summary, stage, variants)
        for f in sorted(stage.iterdir()):
            f.replace(out / f.name)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    if not a.no_manifest:
        write_entry(a, out, meta, summary, files, extra)
    return 0


def make_files(a: argparse.Namespace, G: Generator, meta: dict, summary: dict, out: Path,
               variants: list[str]) -> tuple[dict, dict]:
    """The model's files in ``out`` (ONNX, variants, mean/std, weights), each checked against PyTorch: (files by
    role, the manifest entry's extra fields). A NaN error fails every check (``not err <= tolerance``)."""
    onnx_path = export_onnx(G, out / f"{a.name}.onnx")
    par = parity(G, onnx_path)
    worst = float(np.max(list(par.values())))       # NaN wins (the builtin max may skip it)
    print(f"{a.name}.onnx: {onnx_path.stat().st_size / 1e6:.2f} MB, parity max abs err {worst:.2e} {par}")
    if not worst <= a.tolerance:
        raise ExportError(f"{a.name}.onnx: ONNX differs from PyTorch by {worst:.3g}, not ≤ --tolerance {a.tolerance} "
                          f"({par}); nothing written")
    files = {"onnx": onnx_path.name}
    extra: dict = {"parityMaxAbsErr": float(f"{worst:.3g}")}
    var_err = {}
    for v in variants:
        dst = out / f"{a.name}.{v}.onnx"
        VARIANT_MAKERS[v](onnx_path, dst)
        var_err[v] = variant_error(G, dst)
        files[v] = dst.name
        print(f"{dst.name}: {dst.stat().st_size / 1e6:.2f} MB, max abs err / output std {var_err[v]:.3g}")
        if not np.isfinite(var_err[v]):
            raise ExportError(f"{dst.name}: the {v} variant's error is {var_err[v]}; nothing written")
    if var_err:
        extra["variantRelErr"] = {k: float(f"{v:.3g}") for k, v in var_err.items()}
    ms_path = write_meanstd(np.array(meta["mean"]), np.array(meta["std"]), out / f"{a.name}.meanstd.f32")
    files["meanStd"] = ms_path.name
    if a.ship_weights:
        dst = out / f"{a.name}.weights.f16.pt"
        save_weights_file(dst, G.state_dict(), step=summary["steps"], wall=summary["wall_s"], meta=portable_meta(meta),
                          last_losses=summary["losses"], dtype="float16")
        files["weights"] = dst.name
        print(f"{dst.name}: {dst.stat().st_size / 1e6:.2f} MB (float16 EMA weights for --init-weights)")
    if a.bench:
        bench = {}
        for key, path in [("fp32", onnx_path)] + [(v, out / files[v]) for v in var_err]:
            for th in (1, 2):
                bench[f"{key}_{th}t"] = round(time_step(path, G.cond_dim, threads=th), 1)
        extra["ortCpuMsPerStep196"] = bench
        print("ORT CPU ms/step (196 frames, batch 1):", bench)
    return files, extra


def write_entry(a: argparse.Namespace, out: Path, meta: dict, summary: dict, files: dict, extra: dict) -> None:
    """The manifest entry models.<name> (keeping the earlier entry's guidance, guidanceMinTime, x0Smoothing, speedCap,
    defaultVariant unless given)."""
    var_err = extra.get("variantRelErr", {})
    earlier = mf.load(out, missing_ok=True)["models"].get(a.name, {})   # a re-export keeps what was chosen for it
    extra["guidance"] = float(earlier.get("guidance", 2.5) if a.guidance is None else a.guidance)
    gmin = earlier.get("guidanceMinTime", 0.0) if a.guidance_min_time is None else a.guidance_min_time
    if gmin:
        extra["guidanceMinTime"] = float(gmin)
    sigma = earlier.get("x0Smoothing", 0.0) if a.x0_smoothing is None else a.x0_smoothing
    if sigma:
        extra["x0Smoothing"] = float(sigma)
    if earlier.get("speedCap"):         # chosen by the realism benchmark for this model (docs/MODELS.md)
        extra["speedCap"] = float(earlier["speedCap"])
    dv = a.default_variant
    if dv is None:       # the earlier variant, while that file is still exported
        dv = earlier.get("defaultVariant")
        dv = dv if dv in var_err else None
    if dv and dv != "fp32":
        extra["defaultVariant"] = dv
    entry = manifest_entry(a.name, meta, summary, files, extra)
    mf.update_entry("models", a.name, entry, out)
    print(f"manifest: models.{a.name} written to {out / mf.MANIFEST_NAME}")


if __name__ == "__main__":
    raise SystemExit(main())
