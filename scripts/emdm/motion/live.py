"""The live stream (issue 33) for evaluation: motion made ahead of playback in short windows, each a timeline window
continuing the motion being played, new prompts joining as soon as their window exists. The TypeScript twin is
``src/live/core.ts`` (the bookkeeping) with ``src/live/simulate.ts`` (a simulated clock); the ``tiny-live`` parity
fixture (``python -m emdm.motion.live_fixture``) checks both. The contract is in ``src/live/core.ts``'s header.

    model = Editor.open(open_model("emdm-t2m-web"), steps=4)
    core = LiveCore(model, "a person walks forward", seed=1)
    sim = simulate(core, 600, [(100, "a person waves"), (220, "a person jumps")], cost=[8])
    sim.joints      # (600, 22, 3) as played, world coordinates; sim.windows: (request, accepted at, first new frame)

What is played is the display: each window decoded as a generated motion is shown (``emdm.motion.decode``: σ = 1
smoothing, feet cleaned up), joined causally (frames up to the playhead never change; the difference at the join is
faded out over DISPLAY_FADE frames). The lead adapts to what windows cost (frames played while one was generated):
raised to ⌈LEAD_SAFETY · cost⌉ (at most ``max_lead``) when short of it, lowered by LEAD_STEP_DOWN frames (never below
``lead``) after a window that cost at most a quarter of it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from emdm import skeleton as sk
from emdm.motion.decode import decode_joints
from emdm.motion.edit import OVERLAP, TIMELINE_KEEP_FROM, EditError, Editor, context_keep
from emdm.motion.features import recover_joints
from emdm.motion.seams import ROOT_STEP, ease_seams, seam_accel
from emdm.motion.stitch import align_segment

# New frames of a window (3 s at 20 fps). With 40 (2 s) the live segments of the covered actions were recognised as
# their prompt less often than the same prompts alone (emdm-t2m-web slice 5, int8, 10 steps, python -m emdm.eval.seams,
# 180 prompt changes, seeds 0 / 1 / 2: 86 / 89 / 86 % against 93 / 94 / 92 %, p 0.006 / 0.006 / 0.021): each window of
# a jog in a circle, a throw or a climb began again from a second of context, and the segment read as a run, a walk.
# With 60: 92 / 91 / 92 % against the same alone motions (p 0.50 / 0.07 / 0.71), the kinematic rules as alone (93 / 93 /
# 94 % against 94 / 95 / 92 %), blends within 1.5x the p95 elsewhere 169 / 175 / 168 of 180 (40: 172 / 178 / 172; the
# same spans mid-segment, nothing blended: 171 / 170 / 164). 80 was as good (90 / 92 %) at a costlier prompt window;
# a 40-frame prompt window before 80-frame ones was not (90 / 87 %, p 0.09 / 0.002). docs/RESULTS.md "Seams and loops".
WINDOW = 60
LEAD = 30               # the next window starts when fewer frames are buffered after the playhead
PROMPT_LEAD = 8         # a prompt's window continues the motion this many frames after the playhead
RECORD_SECONDS = 60     # kept behind the playhead
COAST = 10              # frames played back at a time when nothing is buffered (an underrun)
RECENTRE_M = 2.0        # the root moves back towards the stage's centre by whole metres once this far from it
MAX_LEAD = 120          # the lead is never raised past this (6 s)
LEAD_SAFETY = 2         # a lead short of this many times a window's cost is raised to it
LEAD_STEP_DOWN = 4      # frames the lead comes down after a comfortably early window
DISPLAY_PAD = 3         # a window's display replaces the buffer's from this many frames before its join
DISPLAY_FADE = 6        # frames over which its difference to the buffer's display is faded out
# A prompt's window imposes its kept second only at steps with t ≤ this and the last (later windows of the same prompt:
# the timelines' TIMELINE_KEEP_FROM, 0.55), so more of its steps belong to the new prompt. With 0.55 the motion went on
# with the previous action into the new prompt's segment: over 180 prompt changes (emdm-t2m-web, int8, 10 steps; python -m
# emdm.eval.seams, seeds 0 and 1) its segments were recognised as their prompt 85 / 82 % of the time against 94 / 97 % for
# the same prompts alone (the segments' first halves 78 / 80 %); kept from t ≤ 0.4 / 0.3 / 0.2: 88 / 93 / 93 % (seed 0),
# 88 / 91 % at 0.3 / 0.2 (seed 1), the blends as smooth or smoother (seed 0: 155 / 158 / 159 / 162 of 180 within 1.5× the
# p95 elsewhere, seed 1: 166 / 167 / 164 at 0.55 / 0.3 / 0.2). At 10 steps (t = 0.10, 0.20, ...) 0.2 and this value
# impose the context at the last step only; 0.15 keeps it so at every step count up to 10 (T = 10: t_2 = 0.2008).
PROMPT_KEEP_FROM = 0.15
FPS = 20


@dataclass
class Request:
    id: int
    prompt: str
    seed: int
    frames: int
    c: int
    cut: int
    prompted: bool
    start: int                          # the playhead when it was requested (its cost is counted from here)
    known: np.ndarray | None = None     # (c + W, 263) de-normalised, its first c rows kept


@dataclass
class LiveCore:
    model: Editor
    prompt: str
    seed: int = 0
    window: int = WINDOW
    lead: int = LEAD                    # the starting and lowest lead; `lead_now` is the one in use
    max_lead: int = MAX_LEAD
    prompt_lead: int = PROMPT_LEAD
    record_seconds: float = RECORD_SECONDS
    base: int = 0
    features: np.ndarray = field(default_factory=lambda: np.zeros((0, 263), np.float32))
    joints: np.ndarray = field(default_factory=lambda: np.zeros((0, 22, 3), np.float32))
    display: np.ndarray = field(default_factory=lambda: np.zeros((0, 22, 3), np.float32))  # as shown (decode_joints)
    lead_now: int = -1
    origin: tuple = (0.0, 0.0)
    pending: Request | None = None
    requested: int = 0
    underruns: int = 0

    def __post_init__(self):
        self.prompt = _check_prompt(self.prompt)
        if OVERLAP + self.window > self.model.max_frames:
            raise EditError(f"live: a window of {self.window} new frames + {OVERLAP} kept exceeds the model's {self.model.max_frames}")
        if self.max_lead < self.lead:
            raise EditError(f"live: maxLead ({self.max_lead} frames) must be at least lead ({self.lead})")
        self.lead_now = self.lead

    @property
    def end(self) -> int:
        return self.base + len(self.features)

    def _next(self, cut: int, prompted: bool, start: int) -> Request:
        seed = (self.seed + self.requested) % 2**32
        self.requested += 1
        if len(self.features) == 0:
            self.pending = Request(self.requested, self.prompt, seed, OVERLAP + self.window, 0, 0, prompted, start)
            return self.pending
        known = np.zeros((OVERLAP + self.window, 263), np.float32)
        known[:OVERLAP] = self.features[cut - OVERLAP - self.base:cut - self.base]
        known[OVERLAP - 1, ROOT_STEP] = known[OVERLAP - 2, ROOT_STEP]     # its step is into the window (as in a timeline)
        self.pending = Request(self.requested, self.prompt, seed, OVERLAP + self.window, OVERLAP, cut, prompted, start,
                               known)
        return self.pending

    def request(self, p: int) -> Request | None:
        """The window to start at playhead p (None: one is under way, or enough is buffered)."""
        if self.pending is not None or (len(self.features) and self.end - 1 - p >= self.lead_now):
            return None
        return self._next(self.end, False, p)

    def new_prompt(self, prompt: str, p: int) -> Request:
        """A prompt at playhead p: the window in preparation is dropped, the new one continues frame p + prompt_lead."""
        self.prompt = _check_prompt(prompt)
        self.pending = None
        if len(self.features) == 0:
            return self._next(0, True, p)
        return self._next(min(self.end, max(self.base + OVERLAP, p + self.prompt_lead)), True, p)

    def generate(self, req: Request) -> np.ndarray:
        """The request's raw de-normalised features (the model's sampling, a timeline window's keep; its context imposed
        from PROMPT_KEEP_FROM on in a prompt's window, from TIMELINE_KEEP_FROM on in the others)."""
        m = self.model
        if req.known is None:
            return m.denormalise(m.sample(req.prompt, req.frames, req.seed))
        keep = context_keep(req.c, req.frames - req.c)
        keep_from = PROMPT_KEEP_FROM if req.prompted else TIMELINE_KEEP_FROM
        return m.denormalise(m.sample(req.prompt, req.frames, req.seed, m.normalise(req.known) * keep, keep, keep_from))

    def accept(self, req: Request, raw: np.ndarray, p: int) -> tuple[int, bool] | None:
        """Join a generated window at playhead p: (its first new frame, dropped); None for a stale one."""
        if self.pending is None or self.pending.id != req.id:
            return None
        self.pending = None
        if req.c == 0 and len(self.features) == 0:
            self.features = np.asarray(raw, np.float32)
            self.joints = recover_joints(self.features).astype(np.float32)
            self.display = decode_joints(self.features)
            return 0, False
        c, cut, n = req.c, req.cut, req.frames
        self.extend(p)
        self._adapt(max(0, p - req.start))
        before = min(n, cut - self.base)
        rows = lambda a, b: self.features[a - self.base:b - self.base]  # noqa: E731
        f = ease_seams(raw, context_keep(c, n - c), accel=seam_accel(rows(cut - before, cut)))
        late = max(0, p + 1 - cut)
        k = c + late
        if k >= n:
            return cut, True
        if late:
            f = f.copy()
            f[c - 1:k] = rows(cut - 1, cut + late)       # as shown (the first easing took a step out of row c − 1)
            f = ease_seams(f, context_keep(k, n - k), accel=seam_accel(rows(cut + late - before, cut + late)))
        at = cut + late
        prev = self.joints[at - k - self.base:at - self.base]
        rec = recover_joints(f)
        aligned = align_segment(prev, rec, k)
        shown = align_segment(prev, decode_joints(f), k, ref=rec)
        s = max(p + 1, at - DISPLAY_PAD, self.base)
        ks = s - self.base
        display = np.concatenate([self.display[:ks], shown[k - (at - s):]]).astype(np.float32)
        if ks > 0:      # the difference at s − 1 (the last frame kept) faded out over DISPLAY_FADE frames
            diff = self.display[ks - 1].astype(np.float64) - shown[k - (at - s) - 1]
            for i in range(min(DISPLAY_FADE, len(display) - ks)):
                display[ks + i] += np.float32(1 - (i + 1) / (DISPLAY_FADE + 1)) * diff
                low = display[ks + i, list(sk.FOOT_JOINTS), 1].min()
                if low < 0:     # the floor stays under the feet (the clean-up's floor step)
                    display[ks + i, :, 1] -= low
        self.features = np.concatenate([self.features[:at - self.base], np.asarray(f[k:], np.float32)])
        if at - 1 >= self.base:      # the step into the window's first new frame is the seam's (ease_seams)
            self.features[at - 1 - self.base, ROOT_STEP] = f[k - 1, ROOT_STEP]
        self.joints = np.concatenate([self.joints[:at - self.base], np.asarray(aligned[k:], np.float32)])
        self.display = display
        self._recentre(p)
        self.trim(p)
        return at, False

    def _adapt(self, cost: int) -> None:
        """The lead after a window that cost ``cost`` frames (src/live/core.ts's header)."""
        need = int(np.ceil(LEAD_SAFETY * cost))
        if need > self.lead_now:
            self.lead_now = min(self.max_lead, need)
        elif 2 * need <= self.lead_now:
            self.lead_now = max(self.lead, self.lead_now - LEAD_STEP_DOWN)

    def extend(self, p: int) -> None:
        """Make frame p buffered: an underrun plays the motion back from its last frame (mirrored)."""
        if len(self.features) == 0 or p < self.end:
            return
        self.underruns += 1
        while p >= self.end:
            n = min(COAST, len(self.features) - 1)
            idx = np.arange(len(self.features) - 2, len(self.features) - 2 - n, -1)
            f = self.features[idx].copy()
            f[:, 0:3] *= -1
            f[:, 193:259] *= -1
            self.features = np.concatenate([self.features, f])
            self.joints = np.concatenate([self.joints, self.joints[idx]])
            self.display = np.concatenate([self.display, self.display[idx]])

    def _recentre(self, p: int) -> None:
        """Move the stage back under the root shown at frame p (src/live/core.ts's header)."""
        root = self.display[min(max(p, self.base), self.end - 1) - self.base, 0]
        sx, sz = (float(np.trunc(v)) if abs(v) > RECENTRE_M else 0.0 for v in (root[0], root[2]))
        if sx or sz:
            self.joints, self.display = self.joints.copy(), self.display.copy()
            for a in (self.joints, self.display):
                a[..., 0] -= np.float32(sx)
                a[..., 2] -= np.float32(sz)
            self.origin = (self.origin[0] + sx, self.origin[1] + sz)

    def trim(self, p: int) -> None:
        frm = min(p - round(self.record_seconds * FPS), self.end - OVERLAP - self.window)
        if frm > self.base:
            self.features = self.features[frm - self.base:]
            self.joints = self.joints[frm - self.base:]
            self.display = self.display[frm - self.base:]
            self.base = frm

    def frame_at(self, p: int, centre: int | None = None) -> np.ndarray:
        """Joints of frame p as shown (display, (22, 3)), stage coordinates; the stage first moved under the root of
        frame ``centre`` (default p; the playhead: frames read ahead of it must not move the stage from what plays)."""
        q = max(p, self.base)
        self.extend(q)
        self._recentre(max(p if centre is None else centre, self.base))
        return self.display[q - self.base].copy()


@dataclass
class Simulated:
    joints: np.ndarray                              # (frames, 22, 3) as played, world coordinates
    windows: list = field(default_factory=list)     # (request, accepted at p, first new frame or None, dropped)


def simulate(core: LiveCore, frames: int, prompts, cost) -> Simulated:
    """``src/live/simulate.ts``'s clock: at each frame p, (1) the window under way is generated and accepted once
    p ≥ its start + its cost (cost[(id − 1) mod len]), (2) a prompt at p replaces it, (3) with none under way one may
    start, (4) frame p is played."""
    out = Simulated(np.zeros((frames, 22, 3), np.float32))

    def join(req: Request, p: int) -> None:
        r = core.accept(req, core.generate(req), p)
        out.windows.append((req, p, None if r is None else r[0], True if r is None else r[1]))

    join(core.request(0), 0)
    running = None
    for p in range(frames):
        if running is not None and p >= running[1]:
            req, running = running[0], None
            if core.pending is not None and core.pending.id == req.id:
                join(req, p)
        for at, prompt in prompts:
            if at == p:
                req = core.new_prompt(prompt, p)
                running = (req, p + cost[(req.id - 1) % len(cost)])
        if running is None:
            req = core.request(p)
            if req is not None:
                running = (req, p + cost[(req.id - 1) % len(cost)])
        j = core.frame_at(p)
        j[:, 0] += core.origin[0]
        j[:, 2] += core.origin[1]
        out.joints[p] = j
    return out


def _check_prompt(prompt) -> str:
    if not isinstance(prompt, str) or not prompt.strip():
        raise EditError("live: the prompt is empty; say what the character should do")
    return prompt.strip()


__all__ = ["LiveCore", "Request", "Simulated", "simulate"]
