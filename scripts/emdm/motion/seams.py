"""Seams between kept and generated frames: how far and how fast an edit's generated frames are eased into the kept
ones (timelines, in-betweens, loops). The twin of ``src/motion/seams.ts`` (the same arithmetic; parity-tested through
``emdm.motion.edit``'s fixtures), used by ``emdm.motion.edit``."""
from __future__ import annotations

import math

import numpy as np

from emdm.motion.features import recover_joints

FPS = 20
SEAM_EASE = 10             # M: the fewest generated frames over which a seam's offset is eased out (0.5 s)
SEAM_ACCEL = 20.0          # A: the easing's peak joint acceleration, m/s² (a larger jump is eased over more frames)
SEAM_BLEND_EXTRA = 4       # the cross-fade into the generated frames lasts this many frames longer than the offset's fade
SEAM_BLEND_TAU = 3.0       # frames: the kept side's velocity, continued into the cross-fade, decays with this time constant
#                            (or a longer one, where a fast kept side would stop faster than the seam's accel)
SEAM_BLEND_VELOCITY = 3    # frames: the velocity the cross-fade continues is the kept side's mean over up to this many
#                            steps (over one, a foot's one-frame jitter of 0.45 m at a walk's end was carried on: it slid
#                            2 m in 6 frames and 0.19 m under the floor after a walk → wave seam; python -m emdm.eval.seams)
# A timeline seam's easing keeps its peak joint acceleration within the 95th percentile of the window before it
# (``seam_accel``), between these bounds, m/s²: a calm motion is not ended by a fade faster than anything in it.
SEAM_ACCEL_MIN = 5.0
CONTACTS = slice(259, 263)  # foot contact channels: not eased
ROOT_STEP = slice(0, 3)     # root angular and linear velocity: frame t's is the root's step from t to t + 1


def seam_ease_frames(offset: np.ndarray, ease: int = SEAM_EASE, accel: float = SEAM_ACCEL, fps: int = FPS) -> int:
    """Frames m over which ``ease_seams`` fades a seam's ``offset`` (263-d, de-normalised): at least ``ease``, and
    enough that the fade's peak joint acceleration, jump·(π/m)²/2·fps², stays within ``accel`` m/s², where jump is
    the largest offset of a joint position (root height [3], a root-relative joint [4:67], metres):
    m = max(ease, ⌈π·√(jump·fps²/(2·accel))⌉). A 1.5 m jump (standing → lying) takes 13 frames, up to 1 m 10."""
    jump = _reach(offset)
    return max(ease, math.ceil(math.pi * math.sqrt(jump * fps * fps / (2 * accel)) - 1e-9))


def _reach(d: np.ndarray) -> float:
    """The largest joint-position distance in a feature difference d (..., ≥ 67): root height [3], root-relative
    joints [4:67], metres."""
    d = np.asarray(d, np.float64)
    return float(max(np.abs(d[..., 3]).max(), np.linalg.norm(d[..., 4:67].reshape(*d.shape[:-1], 21, 3), axis=-1).max()))


def joint_acceleration(joints: np.ndarray, fps: int = FPS) -> np.ndarray:
    """(F,) per frame t = 1..F−2 (0 at the ends): max over joints of |J[t+1] − 2J[t] + J[t−1]|·fps², m/s²."""
    j = np.asarray(joints, np.float64)
    a = np.zeros(len(j))
    a[1:-1] = np.linalg.norm(j[2:] - 2 * j[1:-1] + j[:-2], axis=2).max(axis=1) * fps**2
    return a


def seam_accel(features_before: np.ndarray) -> float:
    """The peak joint acceleration (m/s²) a timeline seam's easing keeps to: the 95th percentile of
    ``joint_acceleration`` over the window before it (de-normalised features, its joints by ``recover_joints``),
    within [``SEAM_ACCEL_MIN``, ``SEAM_ACCEL``]. The seam is measured against its timeline (issue 14: ≤ 1.5× the
    95th percentile within), and a calm motion's is a third of a real clip's: climb → walk backward → lie down
    (emdm-t2m-web, int8, 10 steps) had 6.6 m/s², and its lie-down, eased to 20, reached 1.77× at the seam."""
    f = np.asarray(features_before)
    if len(f) < 3:
        return SEAM_ACCEL
    p95 = float(np.percentile(joint_acceleration(recover_joints(f).astype(np.float32))[1:-1], 95))
    return min(SEAM_ACCEL, max(SEAM_ACCEL_MIN, p95))


def seam_blend_frames(reach: float, accel: float = SEAM_ACCEL, fps: int = FPS) -> int:
    """Frames b of a cross-fade over a distance ``reach`` (m) whose peak acceleration, reach·(π/(b+1))²/2·fps²,
    stays within ``accel``: b = ⌈π·√(reach·fps²/(2·accel))⌉ − 1."""
    return math.ceil(math.pi * math.sqrt(reach * fps * fps / (2 * accel)) - 1e-9) - 1


def ease_seams(features: np.ndarray, keep: np.ndarray, ease: int = SEAM_EASE, accel: float = SEAM_ACCEL) -> np.ndarray:
    """Ease out the jump between kept frames and generated ones (de-normalised ``features`` (F, D), ``keep`` (F, D)).

    Masked sampling keeps the known frames exactly, but the model's first generated frame need not continue them:
    measured on emdm-t2m-web at 10 steps, the joint acceleration at a timeline seam was up to 117× the motion's 95th
    percentile, and where the new prompt's pose is far from the kept one the model jumps to it in one frame
    (lie-down after raised hands: root height 0.89 → 0.08 m). For every run [s, e) of frames with no kept channel
    next to a fully kept frame, the offset between where the kept side leads (its last frame plus the mean of the
    velocities on both sides of the seam) and the first generated frame is added to the generated frames, fading out
    over m = min(``seam_ease_frames``(o), e − s) frames with w_i = (1 + cos(π·i/m))/2 (left: f[s+i] += w_i·o_L;
    right, mirrored: f[e−1−i] += w_i·o_R; i = 0..m−1); both offsets are taken from the un-eased features. A fixed
    m = 10 left that 1.5 m jump a 0.5 s fall (29 m/s², 2× the timeline's 95th percentile at the seam, 3.8× after
    it); m from the jump keeps the fade's peak acceleration within ``accel``: 20 m/s², the median real test clip's
    95th percentile of joint acceleration (892 clips). The fade is a blend, not a motion the model made, and the
    action classifier reads a long one as another action: over 36 timelines of emdm-t2m-web, accel 5 / 10 / 20 m/s²
    and the fixed 10 frames gave 72 / 72 / 72 / 71 of 72 seams within the bar and lie-down segments recognised
    33 / 44 / 61 / 67 %.

    Then each seam is cross-faded: the offset fixes where the first generated frame is, not how the model moves next,
    and its first frames can swing a limb through a metre in two frames (a timeline's raised hands dropped to the
    sides: 216 m/s² at the frame after the seam, 13× the timeline's 95th percentile, with x̂0 smoothed). The kept side's
    motion continued, c_i = k + v·τ·(1 − exp(−(i+1)/τ)) (k the kept frame next to the seam, v its mean velocity over
    the up to ``SEAM_BLEND_VELOCITY`` kept frames before it, 0 without one; τ = max(``SEAM_BLEND_TAU``, ``_reach``(v)·fps²/``accel``) frames, so that
    stopping the kept side's motion, peak |v|/τ·fps², stays within accel), is blended into the eased frames:
    f[s+i] ← (1 − β_i)·c_i + β_i·f[s+i], β_i = (1 − cos(π(i+1)/(b+1)))/2, over b = min(m + ``SEAM_BLEND_EXTRA``, e − s)
    frames (mirrored on the right, after the left). A jump in the generated frames is scaled down by the β of where
    it falls, so an early one hardly shows; where the model continues smoothly, c and f agree and little changes.
    Over 36 timelines (x̂0 smoothed, seeds 0 and 1000): 58–60 → 72 of 72 seams within 1.5× the 95th percentile,
    seam foot skate 1.30–1.35 → 1.16–1.23× the skate within segments. Foot contacts [259:263] stay. Frames that
    keep only some channels (body-part edits) are neither kept nor free: nothing is eased next to them.

    First of all, at a left seam with two kept frames before it, the last kept frame's root velocity [0:3]
    (``ROOT_STEP``) becomes the one before it: a frame's root velocity is its step to the next frame, and the next
    frame is now a generated one. In a timeline (or a live stream) the kept frame ended the window before, whose step
    out of it was never taken: the model's last frames wander (emdm-t2m-web, int8, 10 steps: climb → walk backward →
    lie down sped from 0.68 to 1.03 m/s on that step, 1.9× the timeline's 95th percentile of root acceleration; 3 of
    144 timeline seams over 1.5×, each such a step); in an in-between it was the step to the frame now replaced. Only
    the root of generated frames moves (every kept frame decodes where it was). Callers that keep their own copy of
    the kept frames take the same step: ``emdm.motion.edit.timeline`` gives it to the window's context before
    sampling, ``emdm.motion.live`` writes it back into its buffer."""
    f = np.asarray(features, np.float64).copy()
    k = np.asarray(keep).astype(bool)
    kept, free = k.all(1), ~k.any(1)
    n = len(f)
    offsets, blends = [], []
    for s in np.flatnonzero(free[2:] & kept[1:-1] & kept[:-2]) + 2:   # a left seam with two kept frames before it
        f[s - 1, ROOT_STEP] = f[s - 2, ROOT_STEP]

    def fade(o):
        o = o.copy()
        o[CONTACTS] = 0
        m = min(seam_ease_frames(o, ease, accel), e - s)
        return o, 0.5 * (1 + np.cos(np.pi * np.arange(m) / m)), min(m + SEAM_BLEND_EXTRA, e - s)

    t = 0
    while t < n:
        if not free[t]:
            t += 1
            continue
        s = t
        while t < n and free[t]:
            t += 1
        e = t
        if s >= 1 and kept[s - 1]:
            beyond = s - 2 if s >= 2 and kept[s - 2] else None          # a second kept frame: the kept side's velocity
            v = [f[s - 1] - f[beyond]] if beyond is not None else []
            v += [f[s + 1] - f[s]] if s + 1 < e else []
            o, w, b = fade(f[s - 1] + (np.mean(v, 0) if v else 0) - f[s])
            offsets += [(s + i, w[i] * o) for i in range(len(w))]
            blends.append((s - 1, _kept_back(kept, s - 1, -1), s, 1, b, e - s))
        if e < n and kept[e]:
            beyond = e + 1 if e + 1 < n and kept[e + 1] else None
            v = [f[beyond] - f[e]] if beyond is not None else []
            v += [f[e - 1] - f[e - 2]] if e - 2 >= s else []
            o, w, b = fade(f[e] - (np.mean(v, 0) if v else 0) - f[e - 1])
            offsets += [(e - 1 - i, w[i] * o) for i in range(len(w))]
            blends.append((e, _kept_back(kept, e, 1), e - 1, -1, b, e - s))
    for row, o in offsets:
        f[row] += o
    for k0, k1, at, step, b, most in blends:     # in order: a run's left seam, then its right one
        v = (f[k0] - f[k1]) / abs(k0 - k1) if k1 is not None else np.zeros(f.shape[1])
        i = np.arange(most, dtype=np.float64)[:, None]
        # the kept side continued, its velocity v decaying at a rate (peak |v|/τ·fps²) within accel
        tau = max(SEAM_BLEND_TAU, _reach(v) * FPS**2 / accel)
        c = f[k0] + v * (tau * (1 - np.exp(-(i + 1) / tau)))
        # longer where the model's first frames leave the continued motion further than the fade's b can take
        b = min(max(b, seam_blend_frames(_reach(f[at + step * np.arange(b)] - c[:b]), accel)), most)
        rows, i, c = at + step * np.arange(b), i[:b], c[:b]
        beta = 0.5 * (1 - np.cos(np.pi * (i + 1) / (b + 1)))
        blended = (1 - beta) * c + beta * f[rows]
        blended[:, CONTACTS] = f[rows][:, CONTACTS]
        f[rows] = blended
    return f.astype(np.float32)


def _kept_back(kept: np.ndarray, k0: int, step: int) -> int | None:
    """The farthest frame k0 + step·q, q = 1..``SEAM_BLEND_VELOCITY``, with every frame from k0 to it kept (None: k0 + step
    is not kept): the kept side's velocity at a seam is (f[k0] − f[k]) / q."""
    k = None
    for q in range(1, SEAM_BLEND_VELOCITY + 1):
        t = k0 + step * q
        if not 0 <= t < len(kept) or not kept[t]:
            break
        k = t
    return k
