"""Sampling motions from a step model, file for file the twin of src/sampler/ (docs/ARCHITECTURE.md "Sampling"):

    from emdm.sampler import SamplingSettings, make_condition, sample_features
    settings = SamplingSettings.from_entry(entry, steps=10, mean=mean, std=std)   # method, guidance, interval, ...
    x = sample_features(step, make_condition(entry["condition"], "a person waves", None, False), 120, settings, seed=1)

- ``schedule``: the variance-preserving schedule (DDGAN posterior and DDIM marginals) for T steps;
- ``ddgan`` / ``ddim``: one update function each, ``registry``: the method names the loop can run;
- ``settings``: ``SamplingSettings`` and ``SampleError``; ``condition``: the condition vector;
- ``sampler``: the loop (``sample_features``, ``sampling`` as a generator, ``drive``);
- ``lockstep``: several runs with one model call per step (``run_together``, ``finish``);
- ``flags``: the command-line flags of the settings every command shares (``add_sampling_settings``, ``with_flags``).
"""

from emdm.sampler.condition import denormalise, make_condition
from emdm.sampler.lockstep import finish, run_together
from emdm.sampler.registry import SAMPLERS, Sampler
from emdm.sampler.sampler import STOP, StepFn, drive, sample_features, sampling
from emdm.sampler.settings import MAX_SEED, SampleError, SamplingSettings, check_steps, check_x0_smoothing

__all__ = ["MAX_SEED", "SAMPLERS", "STOP", "SampleError", "Sampler", "SamplingSettings", "StepFn", "check_steps",
           "check_x0_smoothing", "denormalise", "drive", "finish", "make_condition", "run_together",
           "sample_features", "sampling"]
