"""The sampling loop (docs/ARCHITECTURE.md "Sampling", "DDIM sampling" and "Sampling with constraints"; the
TypeScript twin is src/sampler/sampler.ts), independent of ONNX: the step model is a function, the noise numpy's
``default_rng(seed)``. The update rule is ``settings.method``'s (``emdm.sampler.registry``).

    x = sample_features(step, cond, frames, SamplingSettings(steps=10, guidance=2.5), seed=3)[0]

x_T ~ N(0, I); per step k = T−1..0: a fresh z (zeroed for a rule that does not use it), x̂0 = G(x, z, c, time[k],
mask) (with guidance s ≠ 1, at the steps whose time is above ``guidance_min_time``, one batched call [c, 0] with the
same x and z, x̂0 = x̂0_u + s·(x̂0_c − x̂0_u)); with ``x0_smoothing`` σ, at every step but the last, x̂0's pose channels
← ``smooth_pose``; the kept part of x̂0 ← ``known``; x ← update(x, x̂0, k). Random draws in the order x_T, then per
step z, then ε (DDGAN).

Guidance in a limited interval (Kynkäänniemi et al. 2024; the manifest's ``guidanceMinTime``): the unconditional
row runs only at steps whose time t_k > ``guidance_min_time``; below it x̂0 = x̂0(c). The random draws are the same
either way (z is drawn once per step for both rows), so only the skipped steps' x̂0 changes.

Smoothing x̂0 along time (the manifest's ``x0Smoothing``, σ in frames; 0 = off, bit for bit as without it): at every
step but the last, after guidance and before the kept part is replaced, x̂0's pose channels (root-relative
positions and rotations, ``emdm.motion.smooth.POSE_CHANNELS``) ← ``smooth_frames(·, σ)``; its root, velocity and
contact channels stay the model's (smoothing those made the sampler choose faster motion). The model's x̂0 at
intermediate steps chooses each frame's phase on its own (a wrist front, back, front on consecutive frames); the
smoothed estimate is what is re-noised, so the next step sees one coherent motion. The last x̂0 is the model's own.

Inpainting: ``known`` (frames, D) normalised features and ``keep`` (frames, D) 0/1 (``emdm.motion.mask.keep_mask``)
impose the kept entries: x_T's kept part is a_cum[T]·known + s_cum[T]·x_T, and x̂0's kept part is replaced by
``known`` before each update, so the model always sees the known motion noised to its step's level and the result
equals ``known`` there. ``keep_from_time`` (1 = every step): the kept part is imposed only at the steps whose time
t_k ≤ it (x_T's when the first step's is) and always at the last, so the earlier steps are shaped by the condition
alone and the later ones reconcile the motion with the known part (a timeline window: ``emdm.motion.edit``
``TIMELINE_KEEP_FROM``). The frames kept on every channel at the start (``lead_frames``: a window's context) sit
those earlier steps out: the model sees frames [lead, frames) only, and they join at the first imposing step k as
a_cum[k+1]·known + s_cum[k+1]·(their x_T draw). The random draws are the same either way (x_T and every ε are drawn
for all frames; the rows left out go unused).

Root speed cap (``speed_cap``, off by default; measured in docs/MODELS.md, "A cap on the sampler's side"): the
first step's conditional x̂0 (t = 1: the mean motion of the condition) travels at the real clips' speed, and the
steps at t = 0.9–0.7 make runs a fifth faster than it. With ``speed_cap`` c > 0, a motion whose first conditional
x̂0 travels (median horizontal root speed ≥ ``CAP_MIN_SPEED``) and whose result goes faster than c times that speed
has its root velocity channels (1, 2; de-normalised by ``root_norm``, scaled, normalised back) scaled to it, on the
frames and channels not kept (inpainting). Never faster, and the heading and the pose are the model's. The numbers
are float32 as numpy computes them, so the TypeScript twin (``rootSpeed``/``capRootSpeed``) gives the same.

``sampling`` is the loop as a generator of the step model's inputs; ``drive`` runs it with a step function;
``emdm.sampler.lockstep`` runs several with one model call per step.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from emdm import skeleton as sk
from emdm.motion.smooth import smooth_pose
from emdm.sampler.registry import SAMPLERS
from emdm.sampler.schedule import Schedule, make_schedule
from emdm.sampler.settings import SampleError, SamplingSettings

StepFn = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
STOP = "stop"     # what ``sampling`` yields where it stops (``stop_at``): send it the known motion to go on
DEFAULT = SamplingSettings()
CAP_MIN_SPEED = 0.5 / sk.FPS   # m per frame (0.5 m/s): a first x̂0 slower does not travel; its motion is left alone


def sample_features(step: StepFn, cond: np.ndarray, frames: int, settings: SamplingSettings = DEFAULT, seed: int = 0,
                    num: int | np.ndarray = 1) -> np.ndarray:
    """Normalised x̂0 features (num, frames, D). ``cond`` (C,) — all zeros = unconditional. ``num``: how many
    samples, or each row's length (B,) of a padded batch of clips of several lengths (the step masking the rest:
    ``emdm.eval.sources``), whose rows are smoothed within their own frames."""
    return drive(sampling(cond, frames, settings, seed, num), step)


def sampling(cond: np.ndarray, frames: int, settings: SamplingSettings = DEFAULT, seed: int = 0,
             num: int | np.ndarray = 1, stop_at: float | None = None):
    """``sample_features``'s loop as a generator: it yields each step's model inputs (x, z, c, t, mask) and takes
    the model's x̂0 back (``drive`` runs it with a step function), and returns the result. With ``stop_at`` (the
    TypeScript sampler's stopAt) it yields ``STOP`` before the first step with t ≤ stop_at (at the latest before the
    last) and takes ``known`` back there (None: the one in ``settings``), so ``settings.known`` may be None until
    then: a timeline window's steps before its context joins need nothing from the window before
    (``emdm.sampler.lockstep.run_together``). The same arithmetic and random draws as one uninterrupted run."""
    if frames < 1:
        raise SampleError(f"frames must be ≥ 1, got {frames}")
    s = settings
    s.check(SAMPLERS)
    rule, sch = SAMPLERS[s.method], make_schedule(s.steps)
    num, lengths = (num, None) if np.ndim(num) == 0 else (len(num), np.asarray(num))
    deferred = stop_at is not None and s.known is None and s.keep is not None   # known comes at the stop
    zeros = np.zeros((frames, s.feature_dim), np.float32)
    keep, known = check_known(zeros if deferred else s.known, s.keep, frames, s.feature_dim)
    rng = np.random.default_rng(seed)
    c1 = np.repeat(np.asarray(cond, np.float32)[None], num, 0)
    use_cfg = s.guidance != 1.0 and bool(np.any(c1 != 0))
    x = rng.standard_normal((num, frames, s.feature_dim), dtype=np.float32)
    imposed = [keep is not None and (sch.time[k] <= s.keep_from_time or k == 0) for k in range(s.steps)]
    # a deferred kept part: its leading whole-kept frames sit out the steps before it is imposed (``lead_frames``)
    lead = lead_frames(keep) if keep is not None and not imposed[s.steps - 1] else 0
    stop = stop_index(sch, stop_at, deferred, imposed)
    cap_ref = None                   # per row: the first conditional x̂0's median root speed (m per frame), speed_cap only
    row_frames = frames if lengths is None else lengths
    for k in range(s.steps - 1, -1, -1):
        if k == stop:
            given = yield STOP
            if given is not None:
                known = check_known(given, keep, frames, s.feature_dim)[1]
            elif deferred:
                raise SampleError("this run stopped for its known motion (stop_at): send it")
        if imposed[k]:
            x = enter_known(x, keep, known, sch, k, lead if not imposed[min(k + 1, s.steps - 1)] else 0)
        f0 = 0 if imposed[k] else lead   # the frames the model sees at this step: [f0, frames)
        z = rng.standard_normal((num, s.z_dim), dtype=np.float32)
        z = z if rule.uses_z else np.zeros_like(z)
        guided = use_cfg and sch.time[k] > s.guidance_min_time
        xs = x[:, f0:]
        c = np.concatenate([c1, np.zeros_like(c1)]) if guided else c1
        xin, zin = (np.concatenate([xs, xs]), np.concatenate([z, z])) if guided else (xs, z)
        t = np.full((xin.shape[0],), sch.time[k], np.float32)
        x0 = np.asarray((yield xin, zin, c, t, np.ones((xin.shape[0], frames - f0), np.float32)), np.float32)
        if s.speed_cap > 0 and cap_ref is None:            # the conditional rows come first
            cap_ref = root_speeds(x0[:num], s.root_norm, row_frames - f0)
        if guided:
            x0 = x0[num:] + np.float32(s.guidance) * (x0[:num] - x0[num:])
        if s.x0_smoothing > 0 and k > 0:
            x0 = smooth_pose(x0, float(s.x0_smoothing), None if lengths is None else lengths - f0)
        if imposed[k]:
            x0 = np.where(keep, known, x0)
        x[:, f0:] = rule.update(xs, x0, k, sch, lambda: rng.standard_normal(x.shape, dtype=np.float32)[:, f0:])
    if cap_ref is not None:
        x = cap_root_speed(x, s.speed_cap * cap_ref, s.root_norm, row_frames, keep)
    return x.astype(np.float32)


def root_speeds(x: np.ndarray, root_norm, lengths) -> np.ndarray:
    """(B,) median horizontal root speed, m per frame, of normalised features x (B, F, D) over each row's first
    ``lengths`` frames (an int or (B,))."""
    m1, m2, s1, s2 = (float(v) for v in root_norm)
    v = np.hypot(x[..., 1] * s1 + m1, x[..., 2] * s2 + m2)
    n = np.broadcast_to(np.asarray(lengths), (len(x),))
    return np.array([np.median(v[i, : max(int(n[i]), 1)]) for i in range(len(x))], np.float64)


def cap_root_speed(x: np.ndarray, cap: np.ndarray, root_norm, lengths, keep: np.ndarray | None) -> np.ndarray:
    """x (B, F, D) normalised with each travelling row's root velocity scaled so its median speed is at most ``cap``
    (B,) m per frame; rows whose cap is under CAP_MIN_SPEED (the first x̂0 did not travel), or already slower, as
    they are; entries ``keep`` keeps unchanged."""
    m1, m2, s1, s2 = (np.float32(v) for v in root_norm)
    cur = root_speeds(x, root_norm, lengths)
    out = x.copy()
    for i in np.flatnonzero((cap >= CAP_MIN_SPEED) & (cur > cap)):
        r = np.float32(cap[i] / cur[i])
        scaled = np.stack([((x[i, :, 1] * s1 + m1) * r - m1) / s1, ((x[i, :, 2] * s2 + m2) * r - m2) / s2], axis=-1)
        out[i, :, 1:3] = scaled if keep is None else np.where(keep[:, 1:3] > 0, x[i, :, 1:3], scaled)
    return out


def enter_known(x: np.ndarray, keep: np.ndarray, known: np.ndarray, sch: Schedule, k: int, lead: int) -> np.ndarray:
    """x with the kept part entering where it is first imposed (step k): all of it at the first step (x_T's,
    a_cum[T]·known + s_cum[T]·x_T), or the ``lead`` frames as they join, drawn from q(x_t | known) with their x_T draw."""
    if k == sch.steps - 1:
        return np.where(keep, np.float32(sch.a_cum[sch.steps]) * known + np.float32(sch.s_cum[sch.steps]) * x, x)
    if lead:
        x[:, :lead] = np.float32(sch.a_cum[k + 1]) * known[:lead] + np.float32(sch.s_cum[k + 1]) * x[:, :lead]
    return x


def stop_index(sch: Schedule, stop_at: float | None, deferred: bool, imposed: list[bool]) -> int:
    """The step before which a run with ``stop_at`` stops (-1: it does not): the first with t ≤ stop_at, at the
    latest the last; a deferred known motion must not be needed before it."""
    if stop_at is None:
        return -1
    if not (np.isfinite(stop_at) and stop_at >= 0):
        raise SampleError(f"stop_at must be a finite time ≥ 0, got {stop_at}")
    stop = max(0, max((k for k in range(sch.steps) if sch.time[k] <= stop_at), default=0))
    if deferred and any(imposed[k] for k in range(stop + 1, sch.steps)):
        raise SampleError(f"the kept part is imposed before t ≤ {stop_at}, so known is needed from the start")
    return stop


def drive(run, step: StepFn, known: np.ndarray | None = None, first=None):
    """Run a ``sampling`` generator to its result with ``step`` (one model call per step); at a ``STOP`` it is sent
    ``known``. ``first``: what the run last yielded, when it was advanced before (``emdm.sampler.lockstep.finish``)."""
    try:
        req = next(run) if first is None else first
        while True:
            req = run.send(known if isinstance(req, str) else np.asarray(step(*req), np.float32))
    except StopIteration as done:
        return done.value


def lead_frames(keep: np.ndarray) -> int:
    """How many leading frames ``keep`` (frames, D) keeps on every channel, fewer than all (a timeline window's
    context: 0 for a mask that keeps no whole first frame, or every frame)."""
    whole = np.asarray(keep, bool).all(axis=1)
    return int(np.argmin(whole)) if not whole.all() else 0


def check_known(known, keep, frames: int, feature_dim: int) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(keep as bool, known as float32) for the loop, or (None, None) when nothing is kept."""
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
