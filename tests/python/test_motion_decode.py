"""emdm.motion.decode: the joints a motion is shown with, as the page decodes them (src/motion/decode.ts; the
parity fixture tests/fixtures/parity/decode.* is checked from the TypeScript side by tests/unit/decodeParity.test.ts)."""

import re

import numpy as np

from emdm import skeleton as sk
from emdm.eval.seams import joint_steps, wrap_step
from emdm.motion import decode_fixture
from emdm.motion.decode import decode_joints
from emdm.motion.features import recover_joints, recover_root, rot_y
from emdm.motion.foot_contact import FOOT_CLEANUP, cleanup_foot_contacts, plant_runs
from emdm.motion.ik_fixture import read_case_array
from emdm.paths import REPO_ROOT

REGENERATE = "regenerate with `.venv/bin/python -m emdm.motion.decode_fixture` and commit tests/fixtures/parity/decode.*"


def test_fixture_is_current():
    meta, arrays = decode_fixture.build(decode_fixture.committed_features())
    for key, want in arrays.items():
        got = read_case_array(decode_fixture.PARITY_DIR, decode_fixture.NAME, key)
        # numpy float64 arithmetic on float32 inputs read from files: no kernel varies with the CPU here
        np.testing.assert_allclose(got, want, atol=1e-6, err_msg=f"{key}: {REGENERATE}")


def test_off_is_recover_joints_and_smoothing_keeps_the_path():
    feats = decode_fixture.committed_features()["generated"]   # a generated walk: 1.9 m in 2 s
    np.testing.assert_array_equal(decode_joints(feats, smooth=False, foot_cleanup=False), recover_joints(feats).astype(np.float32))
    raw, smooth = recover_joints(feats), decode_joints(feats, smooth=True, foot_cleanup=False)
    # a low-pass filter: the root gets from A to B as it did (sway and jitter go, the way stays)
    way = lambda j: np.linalg.norm(j[-5, 0, [0, 2]] - j[5, 0, [0, 2]])   # noqa: E731
    assert way(raw) > 1.5 and abs(way(smooth) - way(raw)) < 0.01 * way(raw)


def test_contact_runs_pin_the_feet_on_the_floor_and_keep_the_legs():
    feats = decode_fixture.committed_features()["contacts"]
    before = decode_joints(feats, smooth=True, foot_cleanup=False)
    after = decode_joints(feats, smooth=True, foot_cleanup=True)
    assert before[:, sk.FOOT_JOINTS, 1].min() < -0.01              # the case sinks the body below the floor
    assert after[:, sk.FOOT_JOINTS, 1].min() >= -1e-6              # lifted
    planted = plant_runs(before, feats[:, -4:])
    assert sum(len(r) for r in planted) >= 2, "the case must have plants"
    for c, runs in enumerate(planted):                               # inside a planted run: the joint stays put
        j = sk.FOOT_JOINTS[c]
        for s, e, _ in runs:
            step = np.linalg.norm(np.diff(after[s:e + 1, j][:, [0, 2]], axis=0), axis=1).max()
            # held (within what two-bone IK reaches on a nearly straight stance leg of the real kick)
            assert step < 0.01, f"joint {j}, frames {s}-{e}: the pinned joint slides {step:.4f} m"
    thigh = lambda j: np.linalg.norm(j[:, 4] - j[:, 1], axis=1)     # noqa: E731 - l_knee - l_hip
    np.testing.assert_allclose(thigh(after), thigh(before), atol=1e-5)   # IK keeps the bone lengths


def test_wrong_contacts_shape_is_refused():
    j = np.zeros((5, 22, 3), np.float32)
    try:
        cleanup_foot_contacts(j, np.zeros((4, 4)), sk.PARENTS, sk.FOOT_JOINTS)
    except ValueError as e:
        assert "contacts has shape (4, 4)" in str(e)
    else:
        raise AssertionError("accepted contacts of the wrong length")


def test_a_sliding_contact_is_not_pinned_and_flicker_is_joined():
    """The model says "contact" on a foot sliding at walking speed: pinning it held the foot and then threw it up to
    a metre in one frame (8 walks at σ = 1: 5 of them over 0.5 m); such a run is left alone."""
    f = np.arange(30)
    joints = np.zeros((30, 22, 3), np.float32)
    joints[:, :, 1] = 0.5
    joints[:, sk.FOOT_JOINTS, 1] = 0.02
    joints[:, 7, 2] = joints[:, 10, 2] = 0.08 * f                 # the left foot slides 8 cm a frame
    contacts = np.zeros((30, 4), np.float32)
    contacts[5:25, :2] = 1
    contacts[14, :2] = 0                                         # a one-frame flicker
    assert plant_runs(joints, contacts)[0] == []
    out = cleanup_foot_contacts(joints, contacts, sk.PARENTS, sk.FOOT_JOINTS)
    assert np.abs(np.diff(out[:, 7, 2])).max() < 0.1
    joints[:, 7, 2] = joints[:, 10, 2] = 0.001 * f               # a plant that creeps 1 mm a frame: one run, pinned
    (s, e, _), = plant_runs(joints, contacts)[0]
    assert (s, e) == (5, 24)


def test_a_loop_is_decoded_as_it_plays_across_its_wrap():
    """A looping clip (loop=True) is smoothed and cleaned up across the wrap: decoded, it equals the middle of the
    clip played three times over (set back to the origin), and the step from its last frame to its first is no
    larger than a step inside it. Decoded alone (the old way), the generated walk's ends were smoothed apart."""
    walk = decode_fixture.committed_features()["generated"]
    clip = walk[:30]                     # a walk cut anywhere: the wrap is a jump, as an unfinished loop's
    n = len(clip)
    bare = decode_joints(clip, smooth=False, foot_cleanup=False, loop=True)
    np.testing.assert_allclose(bare, recover_joints(clip), atol=1e-5)      # starts where the clip alone does
    theta, root = recover_root(np.concatenate([clip] * 3))           # the second time round starts here
    three = decode_joints(np.concatenate([clip] * 3), smooth=True, foot_cleanup=False)[n:2 * n]
    three = rot_y(-theta[n], three - root[n] * [1, 0, 1])
    looped = decode_joints(clip, smooth=True, foot_cleanup=False, loop=True)
    np.testing.assert_allclose(looped, three, atol=1e-4)
    alone = decode_joints(clip, smooth=True, foot_cleanup=False)
    assert wrap_step(looped) < 0.8 * wrap_step(alone)
    assert wrap_step(looped) <= joint_steps(looped).max()


def test_two_plants_a_short_swing_apart_hand_the_foot_over_without_a_jump():
    """A run's foot: planted at z = 0 (frames 4–9), a 4-frame swing, planted at z = 1.2 (14–19); the fades overlap in
    the swing. The target mixes the two pins by weight: the pins still pull the swing together (0.24 m steps become
    up to 0.38), but the foot no longer switches from one target to the other in a frame (0.70 m before). With a
    blend longer than the gap a neighbour's fade reaches a plant's own frames, which keep their own pin."""
    z = np.concatenate([np.zeros(10), np.linspace(0.24, 0.96, 4), np.full(10, 1.2)])
    joints = np.zeros((24, 22, 3), np.float32)
    joints[:, :, 1] = 0.9
    joints[:, :, 2] = z[:, None]                                  # the body travels with the foot
    joints[:, [4, 5], 1] = 0.5                                    # knees half way down: the legs can reach
    joints[:, sk.FOOT_JOINTS, 1] = 0.02
    joints[:, [10, 11], 2] += 0.15                                # the balls of the feet ahead of the ankles
    for j in (7, 10):
        joints[:, j, 2] += 0.01 * np.sin(np.arange(24))           # the model's plants wobble by a centimetre
    contacts = np.zeros((24, 4), np.float32)
    contacts[4:10, :2] = contacts[14:20, :2] = 1
    out = cleanup_foot_contacts(joints, contacts, sk.PARENTS, sk.FOOT_JOINTS)
    step = np.abs(np.diff(out[:, 7, 2]))
    assert step.max() < 0.45, step.round(3)                      # the switch between targets: 0.70
    np.testing.assert_allclose(out[4:10, 7, 2], out[4, 7, 2], atol=1e-6)      # pinned: no wobble
    wide = cleanup_foot_contacts(joints, contacts, sk.PARENTS, sk.FOOT_JOINTS, blend=6)
    for s, e, at in ((4, 9, 0.0), (14, 19, 1.2)):               # held still, at its own plant (not pulled towards
        assert np.ptp(wide[s:e + 1, 7, 2]) < 1e-5                 # the other: 1.2 m away)
        assert abs(wide[s, 7, 2] - at) < 0.02


def sliding_run(frames: int = 24):
    """A run as the model makes it (Python twin of coreDecode.test.ts ``slidingRun``): the body travels 3.8 m/s,
    the left foot swings 0.3 m a frame and, in its two stances (frames 4–9 and 14–19, contacts on), still slides
    5 cm a frame: 25 cm, up to 12.5 cm from the stance's mean."""
    z, at = [], 0.0
    for k in range(frames):
        z.append(at)
        at += 0.05 if (4 <= k < 9 or 14 <= k < 19) else 0.3
    z = np.array(z)
    joints = np.zeros((frames, 22, 3), np.float32)
    joints[:, :, 1] = 0.9
    joints[:, :, 2] = np.linspace(z[0], z[-1], frames)[:, None]
    joints[:, [4, 5], 1] = 0.5
    joints[:, sk.FOOT_JOINTS, 1] = 0.02
    joints[:, 7, 2] = joints[:, 10, 2] = z
    joints[:, 10, 2] += 0.15
    contacts = np.zeros((frames, 4), np.float32)
    contacts[4:10, :2] = contacts[14:20, :2] = 1
    return joints, contacts


def test_a_run_stance_that_slides_a_hand_span_is_held():
    """The model's runs outpace their strides: their stances slide 20–40 cm, which the 10 cm drift limit left sliding
    (the runs' foot skate 94 cm/s at the realism benchmark, real runs 37). At 20 cm (``FOOT_CLEANUP``) such a stance
    is held (the leg stretching where it cannot reach); the swing then makes up the 25 cm it no longer slides
    (0.30 m steps become up to 0.60), no throw of a metre as a sliding walk's pin made. A contact longer than a
    stance (over ``stance_frames``) that strays as far is the body moving its foot: it keeps the 10 cm limit."""
    joints, contacts = sliding_run()
    assert plant_runs(joints, contacts, stance_drift=0.1)[0] == []             # the 10 cm limit of before
    assert [(s, e) for s, e, _ in plant_runs(joints, contacts)[0]] == [(4, 9), (14, 19)]
    out = cleanup_foot_contacts(joints, contacts, sk.PARENTS, sk.FOOT_JOINTS)
    for s, e in ((4, 9), (14, 19)):
        assert np.ptp(out[s:e + 1, 7, 2]) < 0.01 < 0.2 < np.ptp(joints[s:e + 1, 7, 2])
    slid = cleanup_foot_contacts(joints, contacts, sk.PARENTS, sk.FOOT_JOINTS, stance_drift=0.1)   # passed through
    assert np.ptp(slid[4:10, 7, 2]) > 0.2
    assert np.linalg.norm(np.diff(out[:, 7], axis=0), axis=1).max() < 0.65
    long = np.zeros((60, 22, 3), np.float32)
    long[:, :, 1] = 0.9
    long[:, sk.FOOT_JOINTS, 1] = 0.02
    long[:, 7, 2] = long[:, 10, 2] = np.linspace(0, 0.3, 60)       # a pivot: the foot moves 30 cm in 3 s
    on = np.ones((60, 4), np.float32)
    assert plant_runs(long, on)[0] == []
    long[:20, 7, 2] = long[:20, 10, 2] = np.linspace(0, 0.3, 20)    # as far within a stance's 20 frames: held
    assert [(s, e) for s, e, _ in plant_runs(long[:20], on[:20])[0]] == [(0, 19)]


def test_the_clean_up_defaults_are_the_typescript_twins():
    """``FOOT_CLEANUP`` here and in src/motion/footContact.ts: the same keys (camelCase there) and values."""
    ts = (REPO_ROOT / "src" / "motion" / "footContact.ts").read_text()
    body = re.search(r"export const FOOT_CLEANUP = \{([^}]*)\}", ts).group(1)
    theirs = {re.sub(r"[A-Z]", lambda m: "_" + m.group(0).lower(), k): float(v)
              for k, v in re.findall(r"(\w+):\s*([\d.]+)", body)}
    assert theirs == {k: float(v) for k, v in FOOT_CLEANUP.items()}
