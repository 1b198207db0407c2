"""Beyond one prompt (emdm.motion.edit): timeline, regenerate, in-betweening, body-part edits and loops on the tiny step
model — their frame bookkeeping, every bad input, and the tiny-edit parity fixture (must be current)."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from emdm.motion import edit as E
from emdm.motion import edit_fixture
from emdm.motion.features import heading_angles, recover_joints
from emdm.motion.ik_fixture import read_case_array
from emdm.motion.mask import group_channels
from emdm.sampler import SamplingSettings

PARITY = edit_fixture.PARITY_DIR


class Spy:
    """Records what every sampling call was given and returned."""

    def __init__(self):
        self.calls = []

    def editor(self):
        spy = self

        class Spying(E.Editor):
            def sample(self, prompt, frames, seed, known=None, keep=None, keep_from_time=1.0):
                x = super().sample(prompt, frames, seed, known, keep, keep_from_time)
                spy.calls.append({"prompt": prompt, "frames": frames, "seed": seed, "known": known, "keep": keep,
                                  "keep_from_time": keep_from_time, "x": x})
                return x

        base = edit_fixture.tiny_editor()
        return Spying(base.step, base.mean, base.std, base.condition, SamplingSettings(steps=2, guidance=2.5))


@pytest.fixture(scope="module")
def model():
    return edit_fixture.tiny_editor()


@pytest.fixture(scope="module")
def tl(model):
    return E.timeline(model, [E.Segment("b", 1.5, 1), E.Segment("e", 1.0, 2), E.Segment("g", 2.0, 3)])


def _rel(joints):
    """Root-relative joints turned to face +Z: the pose without where the body stands or faces."""
    from emdm.motion.features import rot_y

    rel = joints - joints[:, :1] * np.array([1, 0, 1])
    return rot_y(-heading_angles(joints)[:, None], rel)


# ----------------------------------------------------------------------------------------------- timeline

def test_a_timeline_continues_each_segment_from_the_last_second_of_the_sequence():
    spy = Spy()
    segs = [E.Segment("b", 1.5, 1), E.Segment("e", 1.0, 2), E.Segment("g", 2.0, 3)]
    ed = spy.editor()
    tl = E.timeline(ed, segs)
    assert tl.frames == (30, 20, 40) and tl.starts == [0, 30, 50]
    assert tl.features.shape == (90, 263) and tl.joints.shape == (90, 22, 3) and tl.x.shape == (90, 263)
    assert [c["frames"] for c in spy.calls] == [30, 40, 60] and [c["seed"] for c in spy.calls] == [1, 2, 3]
    assert spy.calls[0]["known"] is None
    for k, c in enumerate(spy.calls[1:], 1):
        so_far = tl.features[:tl.starts[k]]
        assert np.array_equal(c["known"][:20], ed.normalise(so_far[-20:]))         # the last second
        assert np.array_equal(c["known"][19, :3], c["known"][18, :3])     # its last step (into the window): the one before
        assert np.array_equal(c["keep"][:20], np.ones((20, 263))) and not c["keep"][20:].any()
        assert np.array_equal(c["x"][:20], c["known"][:20])                        # kept exactly
        before = spy.calls[k - 1]["frames"]                                        # the window before: its c + n
        accel = E.seam_accel(so_far[-before:])
        assert E.SEAM_ACCEL_MIN <= accel <= E.SEAM_ACCEL
        eased = E.ease_seams(ed.denormalise(c["x"]), c["keep"], accel=accel)
        new = tl.features[tl.starts[k]:tl.starts[k] + tl.frames[k]]                # then its new frames,
        last = len(spy.calls) - 1
        assert np.array_equal(new[:-1], eased[20:-1]) and np.array_equal(new[-1, 3:], eased[-1, 3:])
        assert np.array_equal(new[-1, :3], new[-2, :3] if k < last else eased[-1, :3])   # the last one's step: the next's
        raw = ed.denormalise(c["x"])
        o = raw[19] + (raw[19] - raw[18] + raw[21] - raw[20]) / 2 - raw[20]      # the seam's offset
        b = min(E.seam_ease_frames(o, accel=accel) + E.SEAM_BLEND_EXTRA, len(raw) - 20)   # its fade, the cross-fade
        changed = np.nonzero((eased != raw).any(1))[0]
        assert changed.min() == 20 and changed.max() >= 19 + b                 # the cross-fade: b frames or more
        assert np.array_equal(eased[changed.max() + 1:], raw[changed.max() + 1:])
    first = ed.denormalise(spy.calls[0]["x"])
    assert np.array_equal(tl.features[:29], first[:29]) and np.array_equal(tl.features[29, 3:], first[29, 3:])
    assert np.array_equal(tl.features[29, :3], first[28, :3])
    assert np.array_equal(tl.x, ed.normalise(tl.features))


def test_the_stitched_joints_are_the_whole_sequence_decoded_so_seams_do_not_jump(tl):
    """append_segment of every window = recover_joints of the concatenated features: the root is integrated across
    each seam from the previous segment's pose (no jump in position or heading)."""
    whole = recover_joints(tl.features)
    scale = max(1.0, float(np.abs(whole).max()))
    assert np.abs(tl.joints - whole).max() < 1e-5 * scale
    for s in tl.starts[1:]:                          # the seam step is the features' own root step, not a restart
        step = np.linalg.norm(tl.joints[s, 0, [0, 2]] - tl.joints[s - 1, 0, [0, 2]])
        want = np.linalg.norm(tl.features[s - 1, 1:3])
        assert abs(step - want) < 1e-4 * scale


def test_easing_a_seam_removes_the_jump_and_leaves_kept_frames_and_contacts_alone():
    t = np.arange(40, dtype=np.float64)[:, None]
    f = np.repeat(np.sin(t / 6), 263, 1).astype(np.float32)
    f[20:] += 0.8                                                       # generated frames 20.. start off the kept ones
    keep = np.zeros((40, 263), np.float32)
    keep[:20] = 1
    g = E.ease_seams(f, keep)
    m = E.seam_ease_frames(g[20] - f[20])                              # 0.8·√3 m per joint: 12 frames
    assert m == math.ceil(math.pi * math.sqrt(0.8 * math.sqrt(3) * 400 / (2 * E.SEAM_ACCEL))) > E.SEAM_EASE
    assert np.array_equal(g[:19], f[:19]) and np.array_equal(g[19, 3:], f[19, 3:])   # kept, but the last one's step:
    assert np.array_equal(g[19, :3], f[18, :3])                                     # the root velocity before it
    assert np.array_equal(g[20 + m + E.SEAM_BLEND_EXTRA:], f[20 + m + E.SEAM_BLEND_EXTRA:])   # offset fade, then the cross-fade
    assert np.array_equal(g[:, 259:], f[:, 259:])
    acc = lambda x: np.abs(np.diff(x[:, 4], 2))                         # noqa: E731  (a joint's channel)
    assert acc(f)[18:20].max() > 0.5 and acc(g).max() < 0.1            # the jump is gone, spread over m frames
    keep[35:] = 1                                                      # a kept end too: eased backwards into 34, 33, ...
    f[35:] -= 1.6
    h = E.ease_seams(f, keep)
    assert acc(h).max() < 0.1 and np.array_equal(h[35:], f[35:])
    part = np.zeros((40, 263), np.float32)
    part[:, :7] = 1                                                    # a body-part mask: no row kept whole or free
    assert np.array_equal(E.ease_seams(f, part), f)


def test_a_fast_swing_in_the_first_generated_frames_is_damped_by_the_cross_fade():
    """The offset puts the first generated frame where the kept motion leads, but the model's next frames may still
    swing a limb through a metre in two frames (a timeline's raised hands dropped: 216 m/s², 13× the 95th percentile).
    The cross-fade from the kept motion continued scales such a swing down by the β of where it falls."""
    n = 60
    f = np.zeros((n, 263), np.float32)
    f[:, 4:67] = 0.5
    f[22:, 4:67] = -0.5                                                 # frames 20, 21 continue; 22.. a 1 m swing at once
    keep = np.zeros((n, 263), np.float32)
    keep[:20] = 1
    peak = lambda x: np.abs(np.diff(x[:, 4], 2)).max() * math.sqrt(3) * E.FPS**2   # noqa: E731  m/s²
    offset_only = f.copy()                                              # what the offset's fade alone leaves: the swing
    o = E.seam_ease_frames(np.zeros(263))
    assert o == E.SEAM_EASE and peak(f) > 600
    g = E.ease_seams(f, keep)
    assert np.array_equal(g[:20], f[:20]) and np.array_equal(g[:, 259:], f[:, 259:])
    assert peak(g) < 0.25 * peak(offset_only)
    assert np.allclose(g[20 + o + E.SEAM_BLEND_EXTRA:], f[20 + o + E.SEAM_BLEND_EXTRA:])    # the model's pose after it


def test_a_one_frame_jitter_at_the_end_of_the_kept_frames_is_not_carried_on_past_the_seam():
    """A generated walk's foot can jump 0.45 m between two frames (its jitter); when that is the kept side's last step,
    the cross-fade continued it: the foot slid on 0.4 m a frame and 2 m in 6 frames after a walk → wave seam. The
    kept side's velocity is its mean over its last SEAM_BLEND_VELOCITY steps, so the jitter is carried a third as far."""
    n = 60
    f = np.zeros((n, 263), np.float32)
    f[:, 3] = 0.9
    f[:, 4:67] = 0.2                                                    # a still pose, kept 0..19, generated 20..
    f[19, 4:67:3] += 0.45                                               # the last kept frame: every joint 0.45 m in x
    keep = np.zeros((n, 263), np.float32)
    keep[:20] = 1
    g = E.ease_seams(f, keep)
    assert np.array_equal(g[:20], f[:20])
    x = g[:, 4]                                                         # a joint's x, root-relative, metres
    travel = np.abs(x[20:] - x[19]).max()                               # how far past the jittered frame it goes
    steps = np.abs(np.diff(x[19:]))
    assert travel < 0.7 and steps.max() < 0.2, (travel, steps.max())    # carried on with one step's velocity: 1.5 m, 0.42


def test_a_large_jump_at_a_seam_is_eased_over_more_frames_so_the_fade_stays_within_its_acceleration():
    """The model may jump straight to the new prompt's pose (lie-down after standing: root height 0.89 → 0.08 m in
    one frame); fading that over the fixed 10 frames made a 0.5 s fall. The fade's length grows with the jump so its
    peak joint acceleration stays within SEAM_ACCEL; a small jump keeps the 10 frames."""
    n = 80
    f = np.zeros((n, 263), np.float32)
    f[:, 3] = 0.89
    f[:, 4:67] = 1.0
    f[20:, 3] = 0.08                                                    # the root drops 0.81 m at frame 20
    f[20:, 4:67] -= 1.5                                                 # every joint 1.5·√3 = 2.6 m (the largest one counts)
    keep = np.zeros((n, 263), np.float32)
    keep[:20] = 1
    g = E.ease_seams(f, keep)
    m = E.seam_ease_frames(g[20] - f[20])
    assert m == math.ceil(math.pi * math.sqrt(1.5 * math.sqrt(3) * 400 / (2 * E.SEAM_ACCEL)))
    b = m + E.SEAM_BLEND_EXTRA                                          # the cross-fade's frames
    assert np.array_equal(g[20 + b:], f[20 + b:]) and not np.array_equal(g[20 + b - 1], f[20 + b - 1])
    acc = np.abs(np.diff(g[:, 4], 2)) * math.sqrt(3) * E.FPS**2          # the joint's acceleration, m/s²
    assert acc.max() <= E.SEAM_ACCEL * 1.1                              # the cross-fade on top adds 7.5 % here
    fixed = E.ease_seams(f, keep, accel=math.inf)                       # the fixed 10-frame fade: far faster
    assert np.abs(np.diff(fixed[:, 4], 2)).max() * math.sqrt(3) * E.FPS**2 > 1.5 * E.SEAM_ACCEL
    small = f.copy()
    small[20:] = f[:20].mean(0) + 0.02                                  # a 2 cm step: the 10 frames of SEAM_EASE
    assert E.seam_ease_frames(E.ease_seams(small, keep)[20] - small[20]) == E.SEAM_EASE


def test_the_cross_fade_is_longer_where_the_model_leaves_the_kept_motion_in_its_first_frames():
    """A lie-down whose model frames stay at the seam for two frames and then drop 0.9 m at once (emdm-t2m-web:
    1.77× its calm timeline's 95th percentile at the seam): the offset is nil, so the fade keeps its 10 frames, and
    at a calm timeline's accel the cross-fade grows to ``seam_blend_frames`` of the drop. The drop is a step, so the
    blend scales it by the β of its row rather than bounding it: 34 → 24 m/s² here."""
    n = 80
    f = np.zeros((n, 263), np.float32)
    f[:, 3] = 1.0
    f[22:, 3] = 0.1                                                     # frames 20, 21 continue; 22.. 0.9 m lower
    keep = np.zeros((n, 263), np.float32)
    keep[:20] = 1
    assert E.seam_ease_frames(np.zeros(263)) == E.SEAM_EASE
    peak = lambda x: np.abs(np.diff(x[:, 3].astype(np.float64), 2)).max() * E.FPS**2   # noqa: E731  m/s²
    last = lambda g: int(np.nonzero(np.abs(g[:, 3] - f[:, 3]) > 1e-6)[0].max())      # noqa: E731  the last eased frame
    b0 = E.SEAM_EASE + E.SEAM_BLEND_EXTRA
    assert E.seam_blend_frames(0.9, E.SEAM_ACCEL) < b0 < E.seam_blend_frames(0.9, 6.0) == 17
    g = E.ease_seams(f, keep)                                           # 20 m/s²: the fade's 14 frames
    assert last(g) == 20 + b0 - 1
    calm = E.ease_seams(f, keep, accel=6.0)
    assert last(calm) == 20 + 17 - 1 and np.array_equal(calm[:20], f[:20]) and np.array_equal(calm[37:], f[37:])
    assert peak(calm) < 0.75 * peak(g)
    smooth = f.copy()
    smooth[20:, 3] = 1.0                                                # the model continues: nothing to ease
    assert np.array_equal(E.ease_seams(smooth, keep, accel=6.0), smooth)


def test_a_fast_kept_side_is_stopped_no_faster_than_accel():
    """Raised hands dropping fast at the end of the kept second (0.15 m a frame, 3 m/s) and a model that holds still
    after the seam: the continued motion stopped within τ = 3 frames whatever the accel (16.5 m/s² at the seam's
    frames; climb → raise both hands → lie down, seed 1000: 1.97× its timeline's 95th percentile). τ now grows to
    |v|·fps²/accel (10 frames at 6 m/s²), so the stop is spread: 8.2 m/s² at the seam. Not within 6: the model ends
    the joint 7.5 cm past the kept side, so it has to stop within a few centimetres of where it would have gone."""
    n = 60
    f = np.zeros((n, 263), np.float32)
    f[:, 3] = 0.9
    f[:20, 4] = 0.15 * np.arange(20) - 2.0                              # a joint moving 0.15 m a frame, kept
    f[20:, 4] = f[19, 4]                                                # the model: still, where the kept side ended
    keep = np.zeros((n, 263), np.float32)
    keep[:20] = 1
    acc = lambda g: np.abs(np.diff(g[:, 4].astype(np.float64), 2)) * E.FPS**2   # noqa: E731  acc[t − 1]: frame t's
    fast, calm = E.ease_seams(f, keep), E.ease_seams(f, keep, accel=6.0)
    assert np.array_equal(calm[:20], f[:20]) and np.array_equal(fast[:20], f[:20])
    assert acc(fast)[18:21].max() <= E.SEAM_ACCEL                      # the seam's frames 19–21
    assert acc(calm)[18:21].max() <= 1.5 * 6.0 and acc(calm)[18:21].max() < 0.6 * acc(fast)[18:21].max()
    assert acc(calm).max() < 1.7 * 6.0


def test_a_timeline_seam_is_eased_to_the_95th_percentile_of_the_window_before_it():
    t = np.arange(60, dtype=np.float64)
    calm = np.zeros((60, 263), np.float32)
    calm[:, 3] = 0.9
    calm[:, 4:67] = np.tile([0.1, 0.3, 0.0], 21)
    assert E.seam_accel(calm) == E.SEAM_ACCEL_MIN                      # still: the floor, not a fade of seconds
    fast = calm.copy()
    fast[:, 4] += (0.3 * np.sin(t * 1.3)).astype(np.float32)             # a wrist shaking: past SEAM_ACCEL
    assert E.seam_accel(fast) == E.SEAM_ACCEL
    mid = calm.copy()
    mid[:, 4] += (0.12 * np.sin(t / 2)).astype(np.float32)             # 12 m/s² at most
    a = E.joint_acceleration(recover_joints(mid).astype(np.float32))[1:-1]
    assert E.SEAM_ACCEL_MIN < E.seam_accel(mid) < E.SEAM_ACCEL and E.seam_accel(mid) == pytest.approx(np.percentile(a, 95))
    assert E.seam_accel(calm[:2]) == E.SEAM_ACCEL


def test_a_first_segment_shorter_than_the_overlap_is_continued_from_all_its_frames(model):
    spy = Spy()
    tl = E.timeline(spy.editor(), [E.Segment("b", 0.4, 1), E.Segment("e", 1.0, 2)])
    assert tl.frames == (8, 20) and [c["frames"] for c in spy.calls] == [8, 28]
    assert np.array_equal(spy.calls[1]["x"][:8], tl.x[:8]) and len(tl.features) == 28


def test_regenerating_a_segment_keeps_the_ones_before_and_redoes_the_ones_after(model, tl):
    new = E.regenerate(model, tl, 1, E.Segment("c", 1.0, 9))
    assert new.segments[0] == tl.segments[0] and new.segments[1] == E.Segment("c", 1.0, 9)
    assert np.array_equal(new.features[:30], tl.features[:30]) and np.array_equal(new.joints[:30], tl.joints[:30])
    assert np.abs(new.features[30:50] - tl.features[30:50]).mean() > 1e-2
    assert np.abs(new.features[50:] - tl.features[50:]).mean() > 1e-3        # same seed, but continues the new one
    again = E.regenerate(model, tl, 2)                                         # default: same prompt, seed + 1
    assert again.segments[2].seed == 4 and np.array_equal(again.features[:50], tl.features[:50])
    assert len(E.regenerate(model, tl, 2, E.Segment("g", 0.5, 3)).features) == 60    # a new length
    fresh = E.timeline(model, new.segments)                                    # the same as generating it whole
    assert np.array_equal(fresh.features, new.features)


def test_regenerating_needs_the_same_earlier_segments(model, tl):
    with pytest.raises(E.EditError, match=r"segments 1..1 must be those of the previous timeline"):
        E.timeline(model, [E.Segment("a", 1.5, 1), *tl.segments[1:]], previous=tl, start=1)
    with pytest.raises(E.EditError, match=r"segment 4 outside 1..3"):
        E.regenerate(model, tl, 3)


@pytest.mark.parametrize("segments, says", [
    ([], "the timeline is empty"),
    ([("b", 2), ("e", 0)], r"segment 2 \('e'\): 0 s is too short; a segment lasts at least 0.05 s"),
    ([("b", 0.02)], r"segment 1 \('b'\): 0.02 s is too short"),
    ([("b", 2), ("  ", 2)], "segment 2: the prompt is empty"),
    ([("b", 8.8)] * 6 + [("e", 8.2)], r"the timeline lasts 61 s in all; at most 60 s"),
    ([("b", float("nan"))], r"segment 1 \('b'\): seconds must be a number, got nan"),
    ([("b", "2")], r"seconds must be a number, got '2'"),
    ([("zz", 1)], r"segment 1 \('zz'\): .*'zz'"),
])
def test_a_bad_timeline_is_refused_naming_the_segment_and_the_limit_before_sampling(segments, says):
    spy = Spy()
    with pytest.raises(E.EditError, match=says) as e:
        E.timeline(spy.editor(), [E.Segment(p, s, 1) for p, s in segments])
    assert "\n" not in str(e.value) and spy.calls == []


def test_a_segment_longer_than_one_window_is_made_in_several():
    assert E.window_sizes(176, False) == [176] and E.window_sizes(177, False) == [89, 88]
    assert E.window_sizes(196, True) == [196] and E.window_sizes(197, True) == [99, 98]
    assert E.window_sizes(600, False) == [150] * 4 and sum(E.window_sizes(1199, True)) == 1199
    spy = Spy()
    tl = E.timeline(spy.editor(), [E.Segment("b", 1.0, 7), E.Segment("e", 10.0, 2**32 - 1)])
    assert tl.frames == (20, 200) and len(tl.features) == 220 and tl.joints.shape == (220, 22, 3)
    assert [(c["frames"], c["seed"]) for c in spy.calls] == [(20, 7), (120, 2**32 - 1), (120, 0)]
    assert np.array_equal(spy.calls[2]["known"][:20], spy.editor().normalise(tl.features[100:120]))
    assert np.abs(tl.joints - recover_joints(tl.features)).max() < 1e-5 * max(1.0, float(np.abs(tl.joints).max()))


def test_a_bad_seed_is_refused():
    with pytest.raises(E.EditError, match=r"segment 1 \('b'\): seed must be an integer in 0..4294967295, got -1"):
        E.check_timeline([E.Segment("b", 1, -1)])


def test_segment_specs_and_json(tmp_path):
    assert E.parse_segment("a person: then walks:4.5", 7) == E.Segment("a person: then walks", 4.5, 7)
    with pytest.raises(E.EditError, match=r"expected PROMPT:SECONDS"):
        E.parse_segment("a person walks")
    f = tmp_path / "t.json"
    f.write_text(json.dumps([{"prompt": "walk", "seconds": 2}, {"prompt": "wave", "seconds": 1, "seed": 9}]))
    assert E.read_segments(f, 5) == [E.Segment("walk", 2, 5), E.Segment("wave", 1, 9)]
    f.write_text('[{"prompt": "walk", "secs": 2}]')
    with pytest.raises(E.EditError, match=r"segment 1 must be an object with \"prompt\", \"seconds\""):
        E.read_segments(f)
    f.write_text("[{")
    with pytest.raises(E.EditError, match=r"t.json:1: not valid JSON"):
        E.read_segments(f)


# ----------------------------------------------------------------------------------------------- edits

def test_inbetweening_keeps_the_first_and_last_second_where_they_were(model, tl):
    spy = Spy()
    src = tl.features[:70]
    m = E.inbetween(spy.editor(), src, "d", 5)
    keep = spy.calls[0]["keep"].astype(bool)
    assert keep[:20].all() and keep[50:].all() and not keep[20:50].any()
    want = recover_joints(src)
    assert np.abs(m.joints[:20] - want[:20]).max() < 1e-5
    assert np.abs(m.joints[50:] - want[50:]).max() < 1e-3                      # ≤ 1 mm after the free frames
    assert np.abs(m.joints[20:50] - want[20:50]).max() > 1e-2
    changed = np.argwhere(np.abs(m.features - src) > 1e-4 * (1 + np.abs(src)))
    assert changed[:, 0].min() >= 19 and changed[:, 0].max() < 50
    assert set(changed[changed[:, 0] == 19, 1]) <= {0, 1, 2}       # frame 19's step, into a generated frame 20
    assert np.allclose(m.features[19, :3], src[18, :3], atol=1e-5)
    m2 = E.inbetween(model, src, "d", 5, keep_until=9, keep_from=60)             # any marked range
    assert np.abs(m2.joints[60:] - want[60:]).max() < 1e-3 and np.abs(m2.joints[10:60] - want[10:60]).max() > 1e-2


@pytest.mark.parametrize("keep, kept_groups", [("lower", ("root", "legs")), ("upper", ("upper",))])
def test_a_body_part_edit_keeps_its_channels_on_every_frame(model, tl, keep, kept_groups):
    src = tl.features[:60]
    m = E.edit_body(model, src, "f", 4, keep=keep)
    ch = sorted(c for g in kept_groups for c in group_channels(g))
    free = sorted(set(range(263)) - set(ch))
    np.testing.assert_allclose(m.features[:, ch], src[:, ch], rtol=1e-6, atol=1e-6)
    assert np.abs(m.features[:, free] - src[:, free]).mean() > 1e-2
    legs = [0, 1, 2, 4, 5, 7, 8, 10, 11]
    upper = [3, 6, 9, 12, 13, 14, 15, 16, 17, 18, 19, 20, 21]
    want = recover_joints(src)
    if keep == "lower":                                                        # legs where they were, in the world
        assert np.abs(m.joints[:, legs] - want[:, legs]).max() < 1e-3
    else:                                                                      # the upper body's pose, root-relative
        rel = lambda f: f[:, 4:67].reshape(-1, 21, 3)[:, [j - 1 for j in upper]]  # noqa: E731
        assert np.abs(rel(m.features) - rel(src)).max() < 1e-3


def test_a_loop_ends_on_its_first_pose(model, tl):
    spy = Spy()
    src = tl.features[:50]
    lp = E.loop(spy.editor(), src, "b", 6)
    keep = spy.calls[0]["keep"].astype(bool)
    assert keep[:10].all() and keep[40:].all() and not keep[10:40].any()
    assert np.array_equal(spy.calls[0]["known"][40:], spy.calls[0]["known"][:10])
    assert lp.features.shape == (40, 263) and lp.joints.shape == (40, 22, 3) and len(lp.full.features) == 50
    assert np.array_equal(lp.features, lp.full.features[:40])
    pose = lambda f: f[:, 3:67]                                                  # noqa: E731  height + root-relative joints
    assert np.abs(pose(lp.full.features[40:41]) - pose(lp.full.features[:1])).max() < 1e-5
    assert np.abs(_rel(lp.full.joints[40:41]) - _rel(lp.full.joints[:1])).max() < 1e-3   # ≤ 1 mm: the same pose
    assert np.abs(lp.features[10:40] - src[10:40]).mean() > 1e-2


def test_a_timeline_longer_than_the_window_loops_by_sampling_only_its_last_window(tl):
    """A timeline (here 90 frames, the model's window 60) loops: its last window continues the frames before it (its
    first second kept, those frames untouched) and ends on the timeline's first pose."""
    from dataclasses import replace

    spy = Spy()
    ed = replace(spy.editor(), max_frames=60)
    lp = E.loop(ed, tl.features, "b", 6)
    (call,) = spy.calls
    assert call["frames"] == 60
    keep = call["keep"].astype(bool)
    assert keep[:20].all() and keep[50:].all() and not keep[20:50].any()
    assert np.array_equal(call["known"][:20], ed.normalise(tl.features[30:50]))        # the window continues frame 30..49
    assert np.array_equal(call["known"][50:], ed.normalise(tl.features[:10]))          # and ends on the first 10 frames
    assert len(lp.full.features) == 90 and lp.features.shape == (80, 263)
    assert np.array_equal(lp.full.features[:30], tl.features[:30])                    # before the window: as it was
    np.testing.assert_allclose(lp.full.features[30:50], tl.features[30:50], atol=1e-5)  # kept (through mean/std)
    assert np.abs(lp.full.joints[:50] - recover_joints(tl.features[:50])).max() < 1e-5
    assert np.abs(_rel(lp.full.joints[80:81]) - _rel(lp.full.joints[:1])).max() < 1e-3  # the wrap: the first pose
    assert np.abs(lp.full.features[50:80] - tl.features[50:80]).mean() > 1e-2           # the free frames are new


def test_an_in_place_loop_does_not_travel(model, tl):
    src = tl.features[:50]
    moving = E.loop(model, src, "b", 6)
    still = E.loop(model, src, "b", 6, in_place=True)
    assert np.abs(moving.joints[:, 0, [0, 2]]).max() > 0.05
    assert np.abs(still.joints[:, 0, [0, 2]]).max() == 0 and (still.features[:, 1:3] == 0).all()
    np.testing.assert_allclose(still.features[:, [0, *range(3, 263)]], moving.features[:, [0, *range(3, 263)]])
    np.testing.assert_allclose(heading_angles(still.joints), heading_angles(moving.joints), atol=1e-4)


@pytest.mark.parametrize("call, says", [
    (lambda m, f: E.inbetween(m, f[:30], "d", 1), r"in-betweening: kept frames 0..19 and 10..29 leave no frame"),
    (lambda m, f: E.inbetween(m, f[:200], "d", 1), r"in-betweening: the motion has 200 frames; this edit needs 3..196"),
    (lambda m, f: E.inbetween(m, f[:60], " ", 1), r"in-betweening: the prompt is empty"),
    (lambda m, f: E.inbetween(m, f[:60], "d", 2**32), r"seed must be an integer in 0..4294967295"),
    (lambda m, f: E.inbetween(m, f[:60, :200], "d", 1), r"shape \(60, 200\), expected \(frames, 263\)"),
    (lambda m, f: E.inbetween(m, np.full((60, 263), np.nan, np.float32), "d", 1), r"NaN/Infinity"),
    (lambda m, f: E.edit_body(m, f[:60], "f", 1, keep="arms"), r"keep must be 'lower' \(legs and root\) or 'upper'"),
    (lambda m, f: E.loop(m, f[:20], "b", 1), r"loop: the motion has 20 frames; this edit needs 21..1200"),
    (lambda m, f: E.loop(m, f[:60], "b", 1, ends=0), r"ends must be a positive number of frames"),
])
def test_bad_edits_are_refused_with_one_line(model, tl, call, says):
    f = np.concatenate([tl.features, tl.features, tl.features])
    with pytest.raises(E.EditError, match=says) as e:
        call(model, f)
    assert "\n" not in str(e.value)


# ----------------------------------------------------------------------------------------------- the fixture

def test_the_fixture_holds_what_the_typescript_side_needs():
    meta = json.loads((PARITY / "tiny-edit.json").read_text())
    assert [r["op"] for r in meta["runs"]] == ["timeline"] * 3 + ["regenerate"] * 2 + ["inbetween", "body", "loop", "loop_long"]
    assert meta["ops"]["timeline"]["frames"] == [24, 14, 10] and meta["overlap"] == 20 and meta["loopEnds"] == 10
    assert [r["frames"] for r in meta["runs"]] == [24, 34, 30, 34, 30, 48, 48, 48, 34]
    assert meta["runs"][-1]["noise"] == meta["runs"][1]["noise"]        # the long loop's window reuses a timeline window's noise
    tl = read_case_array(PARITY, "tiny-edit", "timeline_features")
    regen = read_case_array(PARITY, "tiny-edit", "regen_features")
    assert np.array_equal(regen[:24], tl[:24]) and np.abs(regen[38:] - tl[38:]).mean() > 1e-3
    assert read_case_array(PARITY, "tiny-edit", "loop_features").shape == (38, 263)
    long_loop = read_case_array(PARITY, "tiny-edit", "loop_long_features")
    assert long_loop.shape == (38, 263) and np.array_equal(long_loop[:14], tl[:14])   # frames before its window stay


def test_timeline_together_runs_every_window_s_early_steps_in_one_call_and_gives_the_same_motion():
    """``together`` (the page's begin): one model call per step for every window until its context joins, then each
    window in turn; the same timeline and regeneration within float rounding (the tiny model is fp32)."""
    base = edit_fixture.tiny_editor()
    calls = []

    def counting(x, z, c, t, mask):
        calls.append((x.shape[0], x.shape[1], float(mask.min())))
        return base.step(x, z, c, t, mask)

    model = E.Editor(counting, base.mean, base.std, base.condition, SamplingSettings(steps=4, guidance=2.5),
                     max_frames=base.max_frames)
    segs = [E.Segment("b", 1.2, 1), E.Segment("e", 0.7, 2), E.Segment("g", 12.0, 3)]     # windows 24, 34, 20+120, 20+120
    in_turn = E.timeline(model, segs)
    calls.clear()
    tl = E.timeline(model, segs, together=True)
    # steps t = 1 and 0.75 (above 0.55, guided): 4 windows × 2 rows in one call, padded to the longest free part
    assert calls[:2] == [(8, 120, 0.0), (8, 120, 0.0)]
    assert len(calls) == 2 + 4 * 2
    np.testing.assert_allclose(tl.features, in_turn.features, atol=1e-4)
    again = E.regenerate(model, tl, 1, together=True)
    np.testing.assert_allclose(again.features, E.regenerate(model, in_turn, 1).features, atol=1e-4)
    np.testing.assert_array_equal(again.features[:24], tl.features[:24])


def test_an_int8_step_file_begins_its_windows_alone_so_together_is_the_timeline_in_turn_exactly():
    """The shipped int8 file quantises activations per call (a scale shared by the batch): ``begin`` runs each window
    alone there, and the timeline is the same bit for bit; the fp32/fp16 files batch."""
    from emdm.model.open import open_model, quantises_per_call
    from emdm.paths import MODELS_DIR

    manifest = json.loads((MODELS_DIR / "manifest.json").read_text())
    if "emdm-t2m-web" not in manifest.get("models", {}):
        pytest.skip("no shipped text model")
    entry = manifest["models"]["emdm-t2m-web"]
    files = {"fp32": entry["onnx"], **entry.get("variants", {})}
    assert {v: quantises_per_call(MODELS_DIR / f) for v, f in files.items()} == {v: v == "int8" for v in files}
    opened = open_model("emdm-t2m-web", variant="int8")
    eye = np.eye(384, dtype=np.float32)
    model = dataclasses.replace(E.Editor.open(opened, steps=4), condition=lambda p: eye[int(p)] * 3)
    assert not model.batches_exactly
    segs = [E.Segment(str(k), 1.5, k) for k in (1, 2, 3)]
    np.testing.assert_array_equal(E.timeline(model, segs, together=True).features, E.timeline(model, segs).features)
    assert E.Editor.open(open_model("emdm-t2m-web", variant="fp16"), steps=4).batches_exactly
