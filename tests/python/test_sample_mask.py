"""Inpainting (docs/ARCHITECTURE.md "Sampling with constraints"): the keep mask, sample_features(known, keep),
`python -m emdm.sample --known/--keep`, the tiny-mask parity fixture, and stitching a continued segment."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from emdm import paths
from emdm.fixtures import TINY_COND_DIM
from emdm.sampler.schedule import make_schedule
from emdm.motion import mask_fixture
from emdm.motion.features import heading_angles, recover_joints
from emdm.motion.ik_fixture import read_case_array
from emdm.motion.mask import GROUPS, KeepRect, KeepSpecError, group_channels, keep_mask, parse_keep
from emdm.motion.stitch import align_segment, append_segment, pin_kept_root, pin_root, root_pose
from emdm.model.open import onnx_step
from emdm.sample import main as sample_main
from emdm.sampler import SampleError, SamplingSettings, finish, run_together, sample_features, sampling

PARITY = mask_fixture.PARITY_DIR


@pytest.fixture(scope="module")
def tiny_step():
    return onnx_step(PARITY / "tiny-step.onnx")


@pytest.fixture(scope="module")
def real_features():
    return read_case_array(PARITY, "recover", "features").astype(np.float32)      # (120, 263), a real clip


# ----------------------------------------------------------------------------------------------- the mask

def test_the_three_groups_split_the_263_channels_by_joint():
    chans = {g: set(group_channels(g)) for g in GROUPS}
    assert sum(len(c) for c in chans.values()) == 263 and set.union(*chans.values()) == set(range(263))
    assert chans["root"] == {0, 1, 2, 3, 193, 194, 195}
    l_knee, l_wrist = 4, 20
    assert {4 + 3 * (l_knee - 1), 67 + 6 * (l_knee - 1), 193 + 3 * l_knee, 259, 262} <= chans["legs"]
    assert {4 + 3 * (l_wrist - 1) + 2, 67 + 6 * (l_wrist - 1) + 5, 193 + 3 * l_wrist} <= chans["upper"]


def test_keep_mask_is_the_union_of_frames_x_groups_rectangles():
    legs = group_channels("legs")
    m = keep_mask(10, [parse_keep("frames:0-2,8-"), parse_keep("frames:5/group:legs")])
    assert m.shape == (10, 263) and m.dtype == np.float32
    assert m[[0, 1, 2, 8, 9]].all() and not m[[3, 4, 6, 7]].any()
    assert m[5, legs].all() and m[5].sum() == len(legs)
    assert np.array_equal(keep_mask(4, [parse_keep("group:root,upper")]).sum(1), [263 - len(legs)] * 4)
    assert parse_keep("group:legs/frames:3-4") == KeepRect(frames=((3, 4),), groups=("legs",))


@pytest.mark.parametrize("spec, says", [
    ("", "empty"), ("legs", "must be frames:RANGES or group:NAMES"), ("group:arms", "unknown group 'arms'"),
    ("frames:5-2", "ends before it starts"), ("frames:a-3", "must be A-B"), ("frames:1,,3", "empty entry"),
    ("frames:1/frames:2", "given twice"), ("group:legs/group:root", "given twice"),
])
def test_a_bad_keep_spec_is_one_line_naming_it(spec, says):
    with pytest.raises(KeepSpecError, match=says) as e:
        parse_keep(spec)
    assert "\n" not in str(e.value)


def test_a_range_past_the_motion_is_refused():
    with pytest.raises(KeepSpecError, match="past the motion's last frame 9"):
        keep_mask(10, [parse_keep("frames:5-10")])
    with pytest.raises(KeepSpecError, match="past the motion's last frame 9"):
        keep_mask(10, [parse_keep("frames:12-")])


# ----------------------------------------------------------------------------------------------- the sampler

def _known_keep(real_features, frames=16):
    known = mask_fixture.known_motion()[:frames]
    return known, keep_mask(frames, [parse_keep("frames:0-5"), parse_keep("group:legs")])


@pytest.mark.parametrize("method, steps, guidance, num", [("ddgan", 4, 2.5, 1), ("ddgan", 2, 1.0, 2),
                                                           ("ddim", 5, 2.5, 1)])
def test_the_result_equals_the_known_motion_exactly_where_kept(tiny_step, real_features, method, steps, guidance, num):
    known, keep = _known_keep(real_features)
    cond = np.random.default_rng(0).standard_normal(TINY_COND_DIM).astype(np.float32)
    free_settings = SamplingSettings(method=method, steps=steps, guidance=guidance)
    x = sample_features(tiny_step, cond, 16, replace(free_settings, known=known, keep=keep), seed=3, num=num)
    kept = np.broadcast_to(keep.astype(bool), x.shape)
    assert np.array_equal(x[kept], np.broadcast_to(known, x.shape)[kept])        # exactly, in normalised space
    free = sample_features(tiny_step, cond, 16, free_settings, seed=3, num=num)
    assert np.abs(free - known)[kept].mean() > 0.1                                  # not kept by accident
    assert np.abs(x - free)[~kept].mean() > 1e-3                                   # the rest follows the kept part


def test_the_model_sees_the_known_motion_noised_to_each_steps_level(tiny_step):
    """Kept entries of every model input are a_cum[k+1]·known + s_cum[k+1]·ε with ε standard normal
    (DDIM: ε is x_T's noise itself; DDGAN: a fresh-looking N(0, 1) at every level)."""
    frames = 60
    known = np.tile(mask_fixture.known_motion(), (4, 1))[:frames]
    keep = keep_mask(frames, [parse_keep("group:root,legs")])
    kept = keep.astype(bool)
    for method, steps in (("ddim", 5), ("ddgan", 4)):
        inputs = []
        def recording(x, z, c, t, mask):
            inputs.append(x[0].copy())
            return tiny_step(x, z, c, t, mask)
        settings = SamplingSettings(method=method, steps=steps, known=known, keep=keep)
        sample_features(recording, np.zeros(TINY_COND_DIM, np.float32), frames, settings, seed=11)
        sch = make_schedule(steps)
        x_T = np.random.default_rng(11).standard_normal((1, frames, 263), dtype=np.float32)[0]
        for i, k in enumerate(range(steps - 1, -1, -1)):
            eps = ((inputs[i] - sch.a_cum[k + 1] * known) / sch.s_cum[k + 1])[kept]
            if method == "ddim":
                np.testing.assert_allclose(eps, x_T[kept], atol=2e-3)
            else:
                assert abs(eps.mean()) < 0.05 and abs(eps.std() - 1) < 0.05, (k, eps.mean(), eps.std())


def test_keep_from_time_imposes_the_kept_part_only_at_the_later_steps(tiny_step, real_features):
    """A timeline window keeps its second of context only from t ≤ keep_from_time on (and at the last step): the
    model inputs before carry no trace of it (the whole-kept leading frames sit those steps out), it joins as the
    known motion noised to its step's level from x_T's own draw, the result still equals it exactly, and 1 is every
    step, bit for bit."""
    known, keep = _known_keep(real_features)
    kept = keep.astype(bool)
    cond = np.random.default_rng(0).standard_normal(TINY_COND_DIM).astype(np.float32)
    def run(**kw):
        inputs = []
        def recording(x, z, c, t, mask):
            inputs.append(x[0].copy())
            return tiny_step(x, z, c, t, mask)
        settings = SamplingSettings(steps=4, guidance=2.5, known=known, keep=keep, **kw)
        return sample_features(recording, cond, 16, settings, seed=3)[0], inputs
    every, _ = run()
    assert np.array_equal(run(keep_from_time=1.0)[0], every)
    late, inputs = run(keep_from_time=0.6)                     # t = 1, 0.75 free; 0.5, 0.25 kept
    free, free_inputs = run(keep_from_time=0.0)                # only the last step
    assert np.array_equal(late[kept], known[kept]) and np.array_equal(free[kept], known[kept])
    assert [len(a) for a in inputs] == [10, 10, 16, 16] and [len(a) for a in free_inputs] == [10, 10, 10, 16]
    assert all(np.array_equal(a, b) for a, b in zip(inputs[:2], free_inputs[:2]))   # frames 6.. alone, no trace of it
    sch = make_schedule(4)
    x_T = np.random.default_rng(3).standard_normal((1, 16, 263), dtype=np.float32)[0]
    np.testing.assert_array_equal(inputs[2][:6], np.float32(sch.a_cum[2]) * known[:6] + np.float32(sch.s_cum[2]) * x_T[:6])
    np.testing.assert_array_equal(inputs[2][6:], free_inputs[2])                     # joined at t = 0.5; then it steers
    assert np.abs(late - every)[~kept].mean() > 1e-3
    with pytest.raises(SampleError, match="keep_from_time must be a finite time"):
        sample_features(tiny_step, cond, 16, SamplingSettings(steps=2, known=known, keep=keep,
                                                              keep_from_time=float("nan")))


@pytest.mark.parametrize("known, keep, says", [
    (np.zeros((16, 263)), None, "both known"),
    (np.zeros((15, 263)), np.ones((16, 263)), r"known has shape \(15, 263\)"),
    (np.zeros((16, 263)), np.full((16, 263), 0.5), "only 0 and 1"),
    (np.full((16, 263), np.nan), np.ones((16, 263)), "NaN/Infinity in 4208 kept"),
])
def test_bad_inpainting_arguments_are_one_line_errors(tiny_step, known, keep, says):
    with pytest.raises(SampleError, match=says):
        sample_features(tiny_step, np.zeros(TINY_COND_DIM, np.float32), 16,
                        SamplingSettings(steps=2, known=known, keep=keep))


# ----------------------------------------------------------------------------------------------- the fixture

# ----------------------------------------------------------------------------------------------- the CLI

def _shipped(name="emdm-a2m-web"):
    if not (paths.MODELS_DIR / "manifest.json").is_file():
        pytest.skip(f"no {paths.MODELS_DIR / 'manifest.json'}")
    man = json.loads((paths.MODELS_DIR / "manifest.json").read_text())
    if name not in man["models"]:
        pytest.skip(f"{name} not shipped")
    return man["models"][name]


def test_cli_keep_regenerates_around_the_kept_part(tmp_path, capsys):
    entry = _shipped()
    base = ["--model", "emdm-a2m-web", "--steps", "2", "--frames", "40", "--no-bvh"]
    assert sample_main([*base, "--action", "walk", "--seed", "1", "--out", str(tmp_path / "walk")]) == 0
    walk = np.load(tmp_path / "walk.features.npy")
    assert sample_main([*base, "--action", "wave-both-hands", "--seed", "2", "--known", str(tmp_path / "walk.features.npy"),
                        "--keep", "frames:0-9,30-39", "--keep", "group:legs", "--out", str(tmp_path / "wave")]) == 0
    wave = np.load(tmp_path / "wave.features.npy")
    keep = keep_mask(40, [parse_keep("frames:0-9,30-39"), parse_keep("group:legs")]).astype(bool)
    ms = np.fromfile(paths.MODELS_DIR / entry["meanStd"], "<f4")
    # de-normalise(normalise(f)) in float32: equal to a few ulps of the channel's scale
    tol = 4e-7 * (np.abs(walk) + np.abs(ms[:263]) + ms[263:])
    assert (np.abs(wave - walk) <= tol)[keep].all()
    assert np.abs(wave - walk)[~keep].mean() > 1e-2
    joints_w, joints_x = np.load(tmp_path / "walk.npy"), np.load(tmp_path / "wave.npy")
    kept_frames = np.r_[0:10, 30:40]                                    # decoded where the walk has them (pin_kept_root)
    assert np.abs(joints_w[kept_frames] - joints_x[kept_frames]).max() < 1e-3      # < 1 mm
    assert np.abs(joints_w[10:30] - joints_x[10:30]).max() > 1e-2


@pytest.mark.parametrize("args, says", [
    (["--keep", "group:arms"], "--known PATH"),
    (["--known", "{known}"], "--known needs --keep SPEC"),
    (["--known", "{known}", "--keep", "group:arms"], "--keep: keep spec 'group:arms': unknown group 'arms'; groups: root, legs, upper"),
    (["--known", "{known}", "--keep", "frames:0-40"], "past the motion's last frame 39"),
    (["--known", "{short}", "--keep", "frames:0-20"], "frame 20 is kept but --known .* has only 12 frames"),
    (["--known", "{bad}", "--keep", "frames:0"], r"shape \(12, 200\), expected \(frames, 263\)"),
    (["--known", "{missing}", "--keep", "frames:0"], "cannot read a .npy array"),
])
def test_cli_bad_keep_arguments_exit_2_with_one_line(tmp_path, capsys, args, says):
    _shipped()
    files = {"known": tmp_path / "k.npy", "short": tmp_path / "s.npy", "bad": tmp_path / "b.npy", "missing": tmp_path / "nope.npy"}
    np.save(files["known"], np.zeros((40, 263), np.float32))
    np.save(files["short"], np.zeros((12, 263), np.float32))
    np.save(files["bad"], np.zeros((12, 200), np.float32))
    args = [a.format(**{k: str(v) for k, v in files.items()}) for a in args]
    rc = sample_main(["--model", "emdm-a2m-web", "--action", "walk", "--steps", "1", "--frames", "40", "--no-bvh",
                      "--out", str(tmp_path / "o"), *args])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].startswith("error: "), err
    assert __import__("re").search(says, err[0]), err[0]
    assert not (tmp_path / "o.npy").exists()


# ----------------------------------------------------------------------------------------------- stitching

def _split(real_features, cut=70, overlap=20):
    """A real clip recovered whole, and as two segments whose overlap frames are the same features (as a segment
    inpainted from the previous one's last frames is): each segment recovered on its own from the origin."""
    whole = recover_joints(real_features)
    prev = recover_joints(real_features[:cut])
    nxt = recover_joints(real_features[cut - overlap:])
    return whole, prev, nxt


def test_stitching_a_real_clip_back_together_gives_the_clip(real_features):
    whole, prev, nxt = _split(real_features)
    assert np.abs(nxt[0, 0] - whole[50, 0]).max() > 0.1 or abs(heading_angles(whole[50:51])[0]) > 0.2   # a real move
    joined = append_segment(prev, nxt, 20)
    assert joined.shape == whole.shape
    assert np.abs(joined - whole).max() < 1e-4
    assert np.abs(align_segment(prev, nxt, 20)[:20] - prev[-20:]).max() < 1e-4     # the overlap lands on prev


def test_no_jump_in_root_position_or_heading_at_the_seam(real_features):
    """A continuation whose later frames differ (another clip's root motion after the overlap)."""
    gen = read_case_array(PARITY, "model-emdm-t2m-web", "features") if (PARITY / "model-emdm-t2m-web.json").is_file() \
        else real_features[::-1].copy()
    prev = recover_joints(real_features[:70])
    nxt = recover_joints(np.concatenate([real_features[50:70], gen]))
    joined = append_segment(prev, nxt, 20)
    root_step = np.linalg.norm(np.diff(joined[:, 0, [0, 2]], axis=0), axis=1)
    turn = np.abs(np.angle(np.exp(1j * np.diff(heading_angles(joined)))))
    seam = 69                                                       # step from prev's last frame to the first new one
    assert root_step[seam] <= 1.5 * np.percentile(np.delete(root_step, seam), 95) + 1e-3
    assert turn[seam] <= 0.05                                       # rad; the clip itself turns up to 0.46 rad a frame
    naive = np.concatenate([prev, nxt[20:]])                          # without stitching: the segment restarts at 0
    assert np.linalg.norm(naive[70, 0, [0, 2]] - naive[69, 0, [0, 2]]) > 10 * max(root_step[seam], 1e-2)
    naive_turn = np.abs(np.angle(np.exp(1j * np.diff(heading_angles(naive[69:71])))))[0]
    assert naive_turn > 1.0                                           # prev ends facing ~1.7 rad away from +Z


def test_align_segment_refuses_a_bad_overlap(real_features):
    _, prev, nxt = _split(real_features)
    with pytest.raises(ValueError, match="overlap must be an integer in 1..70"):
        align_segment(prev, nxt, 0)


def test_pin_root_puts_the_kept_end_of_an_in_between_back_in_place(real_features):
    """In-betweening keeps frames 0..29 and 70..119 of a real clip; the middle is another motion (a generated one
    when its parity fixture is there). Its root path moves the kept end by metres; pinned, the kept frames decode
    to the clip's joints (≤ 1 mm) and the free frames' root steps stay those of a real clip."""
    other = read_case_array(PARITY, "model-emdm-t2m-web", "features")[:40] \
        if (PARITY / "model-emdm-t2m-web.json").is_file() else real_features[::-1][:40]
    inb = real_features.copy()
    inb[30:70] = other
    want = recover_joints(real_features)
    assert np.abs(recover_joints(inb)[70:] - want[70:]).max() > 0.1
    pinned = pin_root(inb, (30, 70), 70, root_pose(real_features, 70))
    got = recover_joints(pinned)
    assert np.abs(got[:30] - want[:30]).max() == 0 and np.abs(got[70:] - want[70:]).max() < 1e-3
    changed = np.argwhere(pinned != inb)
    assert set(changed[:, 1]) <= {0, 1, 2} and changed[:, 0].min() >= 30 and changed[:, 0].max() < 70
    steps = np.linalg.norm(np.diff(got[:, 0, [0, 2]], axis=0), axis=1)
    assert steps.max() <= 1.5 * np.percentile(np.linalg.norm(np.diff(want[:, 0, [0, 2]], axis=0), axis=1), 95)
    with pytest.raises(ValueError, match=r"free frames \[30, 71\) must be a non-empty range ending at or before frame 70"):
        pin_root(inb, (30, 71), 70, (0.0, 0.0, 0.0))


def test_pin_kept_root_finds_the_free_stretch_from_the_mask(real_features):
    inb = real_features.copy()
    inb[30:70] = real_features[:40]
    keep = keep_mask(len(inb), [parse_keep("frames:0-29,70-"), parse_keep("group:legs,upper")])
    assert np.array_equal(pin_kept_root(inb, keep, real_features), pin_root(inb, (30, 70), 70, root_pose(real_features, 70)))
    prefix = keep_mask(len(inb), [parse_keep("frames:0-29")])       # a continuation: nothing kept after the free frames
    assert np.array_equal(pin_kept_root(inb, prefix, real_features), inb)


def test_a_run_stopped_where_its_context_joins_and_finished_equals_one_whole_run(tiny_step, real_features):
    """``sampling(stop_at)`` + ``finish``: bit for bit ``sample_features`` (ddgan, ddim, one step), known given only at
    the stop; ``run_together`` gives each run its own rows (frames padded) within float rounding."""
    known, keep = _known_keep(real_features)
    keep = keep_mask(16, [parse_keep("frames:0-5")])
    cond = np.random.default_rng(0).standard_normal(TINY_COND_DIM).astype(np.float32)
    for method, steps in (("ddgan", 10), ("ddim", 10), ("ddgan", 1)):
        settings = SamplingSettings(method, steps, 2.5, guidance_min_time=0.55, x0_smoothing=1.0, keep=keep,
                                    keep_from_time=0.55)
        whole = sample_features(tiny_step, cond, 16, replace(settings, known=known), seed=5)
        run = sampling(cond, 16, settings, seed=5, stop_at=0.55)
        run_together([run], tiny_step)
        np.testing.assert_array_equal(finish(run, tiny_step, known), whole)
    def window(n):     # a window with 6 frames of context (n > 16), or a first window
        plain = SamplingSettings(steps=10, guidance=2.5)
        return replace(plain, keep=keep_mask(n, [parse_keep("frames:0-5")]), keep_from_time=0.55) if n > 16 else plain
    runs = [sampling(cond, n, window(n), seed=s, stop_at=0.55) for n, s in ((16, 1), (26, 2), (21, 3))]
    run_together(runs, tiny_step)
    for (n, s), run in zip(((16, 1), (26, 2), (21, 3)), runs):
        kn = np.zeros((n, 263), np.float32) if n > 16 else None
        alone = sample_features(tiny_step, cond, n, replace(window(n), known=kn), seed=s)
        np.testing.assert_allclose(finish(run, tiny_step, kn), alone, atol=1e-5)
    with pytest.raises(SampleError, match="imposed before t ≤ 0.3, so known is needed"):
        next(sampling(cond, 16, SamplingSettings(steps=4, keep=keep, keep_from_time=0.6), stop_at=0.3))
    run = sampling(cond, 16, SamplingSettings(steps=4, keep=keep, keep_from_time=0.6), stop_at=0.6)
    run_together([run], tiny_step)
    with pytest.raises(SampleError, match="stopped for its known motion"):
        finish(run, tiny_step)
