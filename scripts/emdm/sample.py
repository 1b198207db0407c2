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
This module is the command line only: arguments → ``emdm.sampler.SamplingSettings`` (the model's manifest entry,
then the flags) → ``emdm.sampler.sample_features`` (the loop of docs/ARCHITECTURE.md "Sampling"; --guidance-min-time
and --x0-smoothing default to the manifest's guidanceMinTime and x0Smoothing; a model trained with ``--objective
diffusion`` is sampled with DDIM) → the writers. Random draws come from numpy's default_rng(--seed).

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
import re
import sys
from pathlib import Path

import numpy as np

from emdm import manifest as mf
from emdm import paths
from emdm import prompt_check
from emdm.writers.bvh import bvh_path, write_bvh
from emdm.model.open import ModelError, open_model
from emdm.motion import edit as E
from emdm.motion.features import recover_joints
from emdm.motion.mask import KeepSpecError, keep_mask, parse_keep
from emdm.motion.stitch import pin_kept_root
from emdm.outdir import OutputRefused, writable_folder, write_npy_atomic
from emdm.sampler.flags import add_sampling_settings, with_flags
from emdm.sampler import (MAX_SEED, SampleError, SamplingSettings, StepFn, check_steps, check_x0_smoothing,
                          denormalise, make_condition, sample_features)

MAX_NUM = 256            # samples of one run
MAX_THREADS = 256        # ORT threads


def load_model(args) -> tuple[StepFn, dict, np.ndarray, np.ndarray]:
    """(step function, model entry (manifest-like), mean, std), opened by emdm.model.open: a corrupt or missing
    file, a name not in the manifest or a file whose sha256 differs from it is a SampleError naming it."""
    try:
        m = open_model(args.ckpt if args.ckpt is not None else args.model, models_dir=args.models_dir,
                       variant=args.variant, threads=args.threads)
    except ModelError as e:
        raise SampleError(str(e)) from None
    return m.step, m.meta, m.mean, m.std


# the names --out's prefix is given: one of them, given whole, stands for its prefix (--out out/walk.npy = out/walk)
OUT_SUFFIXES = (".features.npy", ".centimetres.bvh", ".metres.bvh", ".npy", ".bvh")


def out_prefix(given: str | Path) -> Path:
    """--out as the prefix every output's name is appended to: ``out/walk`` writes out/walk.npy, .features.npy and
    .metres.bvh; dots of the prefix stay (``run.v2`` is not ``run``); one of those names given whole stands for its
    prefix. A folder (an existing one, or a path ending in a separator) is refused: it names no file."""
    text = str(given)
    example = "a path prefix such as out/walk (writes walk.npy, walk.features.npy, walk.metres.bvh)"
    if not text.strip():
        raise SampleError(f"--out is empty; give {example}")
    if text.endswith(("/", "\\")) or Path(text).is_dir():
        raise SampleError(f"--out {text}: a folder; give {example} inside it")
    p = Path(text)
    for suffix in OUT_SUFFIXES:
        if p.name.endswith(suffix) and len(p.name) > len(suffix):
            return p.with_name(p.name[:-len(suffix)])
    return p


def out_file(prefix: Path, suffix: str) -> Path:
    """``prefix`` with ``suffix`` appended (``with_suffix`` would replace a dotted prefix's last part)."""
    return prefix.with_name(prefix.name + suffix)


def bvh_paths(out: Path, num: int, units: str) -> list[Path]:
    """<out>.metres.bvh, or <out>_<i>.metres.bvh per sample with --num > 1 (.centimetres.bvh for units "cm")."""
    if num == 1:
        return [bvh_path(out, units)]
    return [bvh_path(out.with_name(f"{out.name}_{i}"), units) for i in range(num)]


def check_out(out: Path, num: int, bvh_units: str | None) -> None:
    """Refuse an output prefix that cannot be written, before any sampling: the nearest existing folder
    must take a new file, and no output name may be an existing folder. ``bvh_units`` None: no BVH."""
    names = [out_file(out, ".npy"), out_file(out, ".features.npy")]
    if bvh_units is not None:
        names += bvh_paths(out, num, bvh_units)
    for p in names:
        if p.is_dir():
            raise SampleError(f"--out: {p} is a folder; give a path prefix such as out/walk (writes .npy, .bvh)")
    try:
        writable_folder(out.parent)
    except OutputRefused as e:
        raise SampleError(f"--out: {e}") from None


def check_args(a) -> None:
    """What can be checked before any model is opened (one line each, as the page's limits)."""
    if not 1 <= a.num <= MAX_NUM:
        raise SampleError(f"--num must be in 1..{MAX_NUM}, got {a.num} (run several times for more samples)")
    if a.steps is not None and a.steps > mf.MAX_STEPS:       # below 1: check_steps names the model's supported ones
        raise SampleError(f"--steps must be in 1..{mf.MAX_STEPS}, got {a.steps}")
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
    a.out = out_prefix(a.out)
    check_out(a.out, a.num, None if a.no_bvh else a.bvh_units)
    if edit_mode(a):
        check_edit_args(a)
    elif a.keep or a.known is not None:
        keep_rects(a)
        read_known(a.known)


def keep_rects(a) -> list:
    """The parsed --keep rectangles (``emdm.motion.mask``); --keep and --known go together."""
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
    try:
        if a.timeline_json is not None:
            segs = E.read_segments(a.timeline_json, a.seed)
        else:
            segs = [E.parse_segment(spec, (a.seed + k) % (MAX_SEED + 1)) for k, spec in enumerate(a.timeline)]
        E.check_timeline(segs)
    except E.EditError as e:
        raise SampleError(f"{'--timeline-json' if a.timeline_json is not None else '--timeline'}: {e}") from None
    return segs


def inbetween_range(spec: str) -> tuple[int, int] | None:
    """--inbetween A-B → (A, B), the frames to regenerate; "" → None (all but the first and last second)."""
    if spec == "":
        return None
    m = re.fullmatch(r"\s*(\d+)\s*-\s*(\d+)\s*", spec)
    if not m or int(m.group(1)) > int(m.group(2)) or int(m.group(1)) < 1:
        raise SampleError(f"--inbetween {spec!r}: give the frames to regenerate as A-B with 1 ≤ A ≤ B (frame 0 and "
                          f"the last frame stay), e.g. --inbetween 20-99")
    return int(m.group(1)), int(m.group(2))


def run_edit(a, model: E.Editor, frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(features, joints) of one motion made by the edit mode (emdm.motion.edit), de-normalised."""
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


def build_parser() -> argparse.ArgumentParser:
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
    add_sampling_settings(p)
    p.add_argument("--num", type=int, default=1, help="number of samples")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--out", required=True, help="output path prefix: out/walk writes out/walk.npy (joints), "
                   "out/walk.features.npy and out/walk.metres.bvh (an existing file of these names is replaced)")
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
    check_args(a)
    step, entry, mean, std = load_model(a)
    max_frames = int(entry.get("maxFrames", 196))
    frames = 120 if a.frames is None else a.frames
    if not 1 <= frames <= max_frames:
        raise SampleError(f"--frames must be in 1..{max_frames}, got {frames}")
    settings = settings_of(a, entry, mean, std)
    if edit_mode(a):
        editor = E.Editor.from_entry(step, entry, mean, std, models_dir=a.models_dir)
        feats, joints = run_edit(a, dataclasses.replace(editor, settings=settings), frames)
        return write_motion(a, feats[None], joints[None])
    cond = make_condition(entry["condition"], a.text, a.action, a.uncond, a.models_dir)
    try:
        far = a.text and a.model and prompt_check.prompt_notice(a.model, cond, a.models_dir, a.text)
    except prompt_check.CapabilitiesError as e:      # advisory: say it once and generate (the page does the same)
        far = f"no prompt check: {e}"
    if far:                                          # the page says the same beside its prompt box
        print(far, file=sys.stderr)
    known, keep = known_and_keep(a, frames, mean, std) if a.keep else (None, None)
    x = sample_features(step, cond, frames, dataclasses.replace(settings, known=known, keep=keep), a.seed, a.num)
    feats = denormalise(x, mean, std)
    if not np.isfinite(feats).all():
        raise SampleError(f"the model returned non-finite numbers ({int((~np.isfinite(feats)).sum())} of {feats.size} "
                          f"feature values); nothing written. Check the model file and its meanStd against the "
                          f"manifest's sha256, or try --variant fp32")
    if keep is not None:      # kept frames after free ones decode where the known motion has them (pin_kept_root)
        feats = np.stack([pin_kept_root(f, keep, denormalise(known, mean, std)) for f in feats])
    joints = np.stack([recover_joints(f) for f in feats]).astype(np.float32)
    return write_motion(a, feats, joints)


def settings_of(a: argparse.Namespace, entry: dict, mean: np.ndarray | None = None,
                std: np.ndarray | None = None) -> SamplingSettings:
    """The model's sampling settings (its manifest entry, its mean/std for a speedCap) with the flags given: --steps
    (checked against its supportedSteps), --guidance, --guidance-min-time, --x0-smoothing."""
    steps = check_steps(a.steps, entry, a.model or str(a.ckpt))
    return with_flags(SamplingSettings.from_entry(entry, steps, a.guidance, mean, std), a)


def write_motion(a: argparse.Namespace, feats: np.ndarray, joints: np.ndarray) -> int:
    """<out>.npy (joints), <out>.features.npy and the BVH files of (num, frames, ...) motions, after checking them."""
    if not np.isfinite(feats).all():
        raise SampleError(f"the motion has non-finite features ({int((~np.isfinite(feats)).sum())} values); nothing written")
    if not np.isfinite(joints).all():
        raise SampleError("recovering joints gave non-finite positions; nothing written")
    a.out.parent.mkdir(parents=True, exist_ok=True)
    written = [write_npy_atomic(out_file(a.out, ".npy"), joints[0] if a.num == 1 else joints),
               write_npy_atomic(out_file(a.out, ".features.npy"), feats[0] if a.num == 1 else feats)]
    if not a.no_bvh:
        for i, path in enumerate(bvh_paths(a.out, a.num, a.bvh_units)):
            written.append(write_bvh(joints[i], path, units=a.bvh_units))
    print("wrote " + ", ".join(map(str, written)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
