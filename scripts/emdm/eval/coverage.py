"""Coverage: does every action of the dataset come out of its prompt? (issue 12)

    python -m emdm.eval.coverage --model emdm-t2m-web                 # steps 1,2,4,10, 8 seeds per prompt
    python -m emdm.eval.coverage --model emdm-a2m-web --steps 10      # the action model: one-hot labels
    python -m emdm.eval.coverage --ckpt runs/t2m/ckpt.pt --name t2m-balanced
    python -m emdm.eval.coverage --model emdm-t2m-web --chips         # the page's chip candidates (no sampling)

Per action of the dataset vocabulary (actions.json), a text model gets the plain label prompt and the
paraphrases of ``prompts.json`` (beside this file), an action model the label's one-hot condition. Each
prompt makes ``--seeds`` motions, with lengths drawn like the test split (``protocol.sample_lengths``: from
the action's own test clips), at every ``--steps`` count and the model's guidance. The project's judge
(``emdm.eval.judge``: the action classifiers of three seeds, by their mean probability) names every motion; a
motion is *recognised* when it names the prompt's action. Per step count: each action's recognition rate, the macro accuracy (mean rate over the
vocabulary) and the actions *covered* (rate ≥ 0.5). The real test clips, classified the same way, are the
reference row: the *reference set* is the actions recognised in ≥ 50 % of their real clips; actions with
fewer than ``--min-clips`` test clips cannot be tested there and are listed apart with their counts.
*Chips*: the prompts recognised in ≥ 75 % of their motions at the model's default step count.

Writes ``docs/results/json/coverage-<name>.json``; runs of other step counts already in that file (same
model, seeds, guidance, prompts, judge files) are kept, so step counts can be measured one call at a time.
``python -m emdm.eval.report`` turns the files into RESULTS.md's coverage section. On a shared CPU prefix
with ``nice``; one step count of a shipped model takes a few minutes on one thread.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import sys
import time
from datetime import datetime, timezone
from pathlib import Path
from typing import Sequence

import numpy as np

from emdm.data.dataset import DatasetError, cached_text_embeddings, parse_text_file
from emdm.eval import data as evdata
from emdm.eval.protocol import Conditions, sample_lengths
from emdm.eval.args import add_model_source
from emdm.eval.judge import Judge, JudgeError, add_argument as add_judge_argument
from emdm.eval.results import RESULTS_DIR, SCHEMA, dataset_info, hardware, slug, write_result
from emdm.eval.sources import ModelSource
from emdm.model.open import ModelError, open_model
from emdm.outdir import OutputRefused, check_writable
from emdm.paths import DATASET_DIR, display_path
from emdm.eval.plausibility import flip_share
from emdm.sampler.flags import add_sampling_settings

PROMPTS_FILE = Path(__file__).with_name("prompts.json")
COVERED = 0.5          # an action is covered when recognised in at least this share of its motions
CHIP = 0.75            # a prompt may be a page chip when recognised in at least this share
MIN_CLIPS = 3          # fewer real test clips than this: the action cannot be tested on the real row


class CoverageError(ValueError):
    """A prompts file, dataset, classifier or result file does not fit (the message names which)."""


# ----------------------------------------------------------------------------- prompts

def normalise(text: str) -> str:
    """Lower case, words only: how prompts are compared with captions ('A person bows.' = 'a person bows')."""
    return " ".join(re.findall(r"[a-z0-9]+", text.lower()))


def load_prompts(path: Path | str, labels: list[str]) -> dict[str, list[str]]:
    """Action → [plain label prompt, paraphrase, ...] for every label; an error names missing labels."""
    path = Path(path)
    try:
        acts = json.loads(path.read_text())["actions"]
    except (OSError, json.JSONDecodeError, KeyError, TypeError) as e:
        raise CoverageError(f"{path}: expected {{\"actions\": {{label: {{\"plain\": ..., \"paraphrases\": [...]}}}}}} ({e})") from e
    missing = [a for a in labels if a not in acts]
    if missing:
        raise CoverageError(f"{path}: no prompts for {len(missing)} action(s) of the vocabulary: {', '.join(missing)}; add them")
    out = {}
    for a in labels:
        e = acts[a]
        prompts = [e.get("plain", "")] + list(e.get("paraphrases", []))
        if not all(isinstance(p, str) and p.strip() for p in prompts) or len(prompts) < 4:
            raise CoverageError(f"{path}: action {a!r} needs a non-empty 'plain' and at least 3 'paraphrases'")
        if len({normalise(p) for p in prompts}) != len(prompts):
            raise CoverageError(f"{path}: action {a!r} repeats a prompt")
        out[a] = prompts
    return out


def dataset_captions(root: Path | str) -> dict[str, str]:
    """normalised caption → the caption file it occurs in, over every clip of the dataset."""
    out: dict[str, str] = {}
    for f in sorted((Path(root) / "texts").glob("*.txt")):
        for caption, _, _ in parse_text_file(f):
            out.setdefault(normalise(caption), f.name)
    return out


def seen_paraphrases(prompts: dict[str, list[str]], captions: dict[str, str]) -> list[str]:
    """'action: "paraphrase" (file)' for each paraphrase that is a caption of the dataset."""
    return [f"{a}: {p!r} ({captions[normalise(p)]})" for a, ps in prompts.items() for p in ps[1:]
            if normalise(p) in captions]


# ----------------------------------------------------------------------------- summaries (pure)

def rates(labels: list[str], target: np.ndarray, pred: np.ndarray) -> dict[str, dict]:
    """Per action of ``labels``: motions made for it (n), recognised (pred == target), rate (None if n = 0)."""
    target, pred = np.asarray(target), np.asarray(pred)
    out = {}
    for i, a in enumerate(labels):
        sel = target == i
        n, k = int(sel.sum()), int((pred[sel] == i).sum())
        out[a] = {"n": n, "recognised": k, "rate": k / n if n else None}
    return out


def real_summary(labels: list[str], actions: np.ndarray, pred: np.ndarray, min_clips: int = MIN_CLIPS) -> dict:
    """The reference row: per-action rates on the real test clips, the reference set (rate ≥ COVERED among
    actions with ≥ ``min_clips`` clips), the actions with too few clips {label: clips}, and the macro
    accuracy over the testable actions."""
    per = rates(labels, actions, pred)
    testable = [a for a in labels if per[a]["n"] >= min_clips]
    return {"per_action": per, "min_clips": min_clips,
            "reference": [a for a in testable if per[a]["rate"] >= COVERED],
            "too_few": {a: per[a]["n"] for a in labels if per[a]["n"] < min_clips},
            "macro_accuracy": float(np.mean([per[a]["rate"] for a in testable])) if testable else None}


def run_summary(per: dict[str, dict], reference: list[str]) -> dict:
    """Macro accuracy over the vocabulary and over the reference set, the covered actions, and how many
    of the reference set are covered."""
    measured = [a for a, v in per.items() if v["n"]]
    covered = [a for a in measured if per[a]["rate"] >= COVERED]
    ref = [a for a in reference if a in per and per[a]["n"]]
    return {"macro_accuracy": float(np.mean([per[a]["rate"] for a in measured])) if measured else None,
            "macro_reference": float(np.mean([per[a]["rate"] for a in ref])) if ref else None,
            "covered": covered, "covered_reference": [a for a in ref if a in covered],
            "reference_size": len(reference)}


def prompt_rates(prompt_of: list[str], target: np.ndarray, pred: np.ndarray, labels: list[str]) -> dict[str, dict]:
    """Per prompt (text models): its action, motions, recognised, rate, and what the classifier named."""
    out: dict[str, dict] = {}
    for i, p in enumerate(prompt_of):
        e = out.setdefault(p, {"action": labels[int(target[i])], "n": 0, "recognised": 0, "predicted": {}})
        e["n"] += 1
        e["recognised"] += int(pred[i] == target[i])
        name = labels[int(pred[i])]
        e["predicted"][name] = e["predicted"].get(name, 0) + 1
    for e in out.values():
        e["rate"] = e["recognised"] / e["n"]
    return out


def chips(result: dict, steps: int, threshold: float = CHIP) -> list[str]:
    """The prompts recognised in ≥ ``threshold`` of their motions at ``steps``, best first."""
    run = next((r for r in result.get("runs", []) if r["steps"] == steps), None)
    if run is None:
        have = ", ".join(str(r["steps"]) for r in result.get("runs", [])) or "none"
        raise CoverageError(f"{result.get('_file', 'coverage result')}: no run at {steps} steps (have: {have}); "
                            f"measure it with --steps {steps}")
    ps = run.get("prompts") or {}
    return [p for p, e in sorted(ps.items(), key=lambda kv: (-kv[1]["rate"], kv[0])) if e["rate"] >= threshold]


# ----------------------------------------------------------------------------- measuring

class Benchmark:
    """The fixed part of a coverage run: test split, classifier, prompts (or labels), lengths, real row."""

    def __init__(self, dataset: Path, split: str, classifier: Path | Sequence[Path], prompts_file: Path, seeds: int, seed: int = 0,
                 min_clips: int = MIN_CLIPS, log=print):
        self.test = evdata.load_split(dataset, split, require_action=True)
        self.labels = list(self.test.action_labels)
        if not self.labels:
            raise CoverageError(f"{dataset}: no actions.json/metadata.csv, so no actions to cover")
        try:
            self.judge = Judge(classifier)
        except JudgeError as e:                # missing, unreadable, not a classifier or not alike: names the file
            raise CoverageError(str(e)) from None
        have, first = self.judge.labels, display_path(self.judge.paths[0])
        if have is not None and list(have) != self.labels:
            raise CoverageError(f"{first}: trained on labels {have[:4]}… ({len(have)}), the dataset {dataset} has "
                                f"{self.labels[:4]}… ({len(self.labels)}); retrain it on this dataset")
        if self.judge.num_classes != len(self.labels):
            raise CoverageError(f"{first}: {self.judge.num_classes} classes, {dataset} has {len(self.labels)} actions")
        self.dataset, self.prompts_file, self.seeds, self.seed, self.log = Path(dataset), Path(prompts_file), seeds, seed, log
        t0 = time.time()
        self.real = real_summary(self.labels, self.test.actions, self.predict(self.test.motions), min_clips)
        self.real["n"] = len(self.test)
        self.real["flip_share"] = flip_share(self.test.motions)
        log(f"real test clips: {len(self.test)}, reference set {len(self.real['reference'])}/{len(self.labels)} actions, "
            f"too few clips: {self.real['too_few']} ({time.time() - t0:.0f} s)")

    def predict(self, motions) -> np.ndarray:
        return self.judge.predict(motions)

    def conditions(self, source):
        """The motions to make: Conditions (one row per motion), the action id and prompt of each row."""
        rows_action, rows_prompt, lengths = [], [], []
        prompts = load_prompts(self.prompts_file, self.labels) if source.task == "text" else None
        for i, a in enumerate(self.labels):
            ps = prompts[a] if prompts else [a]
            rng = np.random.default_rng([self.seed, i])
            lengths.append(sample_lengths(self.test, len(ps) * self.seeds, rng, action=i))
            rows_action += [i] * (len(ps) * self.seeds)
            rows_prompt += [p for p in ps for _ in range(self.seeds)]
        lengths = np.minimum(np.concatenate(lengths), source.max_frames)
        action = np.array(rows_action)
        if source.task == "text":
            uniq = list(dict.fromkeys(rows_prompt))
            emb = cached_text_embeddings(uniq, evdata.TEXT_ENCODER, os.environ.get("EMDM_EVAL_CACHE") or evdata.CACHE_DIR)
            index = {p: k for k, p in enumerate(uniq)}
            return Conditions(lengths, texts=rows_prompt, text_emb=emb[[index[p] for p in rows_prompt]]), action, rows_prompt
        model_labels = list(source.cond_spec.get("labels") or [])
        missing = [a for a in self.labels if a not in model_labels]
        if missing:
            raise CoverageError(f"{source.model or source.ckpt}: the action model has no condition for {', '.join(missing)} "
                                f"of the dataset {self.dataset}")
        ids = np.array([model_labels.index(self.labels[i]) for i in action])
        return Conditions(lengths, labels=ids), action, rows_prompt

    def measure(self, source) -> dict:
        """One step count: generate every motion, classify, summarise."""
        t0 = time.time()
        cond, action, prompt_of = self.conditions(source)
        motions = source.generate(cond, self.seed)
        t_gen = time.time() - t0
        pred = self.predict(motions)
        per = rates(self.labels, action, pred)
        run = {"steps": source.steps, "motions": len(motions), **run_summary(per, self.real["reference"]),
               "flip_share": flip_share(motions),
               "per_action": per, "generate_seconds": round(t_gen, 1), "seconds": round(time.time() - t0, 1),
               "load_avg_1min_end": os.getloadavg()[0]}
        if source.task == "text":
            run["prompts"] = prompt_rates(prompt_of, action, pred, self.labels)
        self.log(f"[{source.name}] {len(motions)} motions in {run['seconds']:.0f} s: macro {run['macro_accuracy']:.3f}, "
                 f"covered {len(run['covered'])}/{len(self.labels)}, reference {len(run['covered_reference'])}/"
                 f"{run['reference_size']}, frames with a one-frame flip {run['flip_share']:.1%}")
        return run


def model_defaults(opened) -> tuple[float, int]:
    """(guidance, default steps) of an opened model (emdm.model.open): the manifest entry's for a shipped model,
    the sampler's for a checkpoint."""
    return float(opened.meta.get("guidance", 2.5)), int(opened.meta.get("defaultSteps", 10))


def _key(a, guidance: float, guidance_min_time: float = 0.0, x0_smoothing: float = 0.0) -> dict:
    prompts = hashlib.sha256(Path(a.prompts).read_bytes()).hexdigest()[:16]
    return {"seeds": a.seeds, "seed": a.seed, "guidance": guidance, "prompts_sha256": prompts,
            "variant_file": a.variant or "fp32", "split": a.split,
            **({"guidance_min_time": guidance_min_time} if guidance_min_time else {}),
            **({"x0_smoothing": x0_smoothing} if x0_smoothing else {})}


def default_out(a) -> Path:
    name = a.name or a.model or slug(Path(a.ckpt).parent.name, Path(a.ckpt).stem)
    return RESULTS_DIR / "json" / f"coverage-{slug(name)}{'' if a.variant in (None, 'fp32') else '-' + a.variant}.json"


def read_result(path: Path) -> dict | None:
    if not path.exists():
        return None
    try:
        r = json.loads(path.read_text())
    except json.JSONDecodeError as e:
        raise CoverageError(f"{path}:{e.lineno}: not valid JSON ({e.msg}); delete it or pass another --out") from e
    r["_file"] = display_path(path)
    return r


def run(a) -> Path:
    out = check_writable(a.out or default_out(a))          # before anything is measured
    opened = open_model(a.ckpt if a.ckpt is not None else a.model, models_dir=a.models_dir, variant=a.variant,
                        device=a.device, threads=a.threads)  # once, for every step count
    guidance, default_steps = model_defaults(opened)
    guidance = guidance if a.guidance is None else a.guidance
    gmin = float(opened.meta.get("guidanceMinTime", 0.0)) if a.guidance_min_time is None else a.guidance_min_time
    sigma = float(opened.meta.get("x0Smoothing", 0.0)) if a.x0_smoothing is None else a.x0_smoothing
    bench = Benchmark(a.dataset, a.split, a.classifier, a.prompts, a.seeds, a.seed, a.min_clips)
    seen = seen_paraphrases(load_prompts(a.prompts, bench.labels), dataset_captions(a.dataset))
    if seen:
        raise CoverageError(f"{a.prompts}: {len(seen)} paraphrase(s) are captions of the dataset {a.dataset}, so they "
                            f"do not test generalisation: " + "; ".join(seen[:5]))
    key = _key(a, guidance, gmin, sigma)
    old = read_result(out)
    judge = bench.judge.info()
    runs = {r["steps"]: r for r in (old or {}).get("runs", [])} if old and old.get("key") == key else {}
    if runs and (old.get("classifier") or {}).get("sha256") != judge["sha256"]:
        # another classifier (or one not recorded) judged them: kept beside this one's, they would not compare
        log_steps = ", ".join(str(s) for s in sorted(set(runs) - set(a.steps)))
        if log_steps:
            print(f"{display_path(out)}: its runs at {log_steps} step(s) were judged by another classifier; dropped "
                  f"(measure them again with this one: --steps)", file=sys.stderr)
        runs = {}
    result = {}
    for T in a.steps:
        src = ModelSource(opened=opened, steps=T, guidance=guidance, guidance_min_time=gmin, x0_smoothing=sigma, batch_size=a.batch,
                          threads=a.threads, device=a.device)
        runs[T] = bench.measure(src)
        info = {k: v for k, v in src.info.items() if k != "steps"}
        result = {"schema": SCHEMA, "task": "coverage", "name": a.name or a.model or display_path(a.ckpt),
                  "kind": "model", "condition": src.task, "info": info, "key": key, "default_steps": default_steps,
                  "labels": bench.labels, "real": bench.real, "thresholds": {"covered": COVERED, "chip": CHIP},
                  "dataset": dataset_info(Path(a.dataset), a.split), "hardware": hardware(),
                  "classifier": judge,
                  "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                  "runs": [runs[s] for s in sorted(runs)]}
        if src.task == "text" and default_steps in runs:
            result["chips"] = {"steps": default_steps, "threshold": CHIP, "prompts": chips(result, default_steps)}
        write_result(result, out)                # after every step count: an interrupted run keeps what it measured
    return out


def print_chips(a) -> int:
    out = a.out or default_out(a)
    r = read_result(out)
    if r is None:
        raise CoverageError(f"{out}: no coverage result; measure the model first (without --chips)")
    steps = r.get("default_steps", 10)
    ps = chips(r, steps)
    print(f"# prompts recognised in ≥ {CHIP:.0%} of their motions at {steps} steps ({display_path(out)}):")
    print("\n".join(ps) if ps else "# none")
    return 0


def build_parser() -> argparse.ArgumentParser:
    ints = lambda s: [int(x) for x in s.split(",") if x.strip()]  # noqa: E731
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.coverage", description=__doc__.split("\n\n")[0])
    add_model_source(ap)
    ap.add_argument("--name", default=None, help="result name (default: the model's; names the JSON file)")
    ap.add_argument("--steps", type=ints, default=[1, 2, 4, 10])
    ap.add_argument("--seeds", type=int, default=8, help="motions per prompt")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--guidance", type=float, default=None, help="default: the manifest's (2.5 for checkpoints)")
    add_sampling_settings(ap)
    ap.add_argument("--dataset", type=Path, default=DATASET_DIR)
    ap.add_argument("--split", default="test")
    add_judge_argument(ap)
    ap.add_argument("--prompts", type=Path, default=PROMPTS_FILE)
    ap.add_argument("--min-clips", type=int, default=MIN_CLIPS, help="fewer real test clips: listed apart")
    ap.add_argument("--batch", type=int, default=64, help="motions per batched sampling call")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--device", default="cpu", help="with --ckpt: cpu or cuda")
    ap.add_argument("--out", type=Path, default=None, help="default docs/results/json/coverage-<name>.json")
    ap.add_argument("--chips", action="store_true", help="print the prompts that pass the chip bar at the default "
                    "steps from the result file, and exit")
    return ap


def main(argv: list[str] | None = None) -> int:
    import torch

    a = build_parser().parse_args(argv)
    torch.set_num_threads(a.threads)
    try:
        if a.chips:
            return print_chips(a)
        print(f"wrote {run(a)}")
    except (CoverageError, DatasetError, FileNotFoundError, ModelError, OutputRefused) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
