"""Beyond one prompt (issue 14): a prompt timeline for long motions, in-betweening, body-part edits and loops, all
made of masked sampling (``emdm.sampler.sample_features`` with ``known``/``keep`` settings), masks (``emdm.motion.mask``) and root
stitching (``emdm.motion.stitch``); docs/ARCHITECTURE.md "Sampling with constraints". The TypeScript twin is
``src/edit.ts``; both follow the same frame bookkeeping, checked by the ``tiny-edit`` parity fixture
(``python -m emdm.motion.edit_fixture``).

    model = Editor.open(open_model("emdm-t2m-web"), steps=10)
    tl = timeline(model, [Segment("a person walks forward", 4, seed=1), Segment("a person waves", 3, seed=2)])
    tl2 = regenerate(model, tl, 1, Segment("a person sits down", 3, seed=7))   # segment 0 untouched
    mid = inbetween(model, tl.features[:120], "a person jumps", seed=3)        # keeps the first and last second
    wave = edit_body(model, walk, "a person waves both hands", seed=4, keep="lower")
    cyc = loop(model, walk, "a person walks forward", seed=5, in_place=True)  # cyc.features: the looping clip

Frame bookkeeping (the contract with ``src/edit.ts``; FPS 20, C = ``OVERLAP`` = 20 frames):

* timeline: segment k has n_k = floor(seconds·20 + 0.5) ≥ 1 new frames, Σ n_k ≤ 60 s, made in windows
  (``window_sizes``: one window when n_k ≤ maxFrames − C, or ≤ maxFrames for segment 0; else ⌈n_k/(maxFrames − C)⌉
  near-equal ones, window j seeded seed + j). The first window is an ordinary generation. Every later window
  samples c + n frames, c = min(C, frames so far), whose frames [0, c) are kept (all channels) from the
  sequence's last c
  de-normalised frames (the last one's root velocity [0:3], its step into the window, replaced by the frame's
  before: the window before never took it; normalised as the sampler takes them), imposed at the steps with t ≤
  ``TIMELINE_KEEP_FROM`` (``keep_from_time``; the other edits impose theirs at every step); the window's features are eased
  (``ease_seams``) and its joints appended by ``append_segment(prev, window, c)``. The sequence's
  de-normalised features are concat(window_0, window_1[c:], …), the frame before each window's new ones taking the
  step its context gave it. ``regenerate`` from segment i reuses frames
  before segment i.
* in-betweening: known = the motion (N ≤ maxFrames frames), kept frames [0, a] ∪ [b, N−1] (default a = 19,
  b = N − 20). The features of in-betweening, body-part edits and loops are
  ``pin_kept_root(ease_seams(pin_kept_root(denormalise(x))))``: the kept end stays where it was, and the seams
  are eased (``generate({known})`` gives the inner pin).
* body-part edit: kept groups root+legs on every frame (``keep="lower"``: new upper body) or upper
  (``keep="upper"``: new legs and root).
* loop (K = ``LOOP_ENDS`` = 10): known = the motion X with frames [N−K, N) replaced by X[0:K]; kept frames
  [0, K) ∪ [N−K, N); pinned and eased like an edit (frame N−K's root stays where X had it); the clip is frames [0, N−K) (frame N−K, the copy
  of frame 0, is where it wraps to). In place: the de-normalised root x/z velocity [1:3] is set to 0 on every
  frame (the root turns but does not travel). A longer X (a timeline, N ≤ 60 s) samples only its last window
  W = maxFrames: known = X[N−W:] with its last K frames replaced by X[0:K], kept frames [0, C) ∪ [W−K, W) of the
  window (it continues X[:N−W], which stays), the features X[:N−W] followed by the edited window.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from emdm.model.open import quantises_per_call
from emdm.motion.features import recover_joints
from emdm.motion.mask import KeepRect, keep_mask
from emdm.motion.seams import (CONTACTS, ROOT_STEP, SEAM_ACCEL, SEAM_ACCEL_MIN, SEAM_BLEND_EXTRA, SEAM_BLEND_TAU,  # noqa: F401  (re-exported)
                               SEAM_BLEND_VELOCITY, SEAM_EASE, ease_seams, joint_acceleration, seam_accel,
                               seam_blend_frames, seam_ease_frames)
from emdm.motion.stitch import append_segment, pin_kept_root
from emdm.sampler import SamplingSettings, finish, make_condition, run_together, sample_features, sampling

FPS = 20
OVERLAP = 20               # C: frames of the previous segment a new one starts from (1 s)
MAX_SECONDS = 60.0         # a timeline's total length
LOOP_ENDS = 10             # K: frames inpainted at each end of a loop
# A timeline window imposes its kept second only at steps with t ≤ this (the sampler's keep_from_time; the last step
# always): the earlier steps belong to the prompt. Imposed at every step, the window mostly went on with the previous
# segment's action: 36 timelines of emdm-t2m-web (int8, 10 steps) had the 2nd and 3rd segments recognised as their
# own prompt 31 % and 44 % of the time (single motions 89 %), 47 % / 56 % with t ≤ 0.55 (the steps where guidance
# stops: python -m emdm.eval.editing), seams as smooth (72 of 72 within the bar). 0.35 gave 50 % / 56 %.
TIMELINE_KEEP_FROM = 0.55
MAX_SEED = 2**32 - 1


class EditError(ValueError):
    """A timeline or edit that cannot be made, said in one line naming the segment or argument and the limit."""


@dataclass(frozen=True)
class Segment:
    """One entry of a timeline: a prompt (a text model's prompt or an action model's label), its length in seconds
    and the seed of its sampling."""
    prompt: str
    seconds: float
    seed: int = 0


@dataclass(frozen=True)
class Editor:
    """A model and its sampling settings: ``condition(prompt)`` → condition vector, ``sample`` → normalised x̂_0."""
    step: Callable
    mean: np.ndarray
    std: np.ndarray
    condition: Callable[[str], np.ndarray]
    settings: SamplingSettings = SamplingSettings(guidance=2.5)   # the manifest's, with its guidanceMinTime, x0Smoothing
    max_frames: int = 196
    # a row's result is the same in any batch; False for a step file that quantises activations per call (int8):
    # ``begin`` then runs its loops alone (the TypeScript Generator.batchesExactly)
    batches_exactly: bool = True

    @classmethod
    def open(cls, opened, steps: int | None = None, guidance: float | None = None, models_dir=None) -> "Editor":
        """From ``emdm.model.open.open_model(...)``: its step, mean/std and manifest entry (text prompts are encoded
        once each, by the encoder of ``models_dir``, default the folder a shipped model came from, else
        ``emdm.paths.models_dir()``; an action model takes label names or indices)."""
        ed = cls.from_entry(opened.step, opened.meta, opened.mean, opened.std, steps, guidance,
                            models_dir=opened.models_dir if models_dir is None else models_dir)
        exact = opened.kind != "shipped" or not quantises_per_call(opened.path)
        return ed if exact else dataclasses.replace(ed, batches_exactly=False)

    @classmethod
    def from_entry(cls, step: Callable, meta: dict, mean: np.ndarray, std: np.ndarray, steps: int | None = None,
                   guidance: float | None = None, models_dir=None) -> "Editor":
        """From a step function, its manifest-like entry and mean/std (what ``emdm.model.open.open_model`` gives); a
        text model's prompts are encoded by the encoder in ``models_dir`` (default ``emdm.paths.models_dir()``)."""
        spec = meta["condition"]
        cache: dict[str, np.ndarray] = {}

        def condition(prompt: str) -> np.ndarray:
            if prompt not in cache:
                text = prompt if spec["type"] == "text" else None
                action = prompt if spec["type"] != "text" else None
                cache[prompt] = make_condition(spec, text, action, False, models_dir)
            return cache[prompt]

        return cls(step, np.asarray(mean, np.float32), np.asarray(std, np.float32), condition,
                   SamplingSettings.from_entry(meta, steps, guidance, mean, std), int(meta.get("maxFrames", 196)))

    def sample(self, prompt: str, frames: int, seed: int, known: np.ndarray | None = None,
               keep: np.ndarray | None = None, keep_from_time: float = 1.0) -> np.ndarray:
        """(frames, 263) normalised x̂_0 of one motion (``emdm.sampler.sample_features``)."""
        settings = dataclasses.replace(self.settings, known=known, keep=keep, keep_from_time=keep_from_time)
        return sample_features(self.step, self.condition(prompt), frames, settings, seed)[0]

    def sampling(self, prompt: str, frames: int, seed: int, keep: np.ndarray | None = None,
                 keep_from_time: float = 1.0, stop_at: float | None = None):
        """``sample``'s loop as a generator (``emdm.sampler.sampling``) that stops before t ≤ ``stop_at`` for its
        known motion: ``begin`` runs several together, ``finish`` each."""
        settings = dataclasses.replace(self.settings, keep=keep, keep_from_time=keep_from_time)
        return sampling(self.condition(prompt), frames, settings, seed, stop_at=stop_at)

    def begin(self, runs: list) -> None:
        """Advance ``sampling`` runs together, one model call per step, until each stops (``run_together``); one by
        one where the step file does not batch exactly (``batches_exactly``)."""
        for group in ([runs] if self.batches_exactly else [[r] for r in runs]):
            run_together(group, self.step)

    def finish(self, run, known: np.ndarray | None = None) -> np.ndarray:
        """(frames, 263) normalised x̂_0 of a stopped run, given its known motion (normalised; None: nothing kept)."""
        return finish(run, self.step, known)[0]

    def normalise(self, features: np.ndarray) -> np.ndarray:
        return ((np.asarray(features, np.float32) - self.mean) / self.std).astype(np.float32)

    def denormalise(self, x: np.ndarray) -> np.ndarray:
        return (np.asarray(x, np.float32) * self.std + self.mean).astype(np.float32)


@dataclass(frozen=True)
class Motion:
    """De-normalised features (N, 263) and joints (N, 22, 3), metres."""
    features: np.ndarray
    joints: np.ndarray


@dataclass(frozen=True)
class Timeline(Motion):
    """A generated timeline: ``x`` its features normalised (N, 263), ``frames`` the new frames of each segment."""
    segments: tuple[Segment, ...] = ()
    frames: tuple[int, ...] = ()
    x: np.ndarray = field(default_factory=lambda: np.zeros((0, 263), np.float32))
    overlap: int = OVERLAP

    @property
    def starts(self) -> list[int]:
        """The sequence frame where each segment's new frames begin."""
        return [int(s) for s in np.cumsum([0, *self.frames[:-1]])]


@dataclass(frozen=True)
class Loop(Motion):
    """The looping clip (frames [0, N−K)) and ``full``, the sampled N frames (frame N−K repeats frame 0's pose)."""
    full: Motion | None = None


# ----------------------------------------------------------------------------------------------- checks

def segment_frames(seconds: float, fps: int = FPS) -> int:
    """New frames of a segment: seconds·fps rounded half up (as JavaScript's Math.round)."""
    return int(math.floor(seconds * fps + 0.5))


def _name(k: int, seg: Segment) -> str:
    return f"segment {k + 1} ({seg.prompt.strip()[:40]!r})" if isinstance(seg.prompt, str) and seg.prompt.strip() \
        else f"segment {k + 1}"


def check_timeline(segments: Sequence[Segment], max_frames: int = 196, overlap: int = OVERLAP, fps: int = FPS,
                   max_seconds: float = MAX_SECONDS) -> list[int]:
    """Each segment's new frames; a bad segment is an EditError naming it (1-based) and the limit."""
    if not segments:
        raise EditError("the timeline is empty: add at least one segment (a prompt and its seconds)")
    if len(segments) > max_seconds * fps:         # each lasts a frame or more
        raise EditError(f"the timeline has {len(segments)} segments; at most {max_seconds:g} s in all "
                        f"({int(max_seconds * fps)} one-frame segments)")
    frames = []
    for k, seg in enumerate(segments):
        if not isinstance(seg.prompt, str) or not seg.prompt.strip():
            raise EditError(f"segment {k + 1}: the prompt is empty; say what the character should do")
        s = seg.seconds
        if isinstance(s, bool) or not isinstance(s, (int, float)) or s != s or s in (math.inf, -math.inf):
            raise EditError(f"{_name(k, seg)}: seconds must be a number, got {s!r:.40}")
        if s > max_seconds:           # before any arithmetic: an integer of 400 digits is no float
            shown = f"{s:g}" if isinstance(s, float) or s < 1e300 else "over 1e300"
            raise EditError(f"{_name(k, seg)}: {shown} s is too long; a timeline lasts at most {max_seconds:g} s in all")
        n = segment_frames(s, fps) if s > 0 else 0
        if n < 1:
            shown = f"{s:g}" if isinstance(s, float) or s > -1e300 else "under -1e300"
            raise EditError(f"{_name(k, seg)}: {shown} s is too short; a segment lasts at least {1 / fps:g} s "
                            f"(1 frame at {fps} fps)")
        if isinstance(seg.seed, bool) or not isinstance(seg.seed, (int, np.integer)) or not 0 <= seg.seed <= MAX_SEED:
            raise EditError(f"{_name(k, seg)}: seed must be an integer in 0..{MAX_SEED}, got {seg.seed!r:.40}")
        frames.append(n)
    total = sum(frames)
    if total > max_seconds * fps:
        raise EditError(f"the timeline lasts {total / fps:g} s in all; at most {max_seconds:g} s (shorten or remove a segment)")
    return frames


def window_sizes(n: int, first: bool, max_frames: int = 196, overlap: int = OVERLAP) -> list[int]:
    """New frames of each window of an n-frame segment: one window when it fits (the timeline's ``first`` segment
    up to ``max_frames``, later ones up to cap = max_frames − overlap), else ⌈n/cap⌉ near-equal windows, the first
    n mod m of them one frame longer (``src/edit.ts`` windowSizes)."""
    cap = max_frames - overlap
    if n <= (max_frames if first else cap):
        return [n]
    m = -(-n // cap)
    return [n // m + (1 if j < n % m else 0) for j in range(m)]


def parse_segment(spec: str, seed: int = 0) -> Segment:
    """``"a person walks forward:4"`` → Segment(prompt, 4.0, seed): the text after the last ':' is the seconds."""
    prompt, sep, sec = spec.rpartition(":")
    try:
        seconds = float(sec)
    except ValueError:
        seconds = None
    if not sep or seconds is None:
        raise EditError(f"segment {spec!r}: expected PROMPT:SECONDS, e.g. \"a person walks forward:4\"")
    return Segment(prompt.strip(), seconds, seed)


def read_segments(path, seed: int = 0) -> list[Segment]:
    """Segments from a JSON file: [{"prompt": str, "seconds": number, "seed": int (default seed + k)}, ...]."""
    import json
    from pathlib import Path

    try:
        doc = json.loads(Path(path).read_text())
    except OSError as e:
        raise EditError(f"{path}: cannot read it ({e.strerror or e})") from None
    except UnicodeDecodeError:
        raise EditError(f"{path}: not a JSON text file (it is not UTF-8); give a list of segments as JSON") from None
    except json.JSONDecodeError as e:
        raise EditError(f"{path}:{e.lineno}: not valid JSON ({e.msg})") from None
    except ValueError as e:          # an integer of more than 4300 digits
        raise EditError(f"{path}: not valid JSON ({str(e).splitlines()[0][:100]})") from None
    except RecursionError:
        raise EditError(f"{path}: not valid JSON (nested too deeply; give a flat list of segments)") from None
    if not isinstance(doc, list):
        raise EditError(f"{path}: expected a JSON list of segments [{{\"prompt\": ..., \"seconds\": ...}}, ...]")
    out = []
    for k, e in enumerate(doc):
        if not isinstance(e, dict) or set(e) - {"prompt", "seconds", "seed"} or "prompt" not in e or "seconds" not in e:
            raise EditError(f"{path}: segment {k + 1} must be an object with \"prompt\", \"seconds\" and optionally "
                            f"\"seed\", got {json.dumps(e)[:80]}")
        out.append(Segment(e["prompt"], e["seconds"], e.get("seed", (seed + k) % (MAX_SEED + 1))))
    return out


def _check_motion(features, what: str, max_frames: int, min_frames: int, span: str = "one model window") -> np.ndarray:
    f = np.asarray(features, np.float32)
    if f.ndim != 2 or f.shape[1] != 263:
        raise EditError(f"{what}: the motion's features have shape {f.shape}, expected (frames, 263) de-normalised")
    if not min_frames <= len(f) <= max_frames:
        raise EditError(f"{what}: the motion has {len(f)} frames; this edit needs {min_frames}..{max_frames} "
                        f"({min_frames / FPS:g}..{max_frames / FPS:g} s, {span})")
    if not np.isfinite(f).all():
        raise EditError(f"{what}: the motion's features hold NaN/Infinity")
    return f


def _check_prompt_seed(what: str, prompt: str, seed: int) -> None:
    if not isinstance(prompt, str) or not prompt.strip():
        raise EditError(f"{what}: the prompt is empty; say what the character should do")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed <= MAX_SEED:
        raise EditError(f"{what}: seed must be an integer in 0..{MAX_SEED}, got {seed!r}")


# ----------------------------------------------------------------------------------------------- timeline

def timeline(model: Editor, segments: Sequence[Segment], overlap: int = OVERLAP, previous: Timeline | None = None,
             start: int = 0, together: bool = False) -> Timeline:
    """Generate ``segments`` one after the other, each continuing the last ``overlap`` frames of the sequence so far.
    With ``previous`` (a timeline of the same first ``start`` segments) its frames before segment ``start`` are
    kept as they are and only segments ``start``.. are generated. ``together`` (the page's way, src/edit.ts with
    ``begin``): every window's steps above ``TIMELINE_KEEP_FROM`` run first, all windows in one model call per step
    (its context frames sit those steps out, so it needs nothing from the window before), then each window is
    finished in turn; the same motion (an int8 step file begins them one by one: ``Editor.batches_exactly``)."""
    segments = tuple(segments)
    frames = check_timeline(segments, model.max_frames, overlap)
    if not 0 <= start < len(segments):
        raise EditError(f"start segment {start + 1} outside 1..{len(segments)}")
    if start > 0:
        if previous is None:
            raise EditError(f"regenerating from segment {start + 1} needs the previous timeline")
        if previous.overlap != overlap or tuple(previous.segments[:start]) != segments[:start]:
            raise EditError(f"regenerating from segment {start + 1}: segments 1..{start} must be those of the previous "
                            f"timeline (and its overlap {previous.overlap})")
        kept = sum(frames[:start])
        feats, joints = previous.features[:kept], previous.joints[:kept]
        last = window_sizes(frames[start - 1], start == 1, model.max_frames, overlap)[-1]
        before = last + min(overlap, kept - last)      # frames of the window before segment ``start`` (its c + n)
    for k in range(start, len(segments)):          # every condition first: a bad prompt stops before any sampling
        try:
            model.condition(segments[k].prompt)
        except ValueError as e:
            raise EditError(f"{_name(k, segments[k])}: {e}") from None
    # (segment, seed, new frames n, frames c kept from the sequence before): every window's overlap follows from
    # the frames before it, so the plan holds it before anything is sampled
    plan, at = [], sum(frames[:start])
    for k in range(start, len(segments)):
        for j, n in enumerate(window_sizes(frames[k], k == 0, model.max_frames, overlap)):
            plan.append((k, (segments[k].seed + j) % (MAX_SEED + 1), n, min(overlap, at)))
            at += n
    runs = []
    if together:     # every window's early steps at once
        runs = [model.sampling(segments[k].prompt, c + n, seed, context_keep(c, n) if c else None, TIMELINE_KEEP_FROM,
                               TIMELINE_KEEP_FROM) for k, seed, n, c in plan]
        model.begin(runs)
    for i, (k, seed, n, c) in enumerate(plan):
        prompt = segments[k].prompt
        if c == 0:
            feats = model.denormalise(model.finish(runs[0]) if runs else model.sample(prompt, n, seed))
            joints = recover_joints(feats).astype(np.float32)
            before = n
            continue
        known = np.zeros((c + n, feats.shape[1]), np.float32)
        context = feats[-c:].copy()
        if c >= 2:      # its last frame's step is into the window: the step before it (as ease_seams takes it)
            context[-1, ROOT_STEP] = context[-2, ROOT_STEP]
        known[:c] = model.normalise(context)
        keep = context_keep(c, n)
        x = model.finish(runs[i], known) if runs else model.sample(prompt, c + n, seed, known, keep, TIMELINE_KEEP_FROM)
        w = ease_seams(model.denormalise(x), keep, accel=seam_accel(feats[-before:]))
        before = c + n
        joints = append_segment(joints, recover_joints(w), c)
        feats = np.concatenate([feats[:-1], context[-1:], w[c:]])
    return Timeline(feats, np.asarray(joints, np.float32), segments, tuple(frames), model.normalise(feats), overlap)


def context_keep(c: int, n: int) -> np.ndarray:
    """A window's keep mask: its first c frames (the sequence's last c) on every channel, then n free frames."""
    return keep_mask(c + n, [KeepRect(frames=((0, c - 1),))])


def regenerate(model: Editor, tl: Timeline, i: int, segment: Segment | None = None, together: bool = False) -> Timeline:
    """``tl`` with segment ``i`` (0-based) replaced by ``segment`` (default: the same with seed + 1) and every later
    segment generated again (they continue it); segments before ``i`` are untouched."""
    if not 0 <= i < len(tl.segments):
        raise EditError(f"segment {i + 1} outside 1..{len(tl.segments)}")
    old = tl.segments[i]
    segs = list(tl.segments)
    segs[i] = segment if segment is not None else Segment(old.prompt, old.seconds, (old.seed + 1) % (MAX_SEED + 1))
    return timeline(model, segs, tl.overlap, previous=tl, start=i, together=together)


# ----------------------------------------------------------------------------------------------- edits

def _edit(model: Editor, features: np.ndarray, prompt: str, seed: int, keep: np.ndarray,
          known: np.ndarray | None = None) -> Motion:
    """Sample with ``known`` (de-normalised, default ``features``) kept where ``keep``; pin the kept root, ease the
    seams, pin again (the easing moves the free frames' root)."""
    known = features if known is None else known
    x = model.sample(prompt, len(features), seed, model.normalise(known), keep)
    f = pin_kept_root(ease_seams(pin_kept_root(model.denormalise(x), keep, known), keep), keep, known)
    return Motion(f, recover_joints(f).astype(np.float32))


def inbetween(model: Editor, features: np.ndarray, prompt: str, seed: int, keep_until: int | None = None,
              keep_from: int | None = None) -> Motion:
    """Keep frames [0, keep_until] and [keep_from, N−1] of ``features`` (default: the first and last second) and
    regenerate the frames between from ``prompt``."""
    what = "in-betweening"
    _check_prompt_seed(what, prompt, seed)
    f = _check_motion(features, what, model.max_frames, 3)
    n = len(f)
    a = FPS - 1 if keep_until is None else keep_until
    b = n - FPS if keep_from is None else keep_from
    if not (isinstance(a, (int, np.integer)) and isinstance(b, (int, np.integer)) and 0 <= a and b <= n - 1
            and b - a >= 2):
        raise EditError(f"{what}: kept frames 0..{a} and {b}..{n - 1} leave no frame to regenerate in a {n}-frame "
                        f"motion; keep less (0 ≤ first end, first end + 2 ≤ last start ≤ {n - 1})")
    keep = keep_mask(n, [KeepRect(frames=((0, int(a)), (int(b), None)))])
    return _edit(model, f, prompt, seed, keep)


BODY_KEEP = {"lower": ("root", "legs"), "upper": ("upper",)}


def edit_body(model: Editor, features: np.ndarray, prompt: str, seed: int, keep: str = "lower") -> Motion:
    """Keep the lower body (legs and root; ``keep="lower"``) or the upper body (``keep="upper"``) of ``features`` on
    every frame and regenerate the rest from ``prompt``."""
    what = "body-part edit"
    if keep not in BODY_KEEP:
        raise EditError(f"{what}: keep must be 'lower' (legs and root) or 'upper', got {keep!r}")
    _check_prompt_seed(what, prompt, seed)
    f = _check_motion(features, what, model.max_frames, 1)
    return _edit(model, f, prompt, seed, keep_mask(len(f), [KeepRect(groups=BODY_KEEP[keep])]))


def loop(model: Editor, features: np.ndarray, prompt: str, seed: int, ends: int = LOOP_ENDS,
         in_place: bool = False) -> Loop:
    """A seamless loop of ``features`` (made from ``prompt``): its last ``ends`` frames are inpainted to be its first
    ones, so the clip [0, N−ends) wraps onto its first frame; ``in_place`` removes the root's x/z travel. A motion
    longer than the model's window (a timeline, up to MAX_SECONDS) has only its last window W = maxFrames sampled:
    that window's first OVERLAP frames are kept too (it continues the motion before it, which stays as it was)."""
    what = "loop"
    _check_prompt_seed(what, prompt, seed)
    if not isinstance(ends, (int, np.integer)) or ends < 1:
        raise EditError(f"{what}: ends must be a positive number of frames, got {ends!r}")
    f = _check_motion(features, what, int(MAX_SECONDS * FPS), 2 * ends + 1, "a timeline's longest")
    n = len(f)
    w = min(n, model.max_frames)                    # the frames sampled: [n − w, n)
    first = ends if w == n else OVERLAP             # kept at the window's start
    if w - ends - first < 1:
        raise EditError(f"{what}: the model's window ({model.max_frames} frames) leaves no frame to regenerate between "
                        f"the {first} kept at its start and the {ends} at its end")
    known = f[n - w:].copy()
    known[w - ends:] = f[:ends]
    keep = keep_mask(w, [KeepRect(frames=((0, first - 1), (w - ends, None)))])
    full = np.concatenate([f[: n - w], _edit(model, f[n - w:], prompt, seed, keep, known).features])
    if in_place:
        full = full.copy()
        full[:, 1:3] = 0.0
    joints = recover_joints(full).astype(np.float32)
    return Loop(full[: n - ends], joints[: n - ends], Motion(full, joints))
