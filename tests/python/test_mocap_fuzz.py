"""Fuzz the mocap readers (issue 29): malformed BVH and ASF/AMC made from real-looking files by a seeded mutator
(truncate, drop or duplicate lines, numbers swapped for huge/NaN/negative/garbage values, random bytes, deep
nesting, huge counts). Each file must be read, or rejected with MocapFormatError (one message naming the file),
never another exception or warning, and never hang: a case over 1 s is run once more and fails if it is slow again (a
stalled CI machine gets a second chance; a hang does not pass). Deterministic (seed 29), 8,000 cases, and
stopped after BUDGET_S seconds so it stays bounded on a slow machine."""

import random
import signal
import time
import warnings

import numpy as np
import pytest

from emdm import skeleton as sk
from emdm.mocap import asfamc, bvh
from emdm.mocap.errors import MocapFormatError
from emdm.mocap.jointmap import load_joint_map
from emdm.mocap.load import load_bvh_clip
from test_mocap_asfamc import ASF
from test_mocap_bvh import reference_bvh_text

CASES = 4000           # per format
BUDGET_S = 10.0        # per format: the loop stops here even if CASES are not all run
LIMIT_S = 1.0
ODD = ["1e308", "-1e308", "nan", "-inf", "inf", "0", "-0", "-1", "-7", "99999999999999999999999", "1e-320", "",
       "x", "1_0", "0x10", "١٢", "2147483648", "-2147483649", "1e9", "3.5", "NaN", "{", "}"]


class Hang(Exception):
    pass


def _alarm(*_):
    raise Hang()


def _mutate(text: str, rng: random.Random) -> bytes:
    lines = text.split("\n")
    for _ in range(rng.choice([1, 1, 2, 3])):
        op = rng.randrange(7)
        k = rng.randrange(len(lines)) if lines else 0
        if op == 0 and lines:                                   # truncate
            lines = lines[:k] + ([lines[k][:rng.randrange(len(lines[k]) + 1)]] if k < len(lines) else [])
        elif op == 1 and lines:                                 # drop a line
            del lines[k]
        elif op == 2 and lines:                                 # duplicate a run of lines
            n = rng.randint(1, 8)
            lines[k:k] = lines[k:k + n] * rng.choice([1, 2, 50])
        elif op in (3, 4) and lines:                            # a value swapped for an odd one
            toks = lines[k].split(" ")
            toks[rng.randrange(len(toks))] = rng.choice(ODD)
            lines[k] = " ".join(toks)
        elif op == 5:                                           # random bytes
            raw = "\n".join(lines).encode()
            at = rng.randrange(len(raw) + 1)
            junk = bytes(rng.randrange(256) for _ in range(rng.randint(1, 40)))
            return raw[:at] + junk + raw[at + rng.randint(0, 40):]
        else:                                                   # deep nesting / long chains
            lines[k:k] = _deep(rng)
    return "\n".join(lines).encode()


def _deep(rng: random.Random) -> list[str]:
    n = rng.choice([50, 1200])
    kind = rng.randrange(3)
    if kind == 0:
        return [f"JOINT d{i}\n{{\nOFFSET 0 1 0\nCHANNELS 3 Zrotation Xrotation Yrotation" for i in range(n)] + ["}"] * n
    if kind == 1:
        return ["{"] * n + ["}"] * rng.choice([0, n])
    return [f"  begin\n name b{i}\n direction 0 1 0\n length 1\n dof rx\n  end" for i in range(n)]


def _bvh_text() -> str:
    F = 12
    t = np.arange(F) / 30.0
    path = np.stack([np.zeros(F), np.full(F, sk.REFERENCE_OFFSETS[0, 1]), 1.2 * t], axis=1)
    return reference_bvh_text(path, np.linspace(0, 90, F), np.full(F, 20.0))


def _run_case(fn) -> str:
    """'read' or 'rejected'; a Hang or any other exception propagates."""
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, LIMIT_S)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")          # a numpy overflow warning is a case not handled either
            fn()
        return "read"
    except MocapFormatError as e:
        assert str(e).strip() and "\n" not in str(e), repr(e)
        return "rejected"
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _fuzz(tmp_path, seed: int, sources: dict[str, str], read) -> dict[str, int]:
    rng = random.Random(seed)
    seen = {"read": 0, "rejected": 0}
    t0 = time.monotonic()
    for case in range(CASES):
        if time.monotonic() - t0 > BUDGET_S:
            break
        name = rng.choice(sorted(sources))
        files = {k: v.encode() for k, v in sources.items()}
        files[name] = _mutate(sources[name], rng)
        paths = {}
        for k, data in files.items():
            paths[k] = tmp_path / f"case{case % 4}.{k}"
            paths[k].write_bytes(data)
        try:
            outcome = _run_case(lambda: read(paths))
        except Hang:
            try:
                outcome = _run_case(lambda: read(paths))
            except Hang:
                pytest.fail(f"case {case} (seed {seed}, mutated {name}) took over {LIMIT_S} s twice:\n"
                            f"{files[name][:2000]!r}")
        except Exception as e:  # noqa: BLE001 - the point of the test: any other exception is a bug
            pytest.fail(f"case {case} (seed {seed}, mutated {name}) raised {type(e).__name__}: {e}\n"
                        f"{files[name][:2000]!r}")
        seen[outcome] += 1
    return seen


def test_malformed_bvh_is_read_or_rejected_with_one_message(tmp_path):
    jm_path = tmp_path / "map.json"
    jm_path.write_text('{"name": "reference", "format": "bvh", "scale": 0.01, "up": "y", "joints": {'
                       + ", ".join(f'"{n}": "{n}"' for n in sk.JOINT_NAMES) + "}}")
    jmap = load_joint_map(str(jm_path))

    def read(paths):
        bvh.read_bvh_names(paths["bvh"])
        load_bvh_clip(paths["bvh"], jmap)

    seen = _fuzz(tmp_path, 29, {"bvh": _bvh_text()}, read)
    assert seen["read"] > 5 and seen["rejected"] > 100, seen


def test_malformed_asf_amc_is_read_or_rejected_with_one_message(tmp_path):
    asf_text = ASF.format(length=1.0, angle="deg", axis90=90)
    frames = "".join(f"{i}\nroot {i} 0 0 0 {i} 0\nupper {i} 0 0\nlower 0 {i}\n" for i in range(1, 30))
    amc_text = ":FULLY-SPECIFIED\n:DEGREES\n" + frames

    def read(paths):
        asf = asfamc.read_asf(paths["asf"])
        asfamc.forward_kinematics(asf, asfamc.read_amc(paths["amc"], asf))

    seen = _fuzz(tmp_path, 29, {"asf": asf_text, "amc": amc_text}, read)
    assert seen["read"] > 5 and seen["rejected"] > 100, seen
