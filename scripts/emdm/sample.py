"""Generate motions with an exported step model (the same loop the browser runs) or a checkpoint.

    python -m emdm.sample --model emdm-t2m-web --text "a person walks forward" --frames 120 --out out/walk
    python -m emdm.sample --model emdm-a2m-web --action walk --seed 3 --out out/a
    python -m emdm.sample --model emdm-t2m-web --uncond --steps 4 --out out/u
    python -m emdm.sample --ckpt runs/t2m/ckpt.pt --text "..." --out out/x      # PyTorch weights (EMA)
    python -m emdm.sample --model emdm-t2m-web --text "a person waves" --known out/walk.features.npy \
        --keep group:root,legs --out out/walk_wave       # keep the walk's legs and root, regenerate the rest
    python -m emdm.sample --model emdm-t2m-web --timeline "a person walks forward:4" --timeline "a person waves:3" \
        --timeline "a person sits down:3" --out out/long  # one motion, segment by segment (emdm.motion.edit)
    python -m emdm.sample --model emdm-t2m-web --known out/long.features.npy --inbetween 20-99 --text "a person jumps" --out out/j
    python -m emdm.sample --model emdm-t2m-web --known out/walk.features.npy --edit-upper --text "a person waves" --out out/ww
    python -m emdm.sample --model emdm-t2m-web --text "a person walks forward" --frames 80 --loop --in-place --out out/cycle

Writes <out>.npy (joints, (frames, 22, 3) metres; (n, frames, 22, 3) with --num > 1), <out>.features.npy
(de-normalised 263-d) and <out>.metres.bvh (one per sample, <out>_<i>.metres.bvh with --num > 1;
.centimetres.bvh with --bvh-units cm; metres are what Blender's BVH import expects at its scale 1.0).
The loop is docs/ARCHITECTURE.md "Sampling":
x_T ~ N(0, I); per step: fresh z, x0 = G(x, z, c, time[k], mask) (with guidance s ≠ 1, at the steps whose time is above
--guidance-min-time (the manifest's guidanceMinTime; default every step), one batched call
[c, 0] with the same x and z, x0 = x0_u + s·(x0_c − x0_u)); with --x0-smoothing σ (the manifest's x0Smoothing),
at every step but the last, x0 ← x0 with its pose channels smoothed along time (``smooth_pose``); x = coef1·x0 + coef2·x + sigma·ε. Random
draws come from numpy's default_rng(seed) in the order x_T, then per step z, then ε. Models trained with
``--objective diffusion`` are sampled with DDIM (η = 0, z = 0) on the same time grid.

Beyond one prompt (``emdm.motion.edit``, docs/ARCHITECTURE.md "Sampling with constraints"): ``--timeline
PROMPT:SECONDS`` (repeatable; segment k's seed is --seed + k) or ``--timeline-json F`` ([{"prompt", "seconds",
"seed"?}, ...]) makes one motion of up to 60 s; with ``--known``, ``--inbetween [A-B]`` regenerates frames A..B
(default: all but the first and last second), ``--edit-upper`` keeps the legs and root and regenerates the upper
body, ``--edit-lower`` the reverse, each from --text/--action; ``--loop`` makes --known (or the motion the prompt
gives) loop seamlessly, ``--in-place`` without root travel. They write one motion as above (--num 1).

Arguments are checked as the page checks them (the model's supportedSteps, a finite guidance ≥ 0,
--num ≥ 1, a known --variant, a uint32 seed, a writable --out) before any model runs; a bad one is
answered with one line naming it and exit status 2. A motion with NaN/Infinity is an error and is
never written. A prompt longer than the text encoder reads (the manifest's maxTokens) is cut there,
as in the page, with a "prompt truncated to N tokens" line on stderr.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Callable

import numpy as np

from emdm import manifest as mf
from emdm.eval import capabilities
from emdm.model.open import onnx_step, read_meanstd, torch_step  # noqa: F401 - the step functions, re-exported
from emdm.model.schedule import make_schedule
from emdm.motion.smooth import smooth_frames, smooth_pose  # noqa: F401 - x̂0 smoothing; re-exported

StepFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]


class SampleError(ValueError):
    """A bad argument or a bad result, said in one line (the CLI prints it and exits with status 2)."""


MAX_SEED = 2**32 - 1      # the page's seeds are uint32
# Bounds on what a flag can ask for (the manifest's own: emdm.manifest): steps, samples of one run, ORT threads,
# x̂0 smoothing σ in frames (a σ of 50 already averages a 196-frame clip almost flat).
MAX_STEPS = mf.MAX_STEPS
MAX_NUM = 256
MAX_THREADS = 256
MAX_X0_SMOOTHING = mf.MAX_X0_SMOOTHING


def check_x0_smoothing(sigma: float, name: str = "x0_smoothing") -> float:
    """σ in frames, in 0..MAX_X0_SMOOTHING (0 = off); anything else is a SampleError naming ``name``."""
    if (isinstance(sigma, bool) or not isinstance(sigma, (int, float, np.floating))
            or not (math.isfinite(sigma) and 0 <= sigma <= MAX_X0_SMOOTHING)):
        raise SampleError(f"{name} must be a finite σ ≥ 0 in frames (0 = off), got {sigma!r} (at most {MAX_X0_SMOOTHING:g})")
    return float(sigma)


def sample_features(step: StepFn, cond: np.ndarray, frames: int, steps: int = 10, guidance: float = 1.0,
                    seed: int = 0, num: int = 1, z_dim: int = 64, feature_dim: int = 263,
                    objective: str = "ddgan", known: np.ndarray | None = None,
                    keep: np.ndarray | None = None, guidance_min_time: float = 0.0,
                    x0_smoothing: float = 0.0, lengths: np.ndarray | None = None,
                    keep_from_time: float = 1.0) -> np.ndarray:
    """Normalised x̂_0 features (num, frames, 263). ``cond`` (C,) — all zeros = unconditional.

    Guidance in a limited interval (Kynkäänniemi et al. 2024; the manifest's ``guidanceMinTime``): the
    unconditional row runs only at steps whose time t_k > ``guidance_min_time``; below it the step is one
    conditional row and x̂_0 = x̂_0(c). 0 (the default) guides every step. The random draws are the same either
    way (z is drawn once per step for both rows), so only the skipped steps' x̂_0 changes.

    Smoothing x̂_0 along time (the manifest's ``x0Smoothing``, σ in frames; 0 = off, bit for bit as without it): at
    every step but the last, after guidance and before the kept part is replaced, x̂_0's pose channels (root-relative
    positions and rotations, ``emdm.motion.smooth.POSE_CHANNELS``) ← ``smooth_frames(·, σ)``; its root, velocity and
    contact channels stay the model's (smoothing those made the sampler choose faster motion).
    The model's x̂_0 at intermediate steps chooses each frame's phase on its own (a wrist front, back, front on
    consecutive frames); the smoothed estimate is what is re-noised, so the next step sees one coherent motion.
    The last x̂_0 (the result) is the model's own. docs/ARCHITECTURE.md "Sampling"; the same random draws.
    ``lengths`` (num,): rows padded past their length (a batch of clips of several lengths, the step masking the
    rest) are smoothed within their own frames.

    Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"): ``known`` (frames, 263) normalised features
    and ``keep`` (frames, 263) 0/1 (``emdm.motion.mask.keep_mask``) impose the kept entries at every step: x_T's
    kept part is a_cum[T]·known + s_cum[T]·x_T, and x̂_0's kept part is replaced by ``known`` before each update,
    so the model always sees the known motion noised to its step's level and the result equals ``known`` there.
    ``keep_from_time`` (the default 1 = every step): the kept part is imposed only at the steps whose time t_k ≤ it
    (x_T's when the first step's is) and always at the last, so the earlier steps are shaped by the condition alone
    and the later ones reconcile the motion with the known part (a timeline window: ``emdm.motion.edit``
    ``TIMELINE_KEEP_FROM``). The frames kept on every channel at the start (``lead_frames``: a window's context)
    sit those earlier steps out: the model sees frames [lead, frames) only, a generation of its own, and they join
    at the first imposing step k as a_cum[k+1]·known + s_cum[k+1]·(their x_T draw), the known motion noised to that
    step's level. That saves the model their rows at the steps they would not shape, and leaves each window's early
    steps independent of the motion it continues. The random draws are the same either way (x_T and every ε are
    drawn for all frames; the rows left out go unused).

    The loop is ``sampling`` (a generator of the step model's inputs); ``sample_together`` runs several such loops
    with one model call per step, and ``stop_at`` pauses a loop where its kept part is about to be imposed.
    """
    return drive(sampling(cond, frames, steps, guidance, seed, num, z_dim, feature_dim, objective, known, keep,
                          guidance_min_time, x0_smoothing, lengths, keep_from_time), step)


STOP = "stop"     # what ``sampling`` yields where it stops (``stop_at``): send it the known motion to go on


def sampling(cond: np.ndarray, frames: int, steps: int = 10, guidance: float = 1.0, seed: int = 0, num: int = 1,
             z_dim: int = 64, feature_dim: int = 263, objective: str = "ddgan", known: np.ndarray | None = None,
             keep: np.ndarray | None = None, guidance_min_time: float = 0.0, x0_smoothing: float = 0.0,
             lengths: np.ndarray | None = None, keep_from_time: float = 1.0, stop_at: float | None = None):
    """``sample_features``'s loop as a generator: it yields each step's model inputs (x, z, c, t, mask) and takes
    the model's x̂_0 back (``drive`` runs it with a step function), and returns the result. With ``stop_at`` (the
    TypeScript sampler's stopAt) it yields ``STOP`` before the first step with t ≤ stop_at (at the latest before the
    last) and takes ``known`` back there (None: the one it was given), so ``known`` may be None until then: a
    timeline window's steps before its context joins need nothing from the window before (``sample_together``).
    The same arithmetic and random draws as one uninterrupted run."""
    if frames < 1:
        raise SampleError(f"frames must be ≥ 1, got {frames}")
    deferred = stop_at is not None and known is None and keep is not None   # known comes at the stop
    keep, known = check_known(np.zeros((frames, feature_dim), np.float32) if deferred else known, keep, frames, feature_dim)
    sch = make_schedule(steps)
    rng = np.random.default_rng(seed)
    cond = np.asarray(cond, np.float32)
    if not (math.isfinite(guidance_min_time) and guidance_min_time >= 0):
        raise SampleError(f"guidance_min_time must be a finite time ≥ 0 (0 = guide every step), got {guidance_min_time}")
    sigma = check_x0_smoothing(x0_smoothing)
    if not (math.isfinite(keep_from_time) and keep_from_time >= 0):
        raise SampleError(f"keep_from_time must be a finite time ≥ 0 (1 = impose the kept part at every step), got {keep_from_time}")
    use_cfg = guidance != 1.0 and bool(np.any(cond != 0))
    c1 = np.repeat(cond[None], num, 0)
    c2 = np.concatenate([c1, np.zeros_like(c1)])
    x = rng.standard_normal((num, frames, feature_dim), dtype=np.float32)
    imposed = [keep is not None and (sch.time[k] <= keep_from_time or k == 0) for k in range(steps)]
    # a deferred kept part: its leading whole-kept frames sit out the steps before it is imposed (``lead_frames``)
    lead = lead_frames(keep) if keep is not None and not imposed[steps - 1] else 0
    stop = -1
    if stop_at is not None:
        if not (math.isfinite(stop_at) and stop_at >= 0):
            raise SampleError(f"stop_at must be a finite time ≥ 0, got {stop_at}")
        stop = max(0, max((k for k in range(steps) if sch.time[k] <= stop_at), default=0))
        if deferred and any(imposed[k] for k in range(stop + 1, steps)):
            raise SampleError(f"the kept part is imposed before t ≤ {stop_at}, so known is needed from the start")
    for k in range(steps - 1, -1, -1):
        if k == stop:
            given = yield STOP
            if given is not None:
                known = check_known(given, keep, frames, feature_dim)[1]
            elif deferred:
                raise SampleError("this run stopped for its known motion (stop_at): send it")
        if keep is not None and imposed[k] and k == steps - 1:    # the kept part enters: x_T's
            x = np.where(keep, np.float32(sch.a_cum[steps]) * known + np.float32(sch.s_cum[steps]) * x, x)
        if lead and imposed[k] and not imposed[k + 1]:   # they join, drawn from q(x_t | known) with x_T's own draw
            x[:, :lead] = np.float32(sch.a_cum[k + 1]) * known[:lead] + np.float32(sch.s_cum[k + 1]) * x[:, :lead]
        f0 = 0 if imposed[k] else lead   # the frames the model sees at this step: [f0, frames)
        z = rng.standard_normal((num, z_dim), dtype=np.float32)
        if objective == "diffusion":
            z = np.zeros_like(z)
        guided = use_cfg and sch.time[k] > guidance_min_time
        xs = x[:, f0:]
        xin, zin, c = (np.concatenate([xs, xs]), np.concatenate([z, z]), c2) if guided else (xs, z, c1)
        bsz = xin.shape[0]
        t = np.full((bsz,), sch.time[k], np.float32)
        mask = np.ones((bsz, frames - f0), np.float32)
        x0 = np.asarray((yield xin, zin, c, t, mask), np.float32)
        if guided:
            x0 = x0[num:] + np.float32(guidance) * (x0[:num] - x0[num:])
        if sigma > 0 and k > 0:
            x0 = smooth_pose(x0, sigma, None if lengths is None else np.asarray(lengths) - f0)
        if imposed[k]:
            x0 = np.where(keep, known, x0)
        if objective == "diffusion":     # DDIM, η = 0
            eps = (xs - np.float32(sch.a_cum[k + 1]) * x0) / np.float32(sch.s_cum[k + 1])
            x[:, f0:] = (np.float32(sch.a_cum[k]) * x0 + np.float32(sch.s_cum[k]) * eps) if k > 0 else x0
        else:
            xn = np.float32(sch.coef1[k]) * x0 + np.float32(sch.coef2[k]) * xs
            if sch.sigma[k] > 0:
                xn = xn + np.float32(sch.sigma[k]) * rng.standard_normal(x.shape, dtype=np.float32)[:, f0:]
            x[:, f0:] = xn
    return x.astype(np.float32)


def drive(run, step: StepFn, known: np.ndarray | None = None, first=None):
    """Run a ``sampling`` generator to its result with ``step`` (one model call per step); at a ``STOP`` it is sent
    ``known``. ``first``: what the run last yielded, when it was advanced before (``finish``)."""
    try:
        req = next(run) if first is None else first
        while True:
            req = run.send(known if isinstance(req, str) else np.asarray(step(*req), np.float32))
    except StopIteration as done:
        return done.value


def run_together(runs: list, step: StepFn) -> None:
    """Advance several ``sampling`` generators (each with ``stop_at``) with one model call per step for all of them,
    until every one has stopped (``STOP``): their inputs are stacked, frames padded to the longest with mask 0 (the
    model's attention ignores them), and each gets its own rows of x̂_0 back. Then ``finish`` each. The TypeScript
    twin is src/sampler/lockstep.ts (one call costs less than its parts where ORT has threads to spare)."""
    reqs = [next(r) for r in runs]
    while True:
        live = [i for i, q in enumerate(reqs) if not isinstance(q, str)]
        if not live:
            return
        parts = [reqs[i] for i in live]
        length = max(p[0].shape[1] for p in parts)
        pad = lambda a, fill=0: np.pad(a, [(0, 0), (0, length - a.shape[1])] + [(0, 0)] * (a.ndim - 2), constant_values=fill)
        x0 = np.asarray(step(np.concatenate([pad(p[0]) for p in parts]), np.concatenate([p[1] for p in parts]),
                             np.concatenate([p[2] for p in parts]), np.concatenate([p[3] for p in parts]),
                             np.concatenate([pad(p[4]) for p in parts])), np.float32)
        row = 0
        for i, p in zip(live, parts):
            b, n = p[0].shape[:2]
            try:
                reqs[i] = runs[i].send(x0[row:row + b, :n])
            except StopIteration:
                raise SampleError("run_together: a run ended without stopping; give every run stop_at") from None
            row += b


def finish(run, step: StepFn, known: np.ndarray | None = None) -> np.ndarray:
    """Go on with a run stopped by ``run_together`` (or ``stop_at``): send it ``known`` and drive it to its result."""
    return drive(run, step, known, first=STOP)


def lead_frames(keep: np.ndarray) -> int:
    """How many leading frames ``keep`` (frames, D) keeps on every channel, fewer than all (a timeline window's
    context: 0 for a mask that keeps no whole first frame, or every frame)."""
    whole = np.asarray(keep, bool).all(axis=1)
    n = int(np.argmin(whole)) if not whole.all() else 0
    return n


def check_known(known, keep, frames: int, feature_dim: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(keep as bool, known as float32) for ``sample_features``, or (None, None) when nothing is kept."""
    if known is None and keep is None:
        return None, None
    if known is None or keep is None:
        raise SampleError("inpainting needs both known (the motion to keep) and keep (its mask); give both or neither")
    known = np.asarray(known, np.float32)
    keep = np.asarray(keep)
    for name, a in (("known", known), ("keep", keep)):
        if a.shape != (frames, feature_dim):
            raise SampleError(f"{name} has shape {a.shape}, expected (frames, {feature_dim}) = ({frames}, {feature_dim})")
    if not np.isin(keep, (0, 1)).all():
        raise SampleError("keep must hold only 0 and 1 (build it with emdm.motion.mask.keep_mask)")
    keep = keep.astype(bool)
    if not np.isfinite(known[keep]).all():
        raise SampleError(f"known has NaN/Infinity in {int((~np.isfinite(known[keep])).sum())} kept entries")
    return keep, np.where(keep, known, np.float32(0))


def make_condition(spec: dict, text: str | None, action: str | None, uncond: bool,
                   models_dir: Path | str | None = None) -> np.ndarray:
    """The condition vector for a model's ``condition`` spec (manifest format); a text model's encoder is read from
    ``models_dir`` (default ``emdm.paths.models_dir()``: $EMDM_MODELS_DIR or public/models)."""
    dim = int(spec["dim"])
    given = sum(v is not None and v is not False for v in (text, action)) + int(bool(uncond))
    if given != 1:
        raise SampleError("give exactly one of --text, --action, --uncond")
    if uncond:
        return np.zeros(dim, np.float32)
    if spec["type"] == "text":
        if text is None:
            raise SampleError("this is a text model: use --text or --uncond")
        if not text.strip():
            raise SampleError("--text is empty: say what the character should do (or use --uncond)")
        from emdm.text import TextEncoderError, load_encoder, truncation_notice

        try:
            enc = load_encoder(spec["encoder"], models_dir=models_dir)
        except (TextEncoderError, mf.ManifestError) as e:
            raise SampleError(str(e)) from None
        emb = np.asarray(enc.encode([text]), np.float32)[0]
        notice = truncation_notice(enc, text)      # the page shows the same notice under its prompt box
        if notice:
            print(notice, file=sys.stderr)
        if emb.shape != (dim,):
            raise SampleError(f"text encoder {spec['encoder']} gave {emb.shape}, model expects ({dim},)")
        return emb
    if action is None:
        raise SampleError("this is an action model: use --action LABEL (or its index) or --uncond")
    labels = list(spec["labels"])
    if action in labels:
        idx = labels.index(action)
    elif action.isdigit() and int(action) < len(labels):
        idx = int(action)
    else:
        raise SampleError(f"unknown action {action!r}; labels: {', '.join(labels)}")
    c = np.zeros(dim, np.float32)
    c[idx] = 1.0
    return c


def denormalise(x: np.ndarray, mean: np.ndarray, std: np.ndarray) -> np.ndarray:
    return x * std + mean


def load_model(args) -> tuple[StepFn, dict, np.ndarray, np.ndarray]:
    """(step function, model entry (manifest-like), mean, std), opened by emdm.model.open: a corrupt or missing
    file, a name not in the manifest or a file whose sha256 differs from it is a SampleError naming it."""
    from emdm.model.open import ModelError, open_model

    try:
        m = open_model(args.ckpt if args.ckpt is not None else args.model, models_dir=args.models_dir,
                       variant=args.variant, threads=args.threads)
    except ModelError as e:
        raise SampleError(str(e)) from None
    return m.step, m.meta, m.mean, m.std


def bvh_paths(out: Path, num: int, units: str) -> list[Path]:
    """<out>.metres.bvh, or <out>_<i>.metres.bvh per sample with --num > 1 (.centimetres.bvh for units "cm")."""
    from emdm.mocap.bvh_writer import bvh_path

    if num == 1:
        return [bvh_path(out.with_suffix(""), units)]
    return [bvh_path(out.with_name(f"{out.name}_{i}"), units) for i in range(num)]


def check_out(out: Path, num: int, bvh_units: str | None) -> None:
    """Refuse an output prefix that cannot be written, before any sampling: the nearest existing folder
    must take a new file, and no output name may be an existing folder. ``bvh_units`` None: no BVH."""
    names = [out.with_suffix(".npy"), out.with_suffix(".features.npy")]
    if bvh_units is not None:
        names += bvh_paths(out, num, bvh_units)
    for p in names:
        if p.is_dir():
            raise SampleError(f"--out: {p} is a folder; give a path prefix such as out/walk (writes .npy, .bvh)")
    from emdm.outdir import OutputRefused, writable_folder

    try:
        writable_folder(out.parent)
    except OutputRefused as e:
        raise SampleError(f"--out: {e}") from None


def check_args(a) -> None:
    """What can be checked before any model is opened (one line each, as the page's limits)."""
    if not 1 <= a.num <= MAX_NUM:
        raise SampleError(f"--num must be in 1..{MAX_NUM}, got {a.num} (run several times for more samples)")
    if a.steps is not None and a.steps > MAX_STEPS:       # below 1: check_steps names the model's supported ones
        raise SampleError(f"--steps must be in 1..{MAX_STEPS}, got {a.steps}")
    if a.frames is not None and a.frames > mf.MAX_MODEL_FRAMES:  # the model's own maxFrames is checked once it is open
        raise SampleError(f"--frames must be in 1..{mf.MAX_MODEL_FRAMES} (the model's maxFrames, at most), got {a.frames}")
    if a.guidance is not None and not (math.isfinite(a.guidance) and a.guidance >= 0):
        raise SampleError(f"--guidance must be a finite number ≥ 0, got {a.guidance:g} (1 = no guidance)")
    if a.guidance_min_time is not None and not (math.isfinite(a.guidance_min_time) and a.guidance_min_time >= 0):
        raise SampleError(f"--guidance-min-time must be a finite time ≥ 0, got {a.guidance_min_time:g} "
                          f"(0 = guide every step; the step times run from 1 down to 1/steps)")
    if a.x0_smoothing is not None:
        check_x0_smoothing(a.x0_smoothing, "--x0-smoothing")
    if not 0 <= a.seed <= MAX_SEED:
        raise SampleError(f"--seed must be in 0..{MAX_SEED}, got {a.seed}")
    if not 1 <= a.threads <= MAX_THREADS:
        raise SampleError(f"--threads must be in 1..{MAX_THREADS}, got {a.threads}")
    if a.ckpt is not None and a.variant not in (None, "fp32"):
        raise SampleError(f"--variant {a.variant!r} needs --model (a checkpoint has only its fp32 weights)")
    check_out(a.out, a.num, None if a.no_bvh else a.bvh_units)
    if edit_mode(a):
        check_edit_args(a)
    elif a.keep or a.known is not None:
        keep_rects(a)
        read_known(a.known)


def keep_rects(a) -> list:
    """The parsed --keep rectangles (``emdm.motion.mask``); --keep and --known go together."""
    from emdm.motion.mask import KeepSpecError, parse_keep

    if a.known is None:
        raise SampleError("--keep needs --known PATH.features.npy (the motion whose parts are kept)")
    if not a.keep:
        raise SampleError("--known needs --keep SPEC (what to keep, e.g. --keep frames:0-19 or --keep group:legs)")
    try:
        return [parse_keep(spec) for spec in a.keep]
    except KeepSpecError as e:
        raise SampleError(f"--keep: {e}") from None


def read_known(path: Path) -> np.ndarray:
    """A de-normalised (frames, 263) motion, as emdm.sample writes to <out>.features.npy."""
    try:
        f = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as e:
        raise SampleError(f"--known {path}: cannot read a .npy array ({e})") from None
    if f.ndim != 2 or f.shape[1] != 263 or f.shape[0] < 1:
        raise SampleError(f"--known {path}: shape {f.shape}, expected (frames, 263) de-normalised features "
                          f"(an emdm.sample <out>.features.npy of one sample)")
    return f.astype(np.float32)


def known_and_keep(a, frames: int, mean: np.ndarray, std: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(known normalised, keep mask), both (frames, 263): known frame i is output frame i; every kept frame
    must lie inside the known motion."""
    from emdm.motion.mask import KeepSpecError, keep_mask

    feats = read_known(a.known)
    try:
        keep = keep_mask(frames, keep_rects(a))
    except KeepSpecError as e:
        raise SampleError(f"--keep: {e} (--frames {frames})") from None
    kept_rows = np.flatnonzero(keep.any(1))
    if kept_rows.size and kept_rows[-1] >= feats.shape[0]:
        raise SampleError(f"--keep: frame {kept_rows[-1]} is kept but --known {a.known} has only "
                          f"{feats.shape[0]} frames (0..{feats.shape[0] - 1})")
    known = np.zeros((frames, feats.shape[1]), np.float32)
    n = min(frames, feats.shape[0])
    known[:n] = (feats[:n] - mean) / std
    if not np.isfinite(known[keep.astype(bool)]).all():
        raise SampleError(f"--known {a.known}: non-finite values in the kept part")
    return known, keep


EDIT_FLAGS = {"timeline": "--timeline", "timeline_json": "--timeline-json", "inbetween": "--inbetween",
              "edit_upper": "--edit-upper", "edit_lower": "--edit-lower", "loop": "--loop"}


def edit_mode(a) -> str | None:
    """Which emdm.motion.edit mode the arguments ask for ("timeline", "inbetween", "edit_upper", "edit_lower",
    "loop"), None for ordinary sampling; two modes at once are refused."""
    given = [k for k in EDIT_FLAGS if getattr(a, k) not in (None, False, [])]
    if "timeline" in given and "timeline_json" in given:
        raise SampleError("give the segments with --timeline or with --timeline-json, not both")
    given = [("timeline" if k == "timeline_json" else k) for k in given]
    if len(given) > 1:
        raise SampleError(f"{EDIT_FLAGS[given[0]]} and {EDIT_FLAGS[given[1]]} cannot be combined; make one, then "
                          f"give its <out>.features.npy to the other as --known")
    if a.in_place and given != ["loop"]:
        raise SampleError("--in-place needs --loop")
    return given[0] if given else None


def check_edit_args(a) -> None:
    """The arguments of an edit mode that can be checked before the model is opened."""
    mode = edit_mode(a)
    flag = EDIT_FLAGS[mode]
    if a.num != 1:
        raise SampleError(f"{flag} makes one motion; --num must be 1, got {a.num}")
    if a.keep:
        raise SampleError(f"{flag} builds its own keep mask; leave out --keep (or use --known/--keep without {flag})")
    if mode == "timeline":
        for name, v in (("--text", a.text), ("--action", a.action), ("--uncond", a.uncond or None),
                        ("--known", a.known), ("--frames", a.frames)):
            if v is not None:
                raise SampleError(f"--timeline gives each segment its prompt and seconds; leave out {name}")
        timeline_segments(a)
        return
    if a.uncond or (a.text is None) == (a.action is None):
        raise SampleError(f"{flag} regenerates from a prompt: give exactly one of --text or --action")
    if a.known is None and mode != "loop":
        raise SampleError(f"{flag} needs --known PATH.features.npy (the motion to edit, an <out>.features.npy)")
    if a.known is not None:
        if a.frames is not None:
            raise SampleError(f"{flag} keeps --known's length; leave out --frames")
        read_known(a.known)
    if mode == "inbetween":
        inbetween_range(a.inbetween)


def timeline_segments(a) -> list:
    """The segments of --timeline PROMPT:SECONDS (seed --seed + k) or --timeline-json, checked (emdm.motion.edit)."""
    from emdm.motion.edit import EditError, check_timeline, parse_segment, read_segments

    try:
        if a.timeline_json is not None:
            segs = read_segments(a.timeline_json, a.seed)
        else:
            segs = [parse_segment(spec, (a.seed + k) % (MAX_SEED + 1)) for k, spec in enumerate(a.timeline)]
        check_timeline(segs)
    except EditError as e:
        raise SampleError(f"{'--timeline-json' if a.timeline_json is not None else '--timeline'}: {e}") from None
    return segs


def inbetween_range(spec: str) -> tuple[int, int] | None:
    """--inbetween A-B → (A, B), the frames to regenerate; "" → None (all but the first and last second)."""
    import re

    if spec == "":
        return None
    m = re.fullmatch(r"\s*(\d+)\s*-\s*(\d+)\s*", spec)
    if not m or int(m.group(1)) > int(m.group(2)) or int(m.group(1)) < 1:
        raise SampleError(f"--inbetween {spec!r}: give the frames to regenerate as A-B with 1 ≤ A ≤ B (frame 0 and "
                          f"the last frame stay), e.g. --inbetween 20-99")
    return int(m.group(1)), int(m.group(2))


def run_edit(a, step, entry: dict, mean, std, steps: int, guidance: float, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(features, joints) of one motion made by the edit mode (emdm.motion.edit), de-normalised."""
    from emdm.motion import edit as E

    model = E.Editor.from_entry(step, entry, mean, std, steps, guidance, models_dir=a.models_dir)
    if a.guidance_min_time is not None:
        model = dataclasses.replace(model, guidance_min_time=a.guidance_min_time)
    if a.x0_smoothing is not None:
        model = dataclasses.replace(model, x0_smoothing=a.x0_smoothing)
    mode = edit_mode(a)
    prompt = a.text if a.text is not None else a.action
    try:
        if mode == "timeline":
            m = E.timeline(model, timeline_segments(a))
        elif a.known is None:                   # --loop of a motion made from the prompt here (seed, then seed + 1)
            x = model.sample(prompt, frames, a.seed)
            m = E.loop(model, model.denormalise(x), prompt, (a.seed + 1) % (MAX_SEED + 1), in_place=a.in_place)
        else:
            known = read_known(a.known)
            if mode == "loop":
                m = E.loop(model, known, prompt, a.seed, in_place=a.in_place)
            elif mode == "inbetween":
                r = inbetween_range(a.inbetween)
                if r is not None and r[1] >= len(known) - 1:
                    raise SampleError(f"--inbetween {a.inbetween}: frame {r[1]} is not before --known's last frame "
                                      f"{len(known) - 1}; the last frame stays")
                m = E.inbetween(model, known, prompt, a.seed, *((r[0] - 1, r[1] + 1) if r else (None, None)))
            else:
                m = E.edit_body(model, known, prompt, a.seed, keep="lower" if mode == "edit_upper" else "upper")
    except E.EditError as e:
        raise SampleError(f"{EDIT_FLAGS[mode]}: {e}") from None
    return m.features, m.joints


def check_steps(steps: int | None, entry: dict, name: str) -> int:
    """The step count to run: ``steps`` (None: the model's default) if the model supports it, as the page."""
    supported = entry.get("supportedSteps")
    if steps is None:
        return int(entry.get("defaultSteps", 10))
    if supported:
        if steps not in supported:
            raise SampleError(f"--steps: {steps} is not supported by model {name!r}; use one of {list(supported)}")
    elif not 1 <= steps <= MAX_STEPS:
        raise SampleError(f"--steps must be in 1..{MAX_STEPS}, got {steps}")
    return steps


def build_parser() -> argparse.ArgumentParser:
    from emdm import paths

    p = argparse.ArgumentParser(prog="python -m emdm.sample", description=__doc__.split("\n\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--model", help="model name in the manifest (e.g. emdm-t2m-web)")
    src.add_argument("--ckpt", type=Path, help="an emdm.train checkpoint (EMA weights)")
    p.add_argument("--models-dir", type=Path, default=None,
                   help=f"the models folder (manifest.json, step models, text encoder; default ${paths.MODELS_ENV}, "
                        "else the repository's public/models)")
    p.add_argument("--variant", default=None, help="fp32 (default) or a manifest variant such as int8")
    p.add_argument("--text")
    p.add_argument("--action")
    p.add_argument("--uncond", action="store_true")
    p.add_argument("--steps", type=int, default=None, help="denoising steps: one of the model's supportedSteps (default: its defaultSteps)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--frames", type=int, default=None, help="length in frames at 20 fps (≤ 196; default 120)")
    p.add_argument("--guidance", type=float, default=None, help="classifier-free guidance scale (default: model's)")
    p.add_argument("--guidance-min-time", type=float, default=None, metavar="T",
                   help="guide only the steps whose time is above T, one batch row below (guidance in a limited "
                        "interval; default: the model's guidanceMinTime, else 0 = every step)")
    p.add_argument("--x0-smoothing", type=float, default=None, metavar="SIGMA",
                   help="smooth x̂0 along time (Gaussian, σ frames) at every step but the last (default: the model's "
                        "x0Smoothing, else 0 = off)")
    p.add_argument("--num", type=int, default=1, help="number of samples")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--out", type=Path, required=True, help="output path prefix (.npy, .features.npy, .metres.bvh)")
    p.add_argument("--no-bvh", action="store_true")
    p.add_argument("--bvh-units", choices=["m", "cm"], default="m",
                   help="BVH length unit, also in the file name: m (default; Blender's import at scale 1.0) or cm")
    p.add_argument("--known", type=Path, default=None,
                   help="a motion to keep parts of: (frames, 263) de-normalised features (an <out>.features.npy); "
                        "its frame i is output frame i")
    p.add_argument("--keep", action="append", default=[], metavar="SPEC",
                   help="what to keep of --known, repeatable (union): frames:0-19 | group:legs | frames:0-19/group:root,legs "
                        "(ranges A-B inclusive, A, A-; groups root, legs, upper)")
    e = p.add_argument_group("beyond one prompt (emdm.motion.edit)")
    e.add_argument("--timeline", action="append", default=[], metavar="PROMPT:SECONDS",
                   help="a segment of a long motion, repeatable, in order (segment k's seed: --seed + k); ≤ 60 s in all; "
                        "each continues the last second of the one before (one longer than the model's window is made "
                        "in several windows)")
    e.add_argument("--timeline-json", type=Path, default=None, metavar="FILE",
                   help='the segments as JSON: [{"prompt": "...", "seconds": 4, "seed": 1}, ...] (seed optional)')
    e.add_argument("--inbetween", nargs="?", const="", default=None, metavar="A-B",
                   help="with --known: regenerate its frames A..B from the prompt, keep the rest in place "
                        "(default: all but the first and last second)")
    e.add_argument("--edit-upper", action="store_true", help="with --known: keep its legs and root, new upper body from the prompt")
    e.add_argument("--edit-lower", action="store_true", help="with --known: keep its upper body, new legs and root from the prompt")
    e.add_argument("--loop", action="store_true", help="make --known (or the motion of --text/--action, --frames, --seed) "
                   "loop: its last 0.5 s is inpainted into its first; writes the clip without the repeated end")
    e.add_argument("--in-place", action="store_true", help="with --loop: no horizontal root travel (the root may still turn)")
    return p


def main(argv: list[str] | None = None) -> int:
    a = build_parser().parse_args(argv)
    try:
        return run(a)
    except SampleError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2


def run(a: argparse.Namespace) -> int:
    from emdm.motion.features import recover_joints

    check_args(a)
    step, entry, mean, std = load_model(a)
    max_frames = int(entry.get("maxFrames", 196))
    frames = 120 if a.frames is None else a.frames
    if not 1 <= frames <= max_frames:
        raise SampleError(f"--frames must be in 1..{max_frames}, got {frames}")
    steps = check_steps(a.steps, entry, a.model or str(a.ckpt))
    guidance = float(entry.get("guidance", 2.5)) if a.guidance is None else a.guidance
    if edit_mode(a):
        feats, joints = run_edit(a, step, entry, mean, std, steps, guidance, frames)
        return write_motion(a, feats[None], joints[None])
    cond = make_condition(entry["condition"], a.text, a.action, a.uncond, a.models_dir)
    far = a.text and a.model and capabilities.prompt_notice(a.model, cond, a.models_dir)
    if far:                                          # the page says the same beside its prompt box
        print(far, file=sys.stderr)
    known, keep = known_and_keep(a, frames, mean, std) if a.keep else (None, None)
    gmin = float(entry.get("guidanceMinTime", 0.0)) if a.guidance_min_time is None else a.guidance_min_time
    sigma = float(entry.get("x0Smoothing", 0.0)) if a.x0_smoothing is None else a.x0_smoothing
    x = sample_features(step, cond, frames, steps, guidance, a.seed, a.num, int(entry.get("zDim", 64)),
                        objective=entry.get("objective", "ddgan"), known=known, keep=keep, guidance_min_time=gmin,
                        x0_smoothing=sigma)
    feats = denormalise(x, mean, std)
    if not np.isfinite(feats).all():
        raise SampleError(f"the model returned non-finite numbers ({int((~np.isfinite(feats)).sum())} of {feats.size} "
                          f"feature values); nothing written. Check the model file and its meanStd against the "
                          f"manifest's sha256, or try --variant fp32")
    if keep is not None:      # kept frames after free ones decode where the known motion has them (pin_kept_root)
        from emdm.motion.stitch import pin_kept_root

        feats = np.stack([pin_kept_root(f, keep, denormalise(known, mean, std)) for f in feats])
    joints = np.stack([recover_joints(f) for f in feats]).astype(np.float32)
    return write_motion(a, feats, joints)


def write_motion(a: argparse.Namespace, feats: np.ndarray, joints: np.ndarray) -> int:
    """<out>.npy (joints), <out>.features.npy and the BVH files of (num, frames, ...) motions, after checking them."""
    if not np.isfinite(feats).all():
        raise SampleError(f"the motion has non-finite features ({int((~np.isfinite(feats)).sum())} values); nothing written")
    if not np.isfinite(joints).all():
        raise SampleError("recovering joints gave non-finite positions; nothing written")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    np.save(a.out.with_suffix(".npy"), joints[0] if a.num == 1 else joints)
    np.save(a.out.with_suffix(".features.npy"), feats[0] if a.num == 1 else feats)
    written = [a.out.with_suffix(".npy")]
    if not a.no_bvh:
        from emdm.mocap.bvh_writer import write_bvh

        for i, path in enumerate(bvh_paths(a.out, a.num, a.bvh_units)):
            written.append(write_bvh(joints[i], path, units=a.bvh_units))
    print("wrote " + ", ".join(map(str, written)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
