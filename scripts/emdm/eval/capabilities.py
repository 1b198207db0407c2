"""What a shipped model does well, as a small file the page ships (issue 30).

    python -m emdm.eval.capabilities --model emdm-t2m-web     # → public/models/capabilities-emdm-t2m-web.json
    python -m emdm.eval.capabilities --model emdm-a2m-web     # an action model: the action list only
    python -m emdm.eval.capabilities --model emdm-t2m-web --register   # also list it in manifest.json (sha256)

From the coverage benchmark's result (``docs/results/json/coverage-<model>.json``, ``emdm.eval.coverage``) at the
model's default step count: every action with its recognition rate, *covered* (rate ≥ 0.5) or weak, and its best
prompt. For a text model also *anchors*, embedded with the text encoder the page runs (int8, base64): of each covered
action its well-covered benchmark prompts (the chips: recognised ≥ 75 %) and up to ``--captions`` training captions;
of each uncovered action its plain prompt and first paraphrase and up to ``--uncovered-captions`` training captions
(so a prompt for an action the model does not do, such as "a person jumps", finds its own action instead of a covered
neighbour's captions). A prompt is *known* when its closest anchor is of a covered action and its cosine is at least
``check.threshold``; otherwise the page, the library's ``generate`` (``promptCheck``) and ``python -m emdm.sample``
say so (naming the uncovered action it reads as) and offer the three closest chips.

The threshold is calibrated on prompts the file was not built from: of each action's ``prompts.json`` paraphrases
the first is used to build, the others are held apart. Held-apart paraphrases of covered actions should pass, those
of uncovered actions should be warned; the threshold maximises the mean of the two success rates under the rule
above and the file records both error counts (``check``). Rebuild it whenever a model ships.

An action is covered only if its motions also *move*: where the realism result is of this model, the share of its
motions at the page's settings that move as the real clips of the action do (``moving``: peak joint speed at least a quarter of the
real clips' 5th percentile, ``emdm.eval.realism``) must be at least ``MOVES``, and a chip's own motions likewise. A
punch the classifier recognises from a boxer's guard that never throws a fist is not covered: the check names it and
offers working prompts instead.

Each action with real test clips also carries their speed (``realSpeed``: median horizontal root speed of each clip,
m/s; the clips' median and 5th–95th percentile), read from the realism benchmark's real row
(``docs/results/json/realism-*.json``, ``emdm.eval.realism``): the compare view shows a motion's speed beside the real
range of the prompt's nearest action (the check's ``action``).
"""

from __future__ import annotations

import argparse
import base64
import csv
import json
import re
import sys
from pathlib import Path
from typing import Callable

import numpy as np

from emdm import manifest as mf
from emdm.data.dataset import parse_text_file
from emdm.eval import realism_bars
from emdm.eval.coverage import COVERED, PROMPTS_FILE, CoverageError, chips, load_prompts, normalise, read_result
from emdm.eval.results import RESULTS_DIR
from emdm.prompt_check import (SCHEMA, SUGGESTIONS, CapabilitiesError, action_name, check, dequantise, file_name,  # noqa: F401
                               load, notice, prompt_notice)
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, display_path
from emdm import text as text_encoders      # .encode_texts looked up at each call: tests replace it

CAPTIONS = 16          # training captions per covered action kept as anchors
# per uncovered action: enough that its paraphrases find it (8: "a person hops on one foot" → hop, not walk), few
# enough to keep the page's download small (~1.6 × the covered-only file)
UNCOVERED_CAPTIONS = 8
OUTSIDE_FILE = Path(__file__).with_name("prompts_outside.json")
MOVES = 0.5            # covered (and a chip) only where at least this share of its motions move (realism ``moving``)
SCALE = 127            # int8 embedding = round(v · SCALE); unit vectors, so |q| ≤ 127
# prompts a new visitor tried (issue 30) and covered ones: checked by both runtimes against the file's answers
EXAMPLES = ["a person kicks", "bows", "throws a punch", "dances", "swims", "a person walks", "a person walks forward",
            "a person raises the left hand", "a person jumps", "someone jumps up and down", "a person bows",
            "a person punches", "a person waves", "a person waves goodbye", "a person hops on one foot"]


# ----------------------------------------------------------------------------- pure parts

def build_split(prompts: dict[str, list[str]]) -> tuple[dict[str, list[str]], dict[str, list[str]]]:
    """(used to build, held apart) per action: plain prompt + first paraphrase build, the other paraphrases are held."""
    return {a: ps[:2] for a, ps in prompts.items()}, {a: ps[2:] for a, ps in prompts.items()}


def quantise(emb: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(np.asarray(emb, np.float32) * SCALE), -127, 127).astype(np.int8)


def scores(anchors: np.ndarray, covered: np.ndarray, emb: np.ndarray) -> np.ndarray:
    """What the check compares with its threshold, per (unit) row of ``emb`` [N, d]: the best cosine to the anchors
    [M, d] where that closest anchor is of a covered action (``covered`` [M] bool), else -1 (warned at any threshold)."""
    cos = np.atleast_2d(emb) @ anchors.T
    return np.where(np.asarray(covered, bool)[cos.argmax(axis=1)], cos.max(axis=1), -1.0)


def calibrate(known: np.ndarray, unknown: np.ndarray, outside: np.ndarray | None = None) -> dict:
    """The threshold between scores that should pass (``known``) and those that should be warned (``unknown``, and
    ``outside``: prompts of no action of the vocabulary): maximises the mean of the pass rate of known and the warn
    rates of unknown and outside, midway between neighbouring scores."""
    sets = [unknown] + ([outside] if outside is not None and outside.size else [])
    cand = np.unique(np.concatenate([known, *sets]))
    cuts = np.concatenate([[cand[0] - 1e-3], (cand[1:] + cand[:-1]) / 2, [cand[-1] + 1e-3]])
    best = max(cuts, key=lambda t: ((known >= t).mean() + sum((u < t).mean() for u in sets), -abs(t - 0.7)))
    out = {"threshold": round(float(best), 4),
           "falseWarnings": {"n": int(known.size), "warned": int((known < best).sum())},
           "misses": {"n": int(unknown.size), "notWarned": int((unknown >= best).sum())}}
    if len(sets) > 1:
        out["outside"] = {"n": int(outside.size), "notWarned": int((outside >= best).sum())}
    return out


def load_outside(path: Path | str = OUTSIDE_FILE) -> list[str]:
    """The everyday prompts outside the action vocabulary (``prompts_outside.json``): the check should warn each."""
    try:
        doc = json.loads(Path(path).read_text())
    except ValueError as e:
        raise CoverageError(f"{path}: not JSON ({e})") from None
    ps = doc.get("prompts") if isinstance(doc, dict) else None
    if not isinstance(ps, list) or not all(isinstance(p, str) and p.strip() for p in ps):
        raise CoverageError(f"{path}: expected {{\"prompts\": [non-empty strings]}}")
    return ps


# ----------------------------------------------------------------------------- building

def moving_shares(realism: dict, model: str) -> tuple[dict[str, float], dict[str, float]]:
    """({action: share of its motions that move}, {prompt: the same}) of a realism result of ``model`` (the generated
    motions' ``moving``); two empty dicts for a result of another model or one measured before ``moving`` existed."""
    if realism.get("model") != model:
        return {}, {}
    gen = realism.get("generated", {})
    acts = {a: v["moving"] for a, v in gen.get("per_action", {}).items() if "moving" in v}
    return acts, {p: v["moving"] for p, v in gen.get("prompts", {}).items() if "moving" in v}


def actions_table(coverage: dict, prompts: dict[str, list[str]] | None,
                  moving: dict[str, float] | None = None, prompt_moving: dict[str, float] | None = None,
                  unwritten: set[str] | None = None) -> tuple[int, list[dict]]:
    """(steps, [{label, rate, covered, moving?, prompt?}] best first) at the model's default step count; ``moving``
    (per action) and ``prompt_moving`` (per prompt): shares of motions that move, where measured (``moving_shares``).
    An action's prompt is its best recognised one; on a tie the plain label prompt first, except for the actions in
    ``unwritten`` (``unwritten_plain``: "a person walks turn left"), where a written paraphrase is."""
    moving, prompt_moving, unwritten = moving or {}, prompt_moving or {}, unwritten or set()
    steps = int(coverage.get("default_steps", 10))
    run = next((r for r in coverage.get("runs", []) if r["steps"] == steps), None)
    if run is None:
        raise CoverageError(f"{coverage.get('_file')}: no run at the default {steps} steps; measure it first")
    per_prompt = run.get("prompts") or {}
    out = []
    for label, v in run["per_action"].items():
        if not v["n"]:
            continue
        row = {"label": label, "rate": round(v["rate"], 4),
               "covered": v["rate"] >= COVERED and moving.get(label, 1.0) >= MOVES}
        if label in moving:
            row["moving"] = round(moving[label], 4)
        mine = (prompts or {}).get(label, [])
        ps = sorted((p for p in mine if p in per_prompt and prompt_moving.get(p, 1.0) >= MOVES),
                    key=lambda p: (-per_prompt[p]["rate"], label in unwritten and p == mine[0]))
        if ps and per_prompt[ps[0]]["rate"] >= COVERED:
            row["prompt"] = ps[0]
        out.append(row)
    out.sort(key=lambda r: (-r["rate"], r["label"]))
    return steps, out


def real_speeds(realism: dict) -> dict[str, dict]:
    """Per action, its real test clips' speed from a realism result's real row (``real.reference.speeds``: one median
    horizontal root speed per clip, m/s): {median, low: 5th percentile, high: 95th percentile, clips}."""
    try:
        speeds = dict(realism["real"]["reference"]["speeds"])
    except (KeyError, TypeError, ValueError):
        raise CoverageError(f"{realism.get('_file', 'the realism result')}: no field real.reference.speeds; "
                            "rerun python -m emdm.eval.realism") from None
    out = {}
    for label, s in speeds.items():
        if len(s):
            lo, mid, hi = np.percentile(np.asarray(s, float), [5, 50, 95])
            out[label] = {"median": round(float(mid), 2), "low": round(float(lo), 2), "high": round(float(hi), 2),
                          "clips": len(s)}
    return out


def realism_result(model: str, results: Path, entry: dict | None = None) -> Path:
    """The realism result to read: with the model's manifest ``entry``, the newest of its shipped weights at the
    page's settings (``realism_bars.pick``: file, steps, guidance, x̂0 smoothing; the one the *moving* gate needs);
    else the newest of ``model`` (its real row is the dataset's test clips, the same for every model of that
    dataset), else the newest of any model."""
    if entry is not None:
        rs = []
        for f in sorted(results.glob(f"realism-{model}*.json")):
            r = json.loads(f.read_text())
            r["_path"] = f
            rs.append(r)
        default, _ = realism_bars.pick(rs, model, entry)
        if default is not None:
            return default["_path"]
    for pattern in (f"realism-{model}*.json", "realism-*.json"):
        found = sorted(results.glob(pattern), key=lambda p: (json.loads(p.read_text()).get("created", ""), p.name))
        if found:
            return found[-1]
    raise CoverageError(f"{results}: no realism-*.json; run python -m emdm.eval.realism --model {model} or pass --realism")


def unwritten_plain(prompts: dict[str, list[str]], captions: dict[str, list[str]]) -> set[str]:
    """The actions whose plain label prompt ("a person walks turn left", made from the label) is not how their training
    captions say it: its words after "a person" occur in none of them ("raises the left hand", "bows" do)."""
    out = set()
    for label, ps in prompts.items():
        words = re.sub(r"^(a person|someone)\s+", "", ps[0].strip().lower()) if ps else ""
        pattern = re.compile(r"\b" + re.escape(words) + r"\b")
        if words and not any(pattern.search(c.lower()) for c in captions.get(label, [])):
            out.add(label)
    return out


def training_captions(dataset: Path, actions: set[str], per_action: int | None = CAPTIONS) -> dict[str, list[str]]:
    """Up to ``per_action`` distinct train-split captions per action (evenly spread over the sorted list; None: all of
    them, sorted, to be spread later by ``spread``)."""
    meta = Path(dataset) / "metadata.csv"
    if not meta.is_file():
        raise CoverageError(f"{meta}: missing; pass --dataset (the prepared dataset the model was trained on)")
    found: dict[str, dict[str, str]] = {a: {} for a in actions}
    with open(meta, newline="") as f:
        for row in csv.DictReader(f):
            if row.get("split") == "train" and row.get("action") in actions:
                for cap, _, _ in parse_text_file(Path(dataset) / "texts" / f"{row['id']}.txt"):
                    found[row["action"]].setdefault(normalise(cap), cap.strip())
    return {a: spread(sorted(caps.values()), per_action) for a, caps in found.items()}


def spread(captions: list[str], per_action: int | None) -> list[str]:
    """At most ``per_action`` of the sorted ``captions``, evenly spread over them (None: all)."""
    if per_action is None:
        return captions
    stride = max(1, len(captions) // per_action) if captions else 1
    return captions[::stride][:per_action]


def build(coverage: dict, prompts: dict[str, list[str]] | None, captions: dict[str, list[str]],
          encode: Callable[[list[str]], np.ndarray], encoder: dict, realism: dict | None = None,
          outside: list[str] | None = None, unwritten: set[str] | None = None) -> dict:
    """The capabilities file (see the module doc) from a coverage result, the benchmark prompts, the training captions
    of its actions (covered and uncovered), an encoder (``encode``: texts → unit rows; ``encoder``: {id, sha256} of its file) and a
    realism result's real clips' speed per action (``real_speeds``, with ``source``: the result's file); ``outside``:
    prompts of no action of the vocabulary, held apart like the paraphrases (``load_outside``); ``unwritten``: the
    actions whose plain prompt yields to a paraphrase on a tie (``unwritten_plain``)."""
    moving, prompt_moving = (realism or {}).get("moving", {}), (realism or {}).get("promptMoving", {})
    steps, table = actions_table(coverage, prompts, moving, prompt_moving, unwritten)
    speeds = (realism or {}).get("speeds", {})
    for row in table:
        row["name"] = action_name(row["label"])
        if row["label"] in speeds:
            row["realSpeed"] = speeds[row["label"]]
    out = {"schema": SCHEMA, "model": coverage["name"], "condition": coverage.get("condition", "text"),
           "source": coverage.get("_file"), "coverageCreated": coverage.get("created"), "steps": steps,
           "thresholds": {"covered": COVERED, **({"chip": coverage["thresholds"]["chip"]} if "thresholds" in coverage else {}),
                          **({"moving": MOVES} if moving else {})},
           "actions": table}
    judge = coverage.get("classifier") or {}
    if judge.get("sha256"):     # who recognised the rates: one classifier, or several by their mean probability
        out["judge"] = {"classifiers": len(judge.get("members") or [judge]), "sha256": judge["sha256"]}
    if realism is not None:
        out["realSpeedSource"] = realism["source"]
        if moving:
            out["movingSource"] = realism["source"]
    if out["condition"] != "text":
        return out
    covered = {r["label"] for r in table if r["covered"]}
    labels = sorted(r["label"] for r in table)
    used, held = build_split(prompts)
    good = {p for p in chips(coverage, steps) if prompt_moving.get(p, 1.0) >= MOVES}
    texts, acts, suggest = [], [], []
    # a plain prompt no caption says ("a person walks turn left") is an anchor, not a suggestion
    unsaid = {prompts[a][0] for a in unwritten or ()}
    for a in labels:          # a covered action's used prompts only where they work (chips); an uncovered one's all
        for p in used.get(a, []):
            if p in good or a not in covered:
                texts.append(p), acts.append(a), suggest.append(a in covered and p not in unsaid)
        for c in captions.get(a, []):
            if normalise(c) not in {normalise(t) for t in texts}:
                texts.append(c), acts.append(a), suggest.append(False)
    q = quantise(encode(texts))
    anchors, of_covered = dequantise(q), np.array([a in covered for a in acts])
    should_pass = [p for a in labels if a in covered for p in held.get(a, [])]
    should_warn = [p for a in labels if a not in covered for p in held.get(a, [])]
    cal = calibrate(scores(anchors, of_covered, encode(should_pass)), scores(anchors, of_covered, encode(should_warn)),
                    scores(anchors, of_covered, encode(outside)) if outside else None)
    out["encoder"] = encoder
    out["check"] = {**cal, "suggestions": SUGGESTIONS,
                    "heldApart": "prompts.json paraphrases after the first of each covered action (should pass) and "
                                 "of each uncovered action (should be warned)"
                                 + ("; prompts_outside.json: everyday prompts of no action of the vocabulary (should be "
                                    "warned)" if outside else "")}
    out["anchors"] = {"scale": SCALE, "dim": int(q.shape[1]), "texts": texts, "actions": acts, "suggest": suggest,
                      "embeddings": base64.b64encode(q.tobytes()).decode("ascii")}
    # what this side's check says of a few prompts: the page's and the library's check must say the same
    out["examples"] = [{"prompt": p, **check(out, e)} for p, e in zip(EXAMPLES, encode(EXAMPLES))]
    return out


# ----------------------------------------------------------------------------- files

def encoder_info(manifest: dict, encoder_id: str) -> dict:
    entry = manifest["textEncoders"].get(encoder_id)
    if entry is None:
        raise CoverageError(f"manifest.json: no textEncoders entry {encoder_id!r}")
    return {"id": encoder_id, "onnx": entry["onnx"], "sha256": manifest["files"][entry["onnx"]]["sha256"]}


def write(caps: dict, path: Path) -> None:
    check_writable(path)
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(caps, indent=1, ensure_ascii=False) + "\n")
    tmp.replace(path)


def register(model: str, rel: str, models_dir: Path) -> None:
    """List the file under the model's manifest entry (``capabilities`` and ``files``), so the page verifies it."""
    m = mf.load(models_dir)
    entry = m["models"][model]
    entry["capabilities"] = rel
    entry["files"] = sorted(set(entry.get("files", [])) | {rel})
    mf.save(m, models_dir)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.capabilities", description=__doc__.split("\n\n")[0])
    ap.add_argument("--model", required=True, help="a shipped model with a coverage result")
    ap.add_argument("--coverage", type=Path, default=None, help="default docs/results/json/coverage-<model>.json")
    ap.add_argument("--dataset", type=Path, default=DATASET_DIR, help="its training captions (text models)")
    ap.add_argument("--prompts", type=Path, default=PROMPTS_FILE)
    ap.add_argument("--outside", type=Path, default=OUTSIDE_FILE,
                    help="everyday prompts of no action of the vocabulary, for the threshold (default %(default)s)")
    ap.add_argument("--captions", type=int, default=CAPTIONS, help="training captions per covered action")
    ap.add_argument("--uncovered-captions", type=int, default=UNCOVERED_CAPTIONS,
                    help="training captions per uncovered action")
    ap.add_argument("--realism", type=Path, default=None,
                    help="its real clips' speed per action and its motions' moving shares (the gate on covered): a "
                         "realism result of this model at the page's settings; default the newest such "
                         "docs/results/json/realism-<model>*.json")
    ap.add_argument("--models-dir", type=Path, default=mf.DEFAULT_MODELS_DIR)
    ap.add_argument("--register", action="store_true", help="also list the file in manifest.json with its sha256")
    a = ap.parse_args(argv)
    try:
        cov_path = a.coverage or RESULTS_DIR / "json" / f"coverage-{a.model}.json"
        coverage = read_result(cov_path)
        if coverage is None:
            where = "" if a.models_dir == mf.DEFAULT_MODELS_DIR else f" --models-dir {a.models_dir}"
            raise CoverageError(f"{cov_path}: no coverage result; run python -m emdm.eval.coverage --model {a.model}"
                                f"{where}" + (f" --out {a.coverage}" if a.coverage else ""))
        manifest = mf.load(a.models_dir)
        entry = manifest["models"].get(a.model)
        if entry is None:
            raise CoverageError(f"{a.models_dir / mf.MANIFEST_NAME}: no model {a.model!r}")
        real_path = a.realism or realism_result(a.model, RESULTS_DIR / "json", entry)
        realism = read_result(real_path)
        if realism is None:
            raise CoverageError(f"{real_path} (--realism): not found; run python -m emdm.eval.realism")
        speeds = real_speeds(realism)
        moving, prompt_moving = moving_shares(realism, a.model)
        if not moving:
            print(f"note: {display_path(real_path)} is not a realism result of {a.model} with moving shares: covered "
                  "goes by the classifier alone (pass --realism with this model's result)", file=sys.stderr)
        realism = {"speeds": speeds, "source": realism["_file"], "moving": moving, "promptMoving": prompt_moving}
        text = entry["condition"]["type"] == "text"
        prompts = load_prompts(a.prompts, coverage["labels"]) if text else None
        every = training_captions(a.dataset, set(coverage["labels"]), None) if text else {}    # read once
        unwritten = unwritten_plain(prompts, every) if text else None
        _, table = actions_table(coverage, prompts, moving, prompt_moving, unwritten)
        covered = {r["label"] for r in table if r["covered"]}
        captions = {x: spread(cs, a.captions if x in covered else a.uncovered_captions) for x, cs in every.items()}
        enc_id = entry["condition"].get("encoder", "")
        caps = build(coverage, prompts, captions, lambda ts: text_encoders.encode_texts(ts, enc_id, models_dir=a.models_dir),
                     encoder_info(manifest, enc_id) if text else {}, realism, load_outside(a.outside) if text else None,
                     unwritten)
        out = a.models_dir / file_name(a.model)
        write(caps, out)
        if a.register:
            register(a.model, file_name(a.model), a.models_dir)
    except (CoverageError, mf.ManifestError, OutputRefused, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    c = caps.get("check")
    print(f"wrote {display_path(out)} ({out.stat().st_size // 1024} KB): "
          f"{sum(r['covered'] for r in caps['actions'])} of {len(caps['actions'])} actions covered"
          + (f"; threshold {c['threshold']}: {c['falseWarnings']['warned']}/{c['falseWarnings']['n']} covered prompts "
             f"wrongly warned, {c['misses']['notWarned']}/{c['misses']['n']} uncovered ones not warned"
             + (f", {c['outside']['notWarned']}/{c['outside']['n']} outside the vocabulary not warned" if "outside" in c
                else "") if c else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
