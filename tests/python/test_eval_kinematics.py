"""The kinematic judge (emdm.eval.kinematics): descriptors and rules on real Bandai clips through the project's
own pipeline (retarget, 20 fps, floor, first frame facing +Z), where the answer is known, and the validation
bookkeeping on hand-made tables."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import numpy as np
import pytest

from emdm import paths
from emdm.eval import kinematics as K

SHARED = paths.shared_data_dir()
needs_bandai = pytest.mark.skipif(not (SHARED / "bandai-namco-motion.tar.xz").is_file(),
                                  reason=f"real mocap not found: {SHARED}/bandai-namco-motion.tar.xz "
                                         "(put ../shared/data beside the checkout or set EMDM_SHARED_DATA)")


@lru_cache(maxsize=None)
def _jobs():
    from emdm.data.sources import bandai_jobs
    from emdm.data.unpack import unpack_archive

    return {Path(j.path).stem: j for j in bandai_jobs(unpack_archive(SHARED / "bandai-namco-motion.tar.xz"))}


def real_clip(stem: str, frames: int = 120) -> np.ndarray:
    """The first ``frames`` frames (20 fps) of a Bandai take, as ``emdm.data.prepare`` makes a window of it."""
    from emdm.data.process import windows_for
    from emdm.motion.retarget import normalize_clip

    take, _, _ = windows_for(_jobs()[stem])
    return normalize_clip(take[:frames])


WALK = "dataset-1_walk_normal_001"
WAVE = "dataset-2_wave-right-hand_active_001"


@needs_bandai
def test_real_walk_passes_the_walk_rule_and_a_standing_wave_fails_it():
    walk, wave = K.table([real_clip(WALK)]), K.table([real_clip(WAVE)])
    assert 1.0 < walk["speed"][0] < 1.5 and walk["forward"][0] > 0.9 and abs(walk["turn"][0]) < 20
    assert K.passes("walk", walk)[0]
    assert wave["speed"][0] < 0.1
    assert not K.passes("walk", wave)[0]
    assert K.passes("wave-right-hand", wave)[0] and not K.passes("wave-left-hand", wave)[0]
    assert not K.passes("run", walk)[0]


@needs_bandai
def test_descriptors_follow_the_motion_not_the_clip():
    walk = real_clip(WALK)
    back = K.descriptors(walk[::-1])                         # the same walk played backwards: walking backwards
    assert back["forward"] < -0.9
    assert K.passes("walk-backward", {k: np.array([v]) for k, v in back.items()})[0]
    fast = K.descriptors(walk[::2])                          # every second frame: twice as fast
    assert fast["speed"] == pytest.approx(2 * K.descriptors(walk)["speed"], rel=0.05)
    assert K.passes("run", {k: np.array([v]) for k, v in fast.items()})[0]
    lifted = walk.copy()
    lifted[:, :, 1] += 0.3                                   # the whole body 30 cm up: both feet off the floor
    assert K.descriptors(lifted)["airborne"] == 1.0 and K.descriptors(walk)["airborne"] == 0.0


def test_descriptors_refuse_a_wrong_shape():
    with pytest.raises(ValueError, match=r"expected shape \(frames ≥ 2, 22, 3\), got \(5, 21, 3\)"):
        K.descriptors(np.zeros((5, 21, 3)))


def test_validate_and_judged_on_a_hand_made_table():
    labels = ["walk", "run", "bow"]
    actions = np.array([0, 0, 0, 0, 1, 1, 2])
    desc = {k: np.zeros(7) for k in K.DESCRIPTORS}
    desc["speed"][:] = [1.0, 1.2, 0.9, 3.0, 2.5, 1.1, 0.0]   # one walk too fast; one run as slow as a walk
    desc["forward"][:] = 1.0
    v = K.validate(labels, actions, desc)
    assert v["walk"]["own"] == 0.75 and v["walk"]["n"] == 4
    assert v["walk"]["false_pass"] == pytest.approx(1 / 3) and v["walk"]["confused"] == "run"
    assert v["run"]["own"] == 0.5
    assert "bow" in v and v["bow"]["own"] == 0.0             # lean 0 < 0.25
    assert K.judged(v) == [] and K.judged(v, bar=0.75) == ["walk"]
    assert K.judged(v, bar=0.0) == ["walk"]                   # run (2 clips) and bow (1) have too few to judge by
    assert K.judged(v, bar=0.0, min_clips=1) == ["walk", "run", "bow"]
    v["walk"].update(own=None, n=0)                           # an action without test clips is never judged
    assert K.judged(v, bar=0.0, min_clips=0) == ["run", "bow"]


def test_every_rule_reads_known_descriptors():
    for a, conds in K.RULES.items():
        assert conds, a
        for d, op, _ in conds:
            assert d in K.DESCRIPTORS and op in (">=", "<="), (a, d, op)
        assert K.rule_text(a).count(" and ") == len(conds) - 1
