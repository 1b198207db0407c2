"""The decoding parity fixture: de-normalised features → the joints a motion is shown with, by
``emdm.motion.decode.decode_joints``, which the page's ``decodeJoints`` (src/motion/decode.ts) must reproduce
(tests/unit/decodeParity.test.ts) and Python's must still give (tests/python/test_motion_decode.py):

    .venv/bin/python -m emdm.motion.decode_fixture        # writes tests/fixtures/parity/decode.{json,bin}
    .venv/bin/python -m emdm.motion.decode_fixture --keep-inputs   # after a decoding change: the committed inputs

Cases (each: ``<case>_features`` (F, 263) input, then ``<case>_smooth`` (recovered and smoothed),
``<case>_cleanup`` (recovered, feet cleaned up) and ``<case>_both`` (both: the page's default)):

* ``real``: the recover fixture's features (a real retargeted clip from the prepared dataset);
* ``generated``: the emdm-t2m-web parity run's features (a generated motion: jittery, not a rigid skeleton);
* ``contacts``: the real clip's features sunk 10 cm, with a one-frame flicker every 7 frames in its contact
  channels, so the gap closing, pinning, the knee IK and the floor lift all act.

The input features are copied into the fixture, so it does not go stale when the other fixtures change.
"""

from __future__ import annotations

import json

import numpy as np

from emdm import paths
from emdm.fixtures import write_case
from emdm.motion.decode import decode_joints
from emdm.motion.ik_fixture import read_case_array

PARITY_DIR = paths.FIXTURES_DIR / "parity"
NAME = "decode"
MODES = {"smooth": (True, False, False), "cleanup": (False, True, False), "both": (True, True, False),
         "loop": (True, True, True)}            # (smooth, foot clean-up, a looping clip)


def case_features() -> dict[str, np.ndarray]:
    real = read_case_array(PARITY_DIR, "recover", "features")
    gen = read_case_array(PARITY_DIR, "model-emdm-t2m-web", "features")
    contacts = real.copy()
    contacts[::7, -4:] = 0.0                                  # one-frame flickers inside the real contact runs
    contacts[:, 3] -= 0.1                                     # root height and every joint's (ric y): under the floor
    contacts[:, 5:67:3] -= 0.1
    return {"real": real, "generated": gen, "contacts": contacts}


def committed_features() -> dict[str, np.ndarray]:
    """The input features of the committed fixture, per case (what the currency test decodes again)."""
    meta = json.loads((PARITY_DIR / f"{NAME}.json").read_text())
    return {c: read_case_array(PARITY_DIR, NAME, f"{c}_features") for c in meta["cases"]}


def build(features: dict[str, np.ndarray] | None = None) -> tuple[dict, dict[str, np.ndarray]]:
    """Meta and arrays of the fixture for ``features`` per case (default: ``case_features()``, from the other
    fixtures)."""
    arrays, cases = {}, {}
    for name, feats in (case_features() if features is None else features).items():
        arrays[f"{name}_features"] = feats
        for mode, (smooth, cleanup, loop) in MODES.items():
            arrays[f"{name}_{mode}"] = decode_joints(feats, smooth=smooth, foot_cleanup=cleanup, loop=loop)
        cases[name] = {"frames": int(feats.shape[0])}
    modes = {m: {"smooth": s, "footCleanup": c, **({"loop": True} if lp else {})} for m, (s, c, lp) in MODES.items()}
    return {"cases": cases, "modes": modes}, arrays


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="python -m emdm.motion.decode_fixture", description=__doc__.split("\n\n")[0])
    ap.add_argument("--keep-inputs", action="store_true",
                    help="decode the committed fixture's input features again (a decoding change), instead of taking "
                         "them from the other fixtures (which a new model changes)")
    a = ap.parse_args(argv)
    meta, arrays = build(committed_features() if a.keep_inputs else None)
    print(write_case(PARITY_DIR, NAME, meta, arrays))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
