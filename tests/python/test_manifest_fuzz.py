"""Fuzzing the manifest readers: malformed manifest.json files (wrong types, missing fields, huge numbers, NaN, paths
out of the folder, deep nesting, bytes that are not UTF-8) fed to ``emdm.manifest.load``, ``emdm.model.open`` and the
``emdm.sample`` CLI for a bounded time. Each must answer with its one error type (ManifestError, ModelError; the CLI
one ``error:`` line and exit status 2), never a traceback, and never spend more than a second of CPU on a case.

The cases come from the shipped manifest (its models' files are left out, so a manifest that is still valid is refused
for a missing file, with the same one line); each case is made by a seeded generator, so a failure names a seed that
reproduces it."""

from __future__ import annotations

import copy
import json
import random
import signal
import time
from pathlib import Path

import pytest

from emdm import manifest as mf
from emdm import paths
from emdm.model.open import ModelError, open_model
from emdm.sample import main as sample_main

BUDGET_S = 15.0          # wall time for the whole fuzz run
CASE_CPU_S = 1.0         # CPU time one case may take (CPU time: a loaded machine does not make it flaky)
CASE_WALL_S = 10         # a case still running after this is a hang (alarm)

JUNK = [None, True, False, 0, -1, 1.5, -1e308, 1e308, 10**400, 2**63, "", "x", "../../../../etc/passwd", "/etc/passwd",
        "a/../../b", "C:/x", "a\\b", "\u00e9\u2603", "x" * 5000, [], {}, [1, "a", None], {"a": {"b": []}},
        float("nan"), float("inf"), [10**9], [1, 100000], {"type": "action", "dim": 10**9}]


def _paths(node, at=()):
    """Every (path, value) in a JSON tree."""
    yield at, node
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for k, v in items:
        yield from _paths(v, at + (k,))


def _set(doc, at, value):
    if not at:
        return value
    parent = doc
    for k in at[:-1]:
        parent = parent[k]
    parent[at[-1]] = value
    return doc


def _delete(doc, at):
    parent = doc
    for k in at[:-1]:
        parent = parent[k]
    del parent[at[-1]]
    return doc


def _mutate_tree(base: dict, rng: random.Random) -> bytes:
    doc = copy.deepcopy(base)
    for _ in range(rng.randint(1, 3)):
        places = list(_paths(doc))
        at, _ = rng.choice(places)
        if at and rng.random() < 0.25:
            doc = _delete(doc, at)
        else:
            doc = _set(doc, at, copy.deepcopy(rng.choice(JUNK)))
    return json.dumps(doc).encode()                      # NaN/Infinity written as JSON.parse would refuse them


def _mutate_bytes(text: bytes, rng: random.Random) -> bytes:
    kind = rng.randrange(6)
    if kind == 0:                                        # cut short
        return text[:rng.randrange(len(text))]
    if kind == 1:                                        # bytes that are not UTF-8
        i = rng.randrange(len(text))
        return text[:i] + bytes(rng.choice([b"\xff", b"\xc3", b"\xed\xa0\x80", b"\x80\x80"])) + text[i:]
    if kind == 2:                                        # a flipped byte anywhere
        i = rng.randrange(len(text))
        return text[:i] + bytes([text[i] ^ (1 << rng.randrange(8))]) + text[i + 1:]
    if kind == 3:                                        # deep nesting, where a value goes
        depth = rng.choice([100, 1000, 100_000])
        return b'{"schema": 1, "models": ' + b"[" * depth + b"]" * depth + b"}"
    if kind == 4:                                        # a number of 5000 digits
        return b'{"schema": 1, "models": {"m": {"zDim": ' + b"9" * 5000 + b"}}}"
    return rng.choice([b"", b"null", b"[]", b'"x"', b"1e999", b"\xef\xbb\xbf{}", b"{" * 10])


def _case(base: dict, seed: int) -> bytes:
    rng = random.Random(seed)
    if rng.random() < 0.7:
        return _mutate_tree(base, rng)
    return _mutate_bytes(json.dumps(base).encode(), rng)


def _alarm(signum, frame):
    raise TimeoutError(f"a case ran past {CASE_WALL_S} s")


def _check_one(d: Path, out: Path, capsys) -> None:
    """The three readers on the manifest in ``d``: each answers with its one error type."""
    try:
        man = mf.load(d)
    except mf.ManifestError as e:
        assert "\n" not in str(e).strip() and str(e).startswith(str(d)), repr(str(e)[:300])
        man = None
    names = list(man["models"]) if man is not None else []
    for name in names[:3]:
        with pytest.raises(ModelError) as e:
            open_model(name, models_dir=d)
        assert "\n" not in str(e.value).strip(), repr(str(e.value)[:300])
    if man is not None:
        try:
            mf.verify(d)
        except mf.ManifestError:
            pass
    name = names[0] if names and isinstance(names[0], str) else "emdm-a2m-web"
    capsys.readouterr()
    rc = sample_main(["--model", name, "--models-dir", str(d), "--action", "walk", "--frames", "12", "--steps", "1",
                      "--out", str(out)])
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert rc == 2 and "Traceback" not in err, (rc, err[-1500:])
    assert len(lines) == 1 and lines[0].startswith("error: ") and len(lines[0]) < 2000, lines[:3]


def test_malformed_manifests_get_one_clear_error_each(tmp_path, capsys):
    base = json.loads((paths.MODELS_DIR / mf.MANIFEST_NAME).read_text())
    d = tmp_path / "models"
    d.mkdir()
    out = tmp_path / "o" / "x"
    old = signal.signal(signal.SIGALRM, _alarm)
    t_end = time.monotonic() + BUDGET_S
    seed, worst = 0, 0.0
    try:
        while time.monotonic() < t_end and seed < 5000:
            text = _case(base, seed)
            (d / mf.MANIFEST_NAME).write_bytes(text)
            signal.alarm(CASE_WALL_S)
            cpu = time.process_time()
            try:
                _check_one(d, out, capsys)
            except BaseException as e:
                raise AssertionError(f"seed {seed} ({text[:160]!r}...): {type(e).__name__}: {str(e)[:600]}") from e
            finally:
                signal.alarm(0)
            spent = time.process_time() - cpu
            worst = max(worst, spent)
            assert spent < CASE_CPU_S, f"seed {seed}: {spent:.2f} s of CPU ({text[:160]!r}...)"
            seed += 1
    finally:
        signal.signal(signal.SIGALRM, old)
    assert not out.parent.exists(), "a case wrote output"
    assert seed >= 50, f"only {seed} cases ran in {BUDGET_S} s"
    print(f"{seed} malformed manifests, each one clear error; worst {worst * 1000:.0f} ms CPU")
