"""The live-stream parity fixture: ``emdm.motion.live.simulate`` on the tiny step model with the noise of every window
it generates, which ``src/live/simulate.ts`` must reproduce with the same noise (tests/unit/liveParity.test.ts):

    .venv/bin/python -m emdm.motion.live_fixture        # writes tests/fixtures/parity/tiny-live.{json,bin}

The model is ``emdm.motion.edit_fixture.tiny_editor`` (8 one-hot labels, DDGAN, 2 steps, guidance 2.5). The stream
starts with label ``b`` (seed 7), windows of ``WINDOW`` new frames, and plays ``FRAMES`` frames; ``PROMPTS`` are
(frame, label): the one at frame 51 comes while frame 50's window is in preparation (dropped, never
generated). Windows cost ``COST`` frames in turn
(6: on time, before the prompt's cut 8 frames on; 14: late, blended in from the frame after the one playing; 45: longer
than the lead, so playback runs out and the motion is played back: an underrun), so both joins and the underrun are
checked; the 45-frame window at frame 100 raises the lead to 90 and the 6-frame one after it lowers it again
(``leadNow``: the lead in use at the end, 86). Arrays:
``played_joints`` (FRAMES, 22, 3) as played (the display: smoothed, feet cleaned up), world coordinates;
``buffer_features`` the buffer at the end (from frame ``base``); per noise run ``r<k>_`` its ``x_T``, ``z_<k>``, ``eps_<k>``
(``emdm.fixtures.draw_noise``). JSON ``windows``: every generated window (id, label, seed, frames, c, cut, accepted
at, first new frame, dropped, its noise prefix).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from emdm.fixtures import draw_noise, noise_arrays, write_case
from emdm.motion import live as L
from emdm.motion.edit_fixture import LABELS, PARITY_DIR, STEPS, tiny_editor
from emdm.sampler.schedule import make_schedule

NAME = "tiny-live"
FIRST = ("b", 7)
WINDOW = 20             # new frames of a window (the stream's default is L.WINDOW; shorter keeps the fixture small)
FRAMES = 160
PROMPTS = ((25, "e"), (50, "g"), (51, "c"), (80, "h"))
COST = (6, 14, 45)


def make(out_dir: Path = PARITY_DIR, parity_dir: Path = PARITY_DIR) -> Path:
    core = L.LiveCore(tiny_editor(parity_dir), FIRST[0], FIRST[1], window=WINDOW)
    sim = L.simulate(core, FRAMES, PROMPTS, COST)
    sched = make_schedule(STEPS)
    arrays: dict[str, np.ndarray] = {"played_joints": sim.joints, "buffer_features": core.features}
    windows, by_noise = [], {}
    for req, at, frm, dropped in sim.windows:
        key = (req.frames, req.seed)
        if key not in by_noise:
            by_noise[key] = prefix = f"r{len(by_noise)}_"
            noise = noise_arrays(*draw_noise(np.random.default_rng(req.seed), STEPS, req.frames, 263, 64, sched, "ddgan"))
            arrays.update({prefix + k: v for k, v in noise.items()})
        windows.append({"id": req.id, "label": req.prompt, "seed": req.seed, "frames": req.frames, "c": req.c,
                        "cut": req.cut, "at": at, "from": frm, "dropped": dropped, "noise": by_noise[key]})
    meta = {
        "model": "tiny-step.onnx", "meanStd": "tiny.meanstd.f32", "labels": list(LABELS), "steps": STEPS,
        "first": {"label": FIRST[0], "seed": FIRST[1]}, "frames": FRAMES,
        "prompts": [{"frame": f, "label": p} for f, p in PROMPTS], "cost": list(COST),
        "window": WINDOW, "lead": L.LEAD, "promptLead": L.PROMPT_LEAD, "coast": L.COAST, "recentre": L.RECENTRE_M,
        "maxLead": L.MAX_LEAD, "leadSafety": L.LEAD_SAFETY, "leadStepDown": L.LEAD_STEP_DOWN,
        "displayPad": L.DISPLAY_PAD, "displayFade": L.DISPLAY_FADE, "promptKeepFrom": L.PROMPT_KEEP_FROM,
        "leadNow": core.lead_now,
        "base": core.base, "origin": list(core.origin), "underruns": core.underruns, "windows": windows,
    }
    return write_case(out_dir, NAME, meta, arrays)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.motion.live_fixture", description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=PARITY_DIR)
    print(f"live_fixture: wrote {make(ap.parse_args(argv).out)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
