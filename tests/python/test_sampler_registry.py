"""emdm.sampler: a third sampler is one new module plus one registration line, and the loop runs it; the loop runs
the registered update of ``settings.method``; the library imports without its CLI; its entry points take a settings
object, not a dozen positional parameters."""

from __future__ import annotations

import dataclasses
import importlib
import inspect
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from emdm import paths
from emdm.sampler import (SAMPLERS, SampleError, Sampler, SamplingSettings, drive, finish, run_together,
                          sample_features, sampling)
from emdm.sampler.ddgan import ddgan_update
from emdm.sampler.ddim import ddim_update
from emdm.sampler.schedule import make_schedule

D, Z, C = 6, 3, 4     # a toy model's feature, latent and condition sizes

# the whole of a new sampler: one update function that returns the model's x̂0 as it is
X0_MODULE = '''
def x0_update(x, x0, k, schedule, noise):
    """x_k := x̂0 (no re-noising): the model's estimate is the next input."""
    return x0
'''


def toy_step(record: list):
    """A step model whose x̂0 depends on every input (x, z, c, t), recording what it was given."""
    def step(x, z, c, t, mask):
        record.append((x.copy(), z.copy(), t.copy()))
        return (0.5 * x + z.sum(1)[:, None, None] + c.sum(1)[:, None, None] + t[:, None, None]).astype(np.float32)
    return step


def test_a_third_sampler_is_one_new_module_and_one_registration_line(tmp_path, monkeypatch):
    (tmp_path / "x0_sampler.py").write_text(X0_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    x0_sampler = importlib.import_module("x0_sampler")
    monkeypatch.setitem(SAMPLERS, "x0", Sampler(x0_sampler.x0_update))     # the registration line

    calls: list = []
    cond = np.ones(C, np.float32)
    settings = SamplingSettings(method="x0", steps=4, z_dim=Z, feature_dim=D)
    x = sample_features(toy_step(calls), cond, 5, settings, seed=2)
    sch = make_schedule(4)
    assert [float(t[0]) for _, _, t in calls] == pytest.approx(list(sch.time[::-1]))    # every step, T−1 down to 0
    rng = np.random.default_rng(2)
    want = rng.standard_normal((1, 5, D), dtype=np.float32)                             # x_T
    for (xin, z, t), k in zip(calls, range(3, -1, -1)):
        np.testing.assert_array_equal(xin, want)           # each step's input is the x̂0 before it, as the module says
        np.testing.assert_array_equal(z, rng.standard_normal((1, Z), dtype=np.float32))   # z used as drawn
        want = (0.5 * xin + z.sum(1)[:, None, None] + C + t[:, None, None]).astype(np.float32)
    np.testing.assert_array_equal(x, want)                 # the result: the last x̂0

    # the loop's other paths run it too: guidance, inpainting, a stopped run finished
    keep = np.zeros((5, D), np.float32)
    keep[:2] = 1
    known = np.full((5, D), 0.25, np.float32)
    guided = dataclasses.replace(settings, guidance=2.0, known=known, keep=keep)
    x = sample_features(toy_step([]), cond, 5, guided, seed=2)
    np.testing.assert_array_equal(x[0, :2], known[:2])
    run = sampling(cond, 5, guided, seed=2, stop_at=0.5)
    run_together([run], toy_step([]))
    np.testing.assert_array_equal(finish(run, toy_step([])), x)


def test_an_unregistered_method_is_one_line_naming_the_registered_ones():
    with pytest.raises(SampleError, match=r"^method must be one of ddgan, ddim, got 'x0'$"):
        sample_features(toy_step([]), np.ones(C, np.float32), 5, SamplingSettings(method="x0", z_dim=Z, feature_dim=D))


@pytest.mark.parametrize("method, update, uses_z", [("ddgan", ddgan_update, True), ("ddim", ddim_update, False)])
def test_the_loop_runs_the_registered_update_of_its_method(monkeypatch, method, update, uses_z):
    """Each step's x̂0 goes to the method's update with its step index and the schedule; its result is the next
    input; DDIM's model sees z = 0 (z is drawn all the same)."""
    seen = []

    def spy(x, x0, k, schedule, noise):
        out = update(x, x0, k, schedule, noise)
        seen.append((k, schedule.steps, out.copy()))
        return out
    monkeypatch.setitem(SAMPLERS, method, dataclasses.replace(SAMPLERS[method], update=spy))
    calls: list = []
    settings = SamplingSettings(method=method, steps=5, guidance=1.0, z_dim=Z, feature_dim=D)
    x = sample_features(toy_step(calls), np.ones(C, np.float32), 7, settings, seed=9)
    assert [(k, T) for k, T, _ in seen] == [(4, 5), (3, 5), (2, 5), (1, 5), (0, 5)]
    for (_, _, out), (xin, _, _) in zip(seen, calls[1:]):
        np.testing.assert_array_equal(xin, out)
    np.testing.assert_array_equal(x, seen[-1][2])
    assert all(bool(np.any(z != 0)) == uses_z for _, z, _ in calls)


def test_ddgan_and_ddim_updates_are_the_documented_formulas():
    sch = make_schedule(10)
    rng = np.random.default_rng(0)
    x, x0, eps = (rng.standard_normal((2, 3, D), dtype=np.float32) for _ in range(3))
    k = 6
    got = ddgan_update(x, x0, k, sch, lambda: eps)
    np.testing.assert_allclose(got, sch.coef1[k] * x0 + sch.coef2[k] * x + sch.sigma[k] * eps, rtol=1e-6, atol=1e-6)
    last = np.float32(sch.coef1[0]) * x0 + np.float32(sch.coef2[0]) * x          # sigma[0] = 0: no ε drawn
    np.testing.assert_array_equal(ddgan_update(x, x0, 0, sch, lambda: 1 / 0), last)
    e = (x - sch.a_cum[k + 1] * x0) / sch.s_cum[k + 1]
    np.testing.assert_allclose(ddim_update(x, x0, k, sch, lambda: 1 / 0), sch.a_cum[k] * x0 + sch.s_cum[k] * e,
                               rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(ddim_update(x, x0, 0, sch, lambda: 1 / 0), x0)


def test_the_sampling_entry_points_take_at_most_six_parameters():
    from emdm.eval.sources import batched_features

    for fn in (sample_features, sampling, drive, run_together, finish, batched_features):
        assert len(inspect.signature(fn).parameters) <= 6, fn.__qualname__


def test_the_sampler_and_the_editor_import_without_the_command_line():
    """Library code is importable without its CLI: neither emdm.sampler nor emdm.motion.edit loads emdm.sample."""
    code = textwrap.dedent("""
        import sys
        import emdm.sampler, emdm.motion.edit, emdm.generation
        print(sorted(m for m in sys.modules if m == "emdm.sample"))
    """)
    env = {**os.environ, "PYTHONPATH": str(paths.REPO_ROOT / "scripts")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, check=True)
    assert r.stdout.strip() == "[]", r.stdout + r.stderr
