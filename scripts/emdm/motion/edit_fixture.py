"""The timeline / in-between / body-part / loop parity fixture: ``emdm.motion.edit`` run on the tiny step model, with
the noise of every sampling call, which ``src/edit.ts`` must reproduce (≤ 1e-4) with the same noise:

    .venv/bin/python -m emdm.motion.edit_fixture        # writes tests/fixtures/parity/tiny-edit.{json,bin}

The model is the ``tiny`` entry of tests/fixtures/parity/tinyManifest.ts (tiny-step.onnx, tiny.meanstd.f32, an
8-label action model: label i's condition is the one-hot vector e_i), DDGAN, ``steps`` 2, guidance 2.5, the real
constants (C = 20, K = 10, seam easing M ≥ 10 frames at ≤ 5 m/s², 20 fps, maxFrames 196). Operations, in order (JSON ``ops``):

1. ``timeline``: segments (label, seconds, seed) → sequence ``timeline_features`` (48, 263) de-normalised and
   ``timeline_joints`` (48, 22, 3) (windows of 24, 34 and 30 frames; 14 and 10 new frames after the first).
2. ``regenerate`` from segment 2 (1-based) with a new label and seed: ``regen_features``/``regen_joints``; frames
   0..23 equal the timeline's, segment 3 (same seed, so the same noise) continues the new segment 2.
3. ``inbetween`` of ``timeline_features`` (defaults: keep 0..19 and 28..47) → ``inbetween_*``.
4. ``edit_body`` of ``timeline_features``, keep ``lower`` (root + legs) → ``body_*``.
5. ``loop`` of ``timeline_features`` (K = 10; the clip is 38 frames; pinned and eased like the in-between) → ``loop_*``; with ``in_place`` the same
   sampling with root x/z velocity zeroed → ``loop_in_place_joints`` (its features are ``loop_features`` with
   [:, 1:3] = 0).
6. ``loop`` of ``timeline_features`` by a model whose window is 34 frames (``loopLong``): only the last 34 frames are
   sampled (their first 20 and last 10 kept; the noise of the timeline's 34-frame window) → ``loop_long_*``.
7. ``ease``: ``seam_accel`` of a calm window and ``ease_seams`` at it of a window whose model frames drop 0.9 m two
   frames after the seam, both built from ``timeline_features`` frame 0 (``ease_case``); ``ease_out`` holds the rows
   it changed (the cross-fade grows past the fade's frames).

Every sampling call is a ``run`` (JSON ``runs``, in call order) with its frames, label, seed and the key prefix of
its noise arrays: ``<prefix>x_T``, then for k = steps−1..0 ``<prefix>z_<k>`` and ``<prefix>eps_<k>`` when drawn
(the order emdm.sampler draws them; ``emdm.fixtures.draw_noise``). Features are de-normalised throughout. Operations 3–5 start from the stored
``timeline_features`` (not a re-computed timeline), so their errors do not compound.
tests/python/test_fixtures_current.py regenerates the fixture and compares (``emdm.fixture_drift``: it must be current).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emdm import paths
from emdm.fixtures import draw_noise, noise_arrays, write_case
from emdm.model.open import onnx_step
from emdm.motion import edit as E
from emdm.sampler import SamplingSettings
from emdm.sampler.schedule import make_schedule

PARITY_DIR = paths.FIXTURES_DIR / "parity"
NAME = "tiny-edit"
LABELS = ("a", "b", "c", "d", "e", "f", "g", "h")       # tinyManifest.ts's labels
STEPS = 2
GUIDANCE = 2.5
SEGMENTS = (E.Segment("b", 1.2, 101), E.Segment("e", 0.7, 102), E.Segment("g", 0.5, 103))
REGEN = (1, E.Segment("c", 0.7, 202))                   # (0-based segment, its replacement)
INBETWEEN = ("d", 301)
BODY = ("f", 401, "lower")
LOOP = ("b", 501)
EASE = {"calmFrames": 40, "frames": 48, "sway": 0.06, "dropAt": 22, "drop": 0.9}   # ease_case
LOOP_LONG = ("h", 102, 34)      # label, seed, the model's window (the 48-frame timeline is longer); the noise of run r1_


def tiny_editor(parity_dir: Path = PARITY_DIR, record: list | None = None) -> E.Editor:
    """The tiny step model as an ``Editor`` with one-hot label conditions; ``record`` collects (frames, label, seed)
    of every sampling call."""
    ms = np.fromfile(parity_dir / "tiny.meanstd.f32", "<f4")
    eye = np.eye(len(LABELS), dtype=np.float32)

    class Recording(E.Editor):
        def sample(self, prompt, frames, seed, known=None, keep=None, keep_from_time=1.0):
            if record is not None:
                record.append((frames, prompt, seed))
            return super().sample(prompt, frames, seed, known, keep, keep_from_time)

    def condition(label: str) -> np.ndarray:
        if label not in LABELS:
            raise ValueError(f"unknown action {label!r}; labels: {', '.join(LABELS)}")
        return eye[LABELS.index(label)]

    return Recording(onnx_step(parity_dir / "tiny-step.onnx"), ms[:263], ms[263:], condition,
                     SamplingSettings(method="ddgan", steps=STEPS, guidance=GUIDANCE, z_dim=64), max_frames=196)


def make(out_dir: Path = PARITY_DIR, parity_dir: Path = PARITY_DIR) -> Path:
    calls: list = []
    model = tiny_editor(parity_dir, calls)
    tl = E.timeline(model, SEGMENTS)
    regen = E.regenerate(model, tl, REGEN[0], REGEN[1])
    mid = E.inbetween(model, tl.features, *INBETWEEN)
    body = E.edit_body(model, tl.features, BODY[0], BODY[1], keep=BODY[2])
    lp = E.loop(model, tl.features, *LOOP)
    lp_in_place = E.loop(model, tl.features, *LOOP, in_place=True)
    del calls[-1]                                # the in-place loop samples exactly as the loop before it
    from dataclasses import replace

    lp_long = E.loop(replace(model, max_frames=LOOP_LONG[2]), tl.features, LOOP_LONG[0], LOOP_LONG[1])
    n = len(tl.features)
    if not np.array_equal(regen.features[:tl.frames[0]], tl.features[:tl.frames[0]]):
        raise AssertionError("edit_fixture: regenerating segment 2 changed segment 1")

    sched = make_schedule(STEPS)
    arrays: dict[str, np.ndarray] = {}
    runs, by_noise = [], {}
    ops = ["timeline"] * 3 + ["regenerate"] * 2 + ["inbetween", "body", "loop", "loop_long"]
    for (frames, label, seed), op in zip(calls, ops, strict=True):
        key = (frames, seed)
        if key not in by_noise:
            prefix = f"r{len(by_noise)}_"
            by_noise[key] = prefix
            noise = noise_arrays(*draw_noise(np.random.default_rng(seed), STEPS, frames, 263, 64, sched, "ddgan"))
            arrays.update({prefix + k: v for k, v in noise.items()})
        runs.append({"op": op, "frames": frames, "label": label, "cond": LABELS.index(label), "seed": seed,
                     "noise": by_noise[key]})
    for name, m in (("timeline", tl), ("regen", regen), ("inbetween", mid), ("body", body), ("loop", lp), ("loop_long", lp_long)):
        arrays[f"{name}_features"] = m.features
        arrays[f"{name}_joints"] = m.joints
    arrays["loop_in_place_joints"] = lp_in_place.joints
    # 7. a seam eased at a calm window's accel: the timeline's frames 0..19 kept, then a 0.9 m drop two frames in
    calm, steep = ease_case(tl.features[0])
    accel = E.seam_accel(calm)
    eased = E.ease_seams(steep, E.context_keep(E.OVERLAP, len(steep) - E.OVERLAP), accel=accel)
    blend = int(np.nonzero((eased != steep).any(1))[0].max()) + 1 - E.OVERLAP
    arrays["ease_out"] = eased[E.OVERLAP:E.OVERLAP + blend]          # the rows it changed (the rest equal ``steep``)
    seg = lambda s: {"label": s.prompt, "cond": LABELS.index(s.prompt), "seconds": s.seconds, "seed": s.seed}  # noqa: E731
    meta = {
        "model": "tiny-step.onnx", "meanStd": "tiny.meanstd.f32", "labels": list(LABELS), "condition": "one-hot e_label",
        "objective": "ddgan", "steps": STEPS, "guidance": GUIDANCE, "zDim": 64, "featureDim": 263, "fps": E.FPS,
        "maxFrames": 196, "overlap": E.OVERLAP, "loopEnds": E.LOOP_ENDS,
        "seamEase": E.SEAM_EASE, "seamAccel": E.SEAM_ACCEL, "seamBlendExtra": E.SEAM_BLEND_EXTRA,
        "seamBlendTau": E.SEAM_BLEND_TAU, "seamBlendVelocity": E.SEAM_BLEND_VELOCITY, "seamAccelMin": E.SEAM_ACCEL_MIN,
        "timelineKeepFrom": E.TIMELINE_KEEP_FROM,
        "ops": {
            "timeline": {"segments": [seg(s) for s in SEGMENTS], "frames": list(tl.frames), "starts": tl.starts,
                         "total": n},
            "regenerate": {"segment": REGEN[0] + 1, "with": seg(REGEN[1]), "total": len(regen.features)},
            "inbetween": {"of": "timeline_features", "label": INBETWEEN[0], "cond": LABELS.index(INBETWEEN[0]),
                          "seed": INBETWEEN[1], "keepUntil": E.FPS - 1, "keepFrom": n - E.FPS},
            "body": {"of": "timeline_features", "label": BODY[0], "cond": LABELS.index(BODY[0]), "seed": BODY[1],
                     "keep": BODY[2], "groups": list(E.BODY_KEEP[BODY[2]])},
            "loop": {"of": "timeline_features", "label": LOOP[0], "cond": LABELS.index(LOOP[0]), "seed": LOOP[1],
                     "ends": E.LOOP_ENDS, "clipFrames": len(lp.features), "inPlace": "loop_in_place_joints"},
            "loopLong": {"of": "timeline_features", "label": LOOP_LONG[0], "cond": LABELS.index(LOOP_LONG[0]),
                         "seed": LOOP_LONG[1], "maxFrames": LOOP_LONG[2], "clipFrames": len(lp_long.features)},
            "ease": {"of": "timeline_features frame 0", **EASE, "keptFrames": E.OVERLAP, "accel": accel,
                     "blendFrames": blend, "out": "ease_out"},
        },
        "runs": runs,
    }
    return write_case(out_dir, NAME, meta, arrays)


def ease_case(frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """From one frame of features (the TS test builds the same): a calm window (``EASE["calmFrames"]`` frames: that
    pose, not turning or travelling, one joint swaying at most 6 m/s², so its ``seam_accel`` is between the bounds)
    and a window to ease (``EASE["frames"]``: the same, its first 20 frames kept, then model frames that hold two
    frames and drop 0.9 m in root height), for ``ease_seams`` at that accel. Computed in float64, stored float32."""
    t = np.arange(EASE["frames"], dtype=np.float64)
    calm = np.repeat(np.asarray(frame, np.float64)[None], EASE["frames"], 0)
    calm[:, 0:3] = 0                                     # no turning, no travel
    calm[:, 4] += EASE["sway"] * np.sin(t / 2)
    steep = calm.copy()
    steep[EASE["dropAt"]:, 3] -= EASE["drop"]
    return calm[:EASE["calmFrames"]].astype(np.float32), steep.astype(np.float32)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.motion.edit_fixture", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PARITY_DIR)
    path = make(ap.parse_args(argv).out)
    print(f"edit_fixture: wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
