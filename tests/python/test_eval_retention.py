"""emdm.eval.retention on known answers: real clips noised to each level of the sampler's schedule, one x̂0 each, as
the sampler's step takes it (guided only above the guidance interval), described against the clips' own."""

import numpy as np
import pytest

from emdm.eval.kinematics import descriptors
from emdm.eval.retention import main as retention_main, one_step, retention, summary
from emdm.motion.features import extract_features, recover_joints
from emdm.sampler.schedule import make_schedule
from model_synth_data import synth_clip, write_synthetic_dataset

D = 263


def _clip(seed: int, frames: int = 60) -> np.ndarray:
    return extract_features(synth_clip(frames, 1, np.random.default_rng(seed))).astype(np.float32)


def test_a_model_that_returns_the_clip_keeps_all_of_it_at_every_level():
    clip = _clip(1)
    mean, std = clip.mean(0), clip.std(0) + 0.1
    norm = ((clip - mean) / std).astype(np.float32)
    calls = []

    def oracle(x, z, c, t, mask):
        calls.append((x.copy(), float(t[0]), len(x)))
        return np.repeat(norm[None], len(x), 0)
    res = retention(oracle, [clip], np.ones(4, np.float32), mean, std, steps=4, guidance=1.0)
    sch = make_schedule(4)
    assert [lv["t"] for lv in res["levels"]] == [round(float(t), 4) for t in sch.time]
    assert [lv["noise"] for lv in res["levels"]] == [round(float(s), 4) for s in sch.s_cum[1:]]
    real = descriptors(recover_joints(clip))
    for lv in res["levels"]:
        assert not lv["guided"] and len(lv["x0"]) == 1
        for k, v in real.items():
            assert lv["x0"][0][k] == pytest.approx(v, rel=1e-4, abs=1e-5), k
    # each level's input is the clip noised to it: x = a·x0 + s·ε
    for k, (x, t, b) in enumerate(calls):
        assert b == 1 and t == pytest.approx(float(sch.time[k]))
        resid = x[0] - np.float32(sch.a_cum[k + 1]) * norm
        assert resid.std() == pytest.approx(float(sch.s_cum[k + 1]), rel=0.05)
    summ = summary(res, ("arm_speed",))
    assert all(c["share"] == pytest.approx(1.0, rel=1e-3) for c in summ["arm_speed"]["levels"])


def test_guidance_is_the_samplers_and_only_above_its_interval():
    cond = np.ones(3, np.float32)
    a, b = np.full((1, 5, D), 2.0, np.float32), np.full((1, 5, D), 0.5, np.float32)

    def step(x, z, c, t, mask):
        return np.where((c != 0).any(1)[:, None, None], a[0], b[0]).astype(np.float32)
    x, z = np.zeros((1, 5, D), np.float32), np.zeros((1, 64), np.float32)
    assert np.allclose(one_step(step, x, z, cond, 0.9, 1.5, True), 0.5 + 1.5 * (2.0 - 0.5))
    assert np.allclose(one_step(step, x, z, cond, 0.9, 1.5, False), 2.0)
    clip = _clip(2)
    res = retention(step, [clip], cond, clip.mean(0), clip.std(0) + 0.1, steps=10, guidance=1.5, guidance_min_time=0.55)
    assert [lv["guided"] for lv in res["levels"]] == [lv["t"] > 0.55 for lv in res["levels"]]
    assert sum(lv["guided"] for lv in res["levels"]) == 5


def test_the_command_names_what_it_cannot_use(tmp_path, capsys):
    ds = write_synthetic_dataset(tmp_path / "ds", n_clips=8)
    assert retention_main(["--dataset", str(ds), "--actions", "walk", "--clips", "1"]) == 2
    err = capsys.readouterr().err
    assert "prompts" in err and "\n" not in err.strip()            # its actions (walk, wave, turn) lack prompts
    assert retention_main(["--steps", "3"]) == 2
    assert "--steps 3: the model supports" in capsys.readouterr().err
    assert retention_main(["--model", "no-such-model"]) == 2
    assert "no model 'no-such-model'" in capsys.readouterr().err
