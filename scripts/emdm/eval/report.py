"""docs/RESULTS.md from evaluation outputs — the one command that regenerates it:

    python -m emdm.eval.report                  # reads docs/results/json/*.json, writes docs/RESULTS.md + PNGs

Every number in the file comes from a JSON written by ``python -m emdm.eval.evaluate`` (or a timing
JSON of the same schema); nothing is typed by hand. Rows the seed's comparisons need but that have no
JSON yet are listed under "Not measured yet", so a missing baseline is visible, never silent.

Result JSON (schema 1), one file per (task, source):
    {"schema": 1, "task": "text"|"action", "name": row label, "kind": "real"|"model",
     "info": {"variant": "real"|"emdm"|"diffusion"|"ddgan-naive"|"ddgan-nodcond", "sampler": ...,
              "steps": T, ...}, "dataset": {...}, "hardware": str, "evaluator": {...},
     "metrics": {name: [one value per repeat]}, "plausibility": {name: [one value per motion]}, ...}
Timing JSON:
    {"schema": 1, "task": "timing", "runtime": "python-cpu"|"browser-wasm"|"gpu", "hardware": str,
     "rows": [{"variant": ..., "sampler": ..., "steps": T, "frames": F, "ms_per_motion": [runs]}]}
Coverage JSON (``python -m emdm.eval.coverage``), one file per model:
    {"schema": 1, "task": "coverage", "name": ..., "condition": "text"|"action", "labels": [...],
     "real": {"per_action": {label: {"n", "recognised", "rate"}}, "reference": [...], "too_few": {label: n}},
     "runs": [{"steps": T, "per_action": {...}, "macro_accuracy", "covered": [...], ...}], "chips": {...}}
Realism JSON (``python -m emdm.eval.realism``), one file per model and setting: {"schema": 1, "task": "realism",
     "name": ..., "labels": [...], "real": {"per_action", "all", "reference", "kinematic", "classifier"},
     "generated": {same, "n", "seconds"}, "rules": {action: {"rule", "own", "false_pass", ...}}, "judged": [...]}
Poses JSON (``python -m emdm.eval.poses``), one file per model: {"schema": 1, "task": "poses", "name": ...,
     "rows": [{"steps", "guidance", "seconds", "failed_motions", "motions", "impossible_share", ..., "ok"}]}
Editing JSON (``python -m emdm.eval.editing``), one file per model: {"schema": 1, "task": "editing", "name": ...,
     "seams", "semantics", "kept", "loops", "time", "bars": {bar: {"met", "figure"}}, ...}; its time bar alone on
     another runtime (``--time-only``): {"schema": 1, "task": "editing-time", "name": ..., "runtime", "hardware",
     "steps", "time": {"by_threads": {n: {"ratio", "timeline_s", "single_s", ...}}, "threads_are"}, "bars": {"time"}}
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

from emdm.eval.coverage import COVERED
from emdm.eval.metrics import mean_ci95
from emdm.paths import REPO_ROOT

RESULTS_DIR = REPO_ROOT / "docs" / "results"
RESULTS_MD = REPO_ROOT / "docs" / "RESULTS.md"
SCHEMA = 1

VARIANT_LABEL = {
    "real": "Real motion",
    "emdm": "EMDM (DDGAN + L_geo, D conditioned)",
    "diffusion": "Diffusion (same transformer) + DDIM",
    "ddgan-naive": "Naive DDGAN (R = 0, D unconditioned)",
    "ddgan-nodcond": "DDGAN + L_geo, D unconditioned",
}
VARIANT_ORDER = ["real", "emdm", "diffusion", "ddgan-naive", "ddgan-nodcond"]

# The rows the seed's comparisons need: (task, variant, steps or None for "any"), and the table they feed.
EXPECTED = [
    ("text", "real", None, "Tab. D2–D4 reference row"),
    ("text", "emdm", 10, "Tab. D2–D4: EMDM at 10 steps"),
    ("text", "diffusion", 10, "Tab. D2: diffusion + DDIM at 10 steps"),
    ("text", "diffusion", 50, "Tab. D2: diffusion + DDIM at 50 steps"),
    ("text", "diffusion", 100, "Tab. D2: diffusion + DDIM at 100 steps"),
    ("text", "ddgan-naive", 10, "Tab. D3: naive DDGAN"),
    ("text", "ddgan-nodcond", 10, "Tab. D4: D without condition (with L_geo)"),
    ("action", "real", None, "action-to-motion reference row"),
    ("action", "emdm", 10, "action-to-motion: EMDM at 10 steps"),
]
EXPECTED_TIMING = [("python-cpu", "emdm"), ("python-cpu", "diffusion"), ("browser-wasm", "emdm"),
                   ("browser-wasm", "diffusion"), ("python-cuda", "emdm"), ("python-cuda", "diffusion")]


class ReportError(ValueError):
    pass


# ----------------------------------------------------------------------------- loading

def load_results(json_dir: Path | str) -> list[dict]:
    json_dir = Path(json_dir)
    out = []
    for path in sorted(json_dir.glob("*.json")):
        if path.name.startswith("models-"):     # docs/MODELS.md's inputs (emdm.eval.models_report)
            continue
        try:
            r = json.loads(path.read_text())
        except json.JSONDecodeError as e:
            raise ReportError(f"{path}:{e.lineno}: not valid JSON: {e.msg}") from e
        if r.get("schema") != SCHEMA:
            raise ReportError(f"{path}: field 'schema' is {r.get('schema')!r}, expected {SCHEMA}")
        task = r.get("task")
        if task not in ("text", "action", "timing", "coverage", "editing", "editing-time", "poses", "realism", "seams"):
            raise ReportError(f"{path}: field 'task' is {task!r}, expected 'text', 'action', 'timing', 'coverage', "
                              f"'editing', 'editing-time', 'poses', 'realism' or 'seams'")
        need = {"timing": ("rows", "runtime"), "coverage": ("name", "labels", "real", "runs"), "poses": ("name", "rows"),
                "realism": ("name", "labels", "real", "generated", "rules", "judged"),
                "editing": ("name", "seams", "semantics", "kept", "loops", "time", "bars"),
                "editing-time": ("name", "runtime", "hardware", "steps", "time", "bars"),
                "seams": ("name", "figures", "rows", "bars")}.get(
            task, ("name", "kind", "info", "metrics"))
        for k in need:
            if k not in r:
                raise ReportError(f"{path}: missing field {k!r}")
        r["_file"] = path.name
        out.append(r)
    return out


# ----------------------------------------------------------------------------- formatting

def fmt(values, digits: int = 3) -> str:
    """'mean ±ci' over repeats (ci = 95 % half-interval); '–' when there are no values."""
    if values is None or len(values) == 0:
        return "–"
    m, h = mean_ci95(values)
    return f"{m:.{digits}f} ±{h:.{digits}f}" if len(values) > 1 else f"{m:.{digits}f}"


def _steps(r: dict):
    return r["info"].get("steps")


def _sort_key(r: dict):
    v = r["info"].get("variant", "real" if r["kind"] == "real" else "emdm")
    return (VARIANT_ORDER.index(v) if v in VARIANT_ORDER else 99, _steps(r) or 0, r["name"])


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _method_cells(r: dict) -> list[str]:
    info = r["info"]
    steps = _steps(r)
    return [r["name"], "–" if steps is None else str(steps), str(r.get("n", "–")), str(info.get("train_steps", "–"))]


def text_table(results: list[dict]) -> str:
    rows = []
    for r in sorted((r for r in results if r["task"] == "text"), key=_sort_key):
        m = r["metrics"]
        rows.append(_method_cells(r) + [fmt(m.get("top1")), fmt(m.get("top2")), fmt(m.get("top3")),
                                         fmt(m.get("fid")), fmt(m.get("mm_dist")), fmt(m.get("diversity")),
                                         fmt(m.get("multimodality")), str(r.get("repeats", len(m.get("top1", []))))])
    return _table(["Method", "Steps", "Clips", "Train steps", "R-prec top-1 ↑", "top-2 ↑", "top-3 ↑", "FID ↓",
                   "MM-Dist ↓", "Diversity →", "MModality ↑", "Repeats"], rows)


def action_table(results: list[dict]) -> str:
    rows = []
    for r in sorted((r for r in results if r["task"] == "action"), key=_sort_key):
        m = r["metrics"]
        rows.append(_method_cells(r) + [fmt(m.get("accuracy")), fmt(m.get("fid")), fmt(m.get("diversity")),
                                         fmt(m.get("multimodality")), str(r.get("repeats", len(m.get("accuracy", []))))])
    return _table(["Method", "Steps", "Clips", "Train steps", "Accuracy ↑", "FID ↓", "Diversity →", "Multimodality →",
                   "Repeats"], rows)


def plausibility_table(results: list[dict]) -> str:
    rows, seen = [], set()
    for r in sorted((r for r in results if r["task"] in ("text", "action") and r.get("plausibility")),
                    key=lambda r: (r["task"] != "text", _sort_key(r))):
        p = r["plausibility"]
        key = (r["name"], json.dumps(p, sort_keys=True))
        if key in seen:                 # e.g. the real clips measured by both the text and action runs
            continue
        seen.add(key)
        n = len(p.get("penetration_mm", []))
        rows.append([r["name"], r["task"], "–" if _steps(r) is None else str(_steps(r)), str(n),
                     fmt(p.get("penetration_mm"), 1), fmt(p.get("floating_mm"), 1), fmt(p.get("skate_cm_s"), 1),
                     fmt(p.get("skate_ratio"), 3), fmt(p.get("phys_err_mm"), 1)])
    return _table(["Method", "Task", "Steps", "Motions", "Penetrate (mm) ↓", "Float (mm) ↓", "Skate (cm/s) ↓",
                   "Skate ratio ↓", "Phys-Err (mm) ↓"], rows)


def timing_rows(results: list[dict]) -> list[dict]:
    """Flattened timing rows with runtime/hardware, ms per motion and per frame (means over runs)."""
    flat = []
    for r in results:
        if r["task"] != "timing":
            continue
        for i, row in enumerate(r["rows"]):
            for k in ("variant", "steps", "frames", "ms_per_motion"):
                if k not in row:
                    raise ReportError(f"{r['_file']}: rows[{i}] misses field {k!r}")
            ms = float(np.mean(row["ms_per_motion"]))
            hw = r.get("hardware", "?")
            if r.get("load_avg_1min"):
                hw += f"; load avg {r['load_avg_1min'][0]:.1f}→{r['load_avg_1min'][1]:.1f}"
            flat.append({**row, "runtime": r["runtime"], "hardware": hw,
                         "ms": ms, "ms_per_frame": ms / row["frames"],
                         "runs": row.get("reps") or len(row["ms_per_motion"])})
    return flat


def timing_table(results: list[dict]) -> tuple[str, list[str]]:
    """The table and the headline ratios (diffusion time / EMDM time per frame, same runtime and
    thread count; the EMDM reference is its 10-step row, else its first)."""
    flat = timing_rows(results)
    rows, ratios = [], []
    order = lambda f: (VARIANT_ORDER.index(f["variant"]) if f["variant"] in VARIANT_ORDER else 99, f["steps"])  # noqa: E731
    for runtime, threads in sorted({(f["runtime"], f.get("threads", 1)) for f in flat}):
        group = sorted((f for f in flat if f["runtime"] == runtime and f.get("threads", 1) == threads), key=order)
        emdm = {f["steps"]: f for f in group if f["variant"] == "emdm"}
        ref = emdm.get(10) or (next(iter(emdm.values())) if emdm else None)
        for f in group:
            ratio = f"{f['ms_per_frame'] / ref['ms_per_frame']:.2f}×" if ref else "–"
            rows.append([runtime, VARIANT_LABEL.get(f["variant"], f["variant"]), str(f["steps"]), str(threads),
                         str(f["frames"]), f"{f['ms']:.1f}", f"{f['ms_per_frame']:.3f}", ratio, str(f["runs"]),
                         f["hardware"]])
            if ref and f["variant"] == "diffusion":
                ratios.append(f"{runtime}, {threads} thread(s): diffusion + DDIM at {f['steps']} steps takes "
                              f"{f['ms_per_frame'] / ref['ms_per_frame']:.1f}× the time per frame of EMDM at "
                              f"{ref['steps']} steps ({f['ms_per_frame']:.3f} vs {ref['ms_per_frame']:.3f} ms).")
    table = _table(["Runtime", "Method", "Steps", "Threads", "Frames", "ms / motion", "ms / frame", "× EMDM", "Runs",
                    "Hardware"], rows)
    return table, ratios


def _rate(v: dict | None) -> str:
    return "–" if not v or v.get("rate") is None else f"{v['rate']:.2f}"


def coverage_section(r: dict, plot: str | None) -> list[str]:
    """One model's coverage: action × steps recognition rates next to the real row, summary rows, the
    actions with too few test clips, the chip candidates and the bar plot."""
    real, runs = r["real"], sorted(r["runs"], key=lambda x: x["steps"])
    ref, few = set(real["reference"]), real.get("too_few", {})
    cond = "its plain label prompt and paraphrases (`scripts/emdm/eval/prompts.json`)" if r.get("condition") == "text" \
        else "its one-hot label"
    seeds = r.get("key", {}).get("seeds", "?")
    key = r.get("key", {})
    interval = f" at t > {key['guidance_min_time']:g}" if key.get("guidance_min_time") else ""
    interval += f", x̂0 smoothed along time (σ {key['x0_smoothing']:g} frames)" if key.get("x0_smoothing") else ""
    out = [f"### {r['name']} ({r.get('condition', '?')} model, guidance {key.get('guidance', '?')}{interval})", "",
           f"Each action asked for with {cond}, {seeds} motions per prompt, lengths drawn from the action's real test "
           f"clips; a cell is the share of its motions the classifier names as that action. *Ref.* marks the "
           f"reference set (real clips recognised ≥ {COVERED:.0%}); actions with fewer than "
           f"{real.get('min_clips', 3)} real test clips are marked *few* and listed below.", ""]
    header = ["Action", "Ref.", "Real (clips)"] + [f"{x['steps']} step{'s' if x['steps'] > 1 else ''}" for x in runs]
    rows = []
    for a in r["labels"]:
        rv = real["per_action"][a]
        mark = "✓" if a in ref else ("few" if a in few else "")
        rows.append([a, mark, f"{_rate(rv)} ({rv['n']})"] + [_rate(x["per_action"].get(a)) for x in runs])
    macro = lambda v: "–" if v is None else f"{v:.3f}"  # noqa: E731
    rows.append(["**macro accuracy**", "", macro(real.get("macro_accuracy"))] + [macro(x["macro_accuracy"]) for x in runs])
    rows.append(["**macro, reference set**", "", "–"] + [macro(x.get("macro_reference")) for x in runs])
    rows.append(["**covered (≥ 50 %)**", "", f"{len(ref)}/{len(r['labels']) - len(few)}"] +
                [f"{len(x['covered'])}/{len(r['labels'])}" for x in runs])
    rows.append(["**covered of the reference set**", "", f"{len(ref)}/{len(ref)}"] +
                [f"{len(x['covered_reference'])}/{x['reference_size']}" for x in runs])
    if all("flip_share" in x for x in runs) and "flip_share" in real:
        rows.append(["**frames with a one-frame flip** (a joint > 10 cm out and back)", "", f"{real['flip_share']:.2%}"] +
                    [f"{x['flip_share']:.1%}" for x in runs])
    out += [_table(header, rows), ""]
    if few:
        out += ["Too few real test clips to judge the classifier on (listed, not dropped; their generated rates are "
                "in the table): " + ", ".join(f"{a} ({n})" for a, n in few.items()) + ".", ""]
    missed = [a for a in real["reference"] if runs and a not in runs[-1]["covered_reference"]]
    if runs and missed:
        out += [f"Reference actions not covered at {runs[-1]['steps']} steps: " + ", ".join(missed) + ".", ""]
    if r.get("chips"):
        c = r["chips"]
        out += [f"Prompts recognised in ≥ {c['threshold']:.0%} of their motions at {c['steps']} steps (the page's "
                f"example chips come from these): " + (", ".join(f"\"{p}\"" for p in c["prompts"]) or "none") + ".", ""]
    secs = ", ".join(f"{x['steps']} step{'s' if x['steps'] > 1 else ''} {x['seconds'] / 60:.1f} min ({x['motions']} motions, load average {x.get('load_avg_1min_end', 0):.0f} at the end)" for x in runs)
    out += [f"Measured on {r.get('hardware', '?')}; {secs}. Classifier: {r.get('classifier', {}).get('summary', '?')}.", ""]
    if plot:
        out += [f"![coverage of {r['name']}]({plot})", ""]
    return out


# ----------------------------------------------------------------------------- plots

def plot_coverage(r: dict, path: Path) -> bool:
    """Horizontal grouped bars: per action, the real clips' and each step count's recognition rate."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels, runs = r["labels"], sorted(r["runs"], key=lambda x: x["steps"])
    series = [("real test clips", [r["real"]["per_action"][a]["rate"] for a in labels], "0.6")]
    series += [(f"{x['steps']} step{'s' if x['steps'] > 1 else ''}", [x["per_action"][a]["rate"] for a in labels], None)
               for x in runs]
    h = 0.8 / len(series)
    y = np.arange(len(labels))
    fig, ax = plt.subplots(figsize=(7.5, 0.32 * len(labels) + 1.2), dpi=100)
    for k, (name, vals, color) in enumerate(series):
        ax.barh(y + (k - (len(series) - 1) / 2) * h, [np.nan if v is None else v for v in vals], h,
                label=name, color=color)
    ax.axvline(COVERED, color="k", lw=0.8, ls="--")
    ax.set_yticks(y, [a + (" *" if a in r["real"].get("too_few", {}) else "") for a in labels], fontsize=7)
    ax.set_ylim(len(labels) - 0.5, -0.5)                 # first action on top, no empty margin
    ax.set_xlim(0, 1)
    ax.set_xlabel("share of motions the classifier names as the action (dashed: covered)")
    fig.suptitle(f"Coverage per action: {r['name']} (* = too few real test clips)", fontsize=9)
    ax.legend(fontsize=7, loc="lower left", bbox_to_anchor=(0.0, 1.0), ncol=len(series), frameon=False)
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return True


def _step_axis(ax, steps) -> None:
    """Log-scaled x axis labelled with the step counts themselves (1, 2, 10, 100), not powers of ten."""
    from matplotlib.ticker import FixedLocator, NullFormatter, ScalarFormatter

    ax.set_xscale("log")
    ax.xaxis.set_major_locator(FixedLocator(sorted(set(steps))))
    ax.xaxis.set_major_formatter(ScalarFormatter())
    ax.xaxis.set_minor_formatter(NullFormatter())


def plot_fid_vs_steps(results: list[dict], path: Path) -> bool:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    # one series per (variant, number of clips): FID is biased by the sample size, so rows measured on a
    # subset are drawn apart, each with the real-vs-real floor of its own clip count
    series: dict[tuple[str, int], list[tuple[int, float, float]]] = {}
    reals: dict[int, float] = {}
    for r in results:
        if r["task"] != "text" or "fid" not in r["metrics"]:
            continue
        m, h = mean_ci95(r["metrics"]["fid"])
        if r["kind"] == "real":
            reals[r.get("n", 0)] = m
        elif _steps(r) is not None:
            key = (r["info"].get("variant"), r.get("n", 0), r["info"].get("train_steps"))
            series.setdefault(key, []).append((_steps(r), m, h))
    if not series:
        return False
    several = len({k[1] for k in series}) > 1
    trained = {}                                   # variant -> its train-step counts
    for v, _, t in series:
        trained.setdefault(v, set()).add(t)
    fig, ax = plt.subplots(figsize=(9.6, 4.2), dpi=120)
    for (v, n, t), pts in sorted(series.items(), key=lambda kv: (-kv[0][1], kv[0][0], kv[0][2] or 0)):
        pts.sort()
        label = (VARIANT_LABEL.get(v, v) + (f", {t} train steps" if len(trained[v]) > 1 else "")
                 + (f", {n} clips" if several else ""))
        ax.errorbar([p[0] for p in pts], [p[1] for p in pts], yerr=[p[2] for p in pts], marker="o", capsize=3,
                    ls="-" if n == max(k[1] for k in series) else ":", label=label)
    for n in sorted({k[1] for k in series}, reverse=True):
        if n in reals:
            ax.axhline(reals[n], color="gray", ls="--" if n == max(reals) else ":",
                       label="real vs real" + (f", {n} clips" if several else ""))
    _step_axis(ax, [p[0] for pts in series.values() for p in pts])
    ax.set_xlabel("sampling steps")
    ax.set_ylabel("FID (matcher features) ↓")
    ax.set_title("Text-to-motion FID vs steps (test split, ±95%)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))        # outside: never over a point
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return True


def plot_time_vs_steps(results: list[dict], path: Path) -> bool:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    flat = timing_rows(results)
    if not flat:
        return False
    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    for key in sorted({(f["runtime"], f.get("threads", 1), f["variant"]) for f in flat}):
        pts = sorted((f["steps"], f["ms_per_frame"]) for f in flat
                     if (f["runtime"], f.get("threads", 1), f["variant"]) == key)
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o",
                label=f"{key[0]} ({key[1]} thr): {VARIANT_LABEL.get(key[2], key[2])}")
    _step_axis(ax, [f["steps"] for f in flat])
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0)))
    ax.yaxis.set_major_formatter(ScalarFormatter())
    ax.yaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("sampling steps")
    ax.set_ylabel("time per frame (ms)")
    ax.set_title("Generation time per frame vs steps")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return True


# ----------------------------------------------------------------------------- document

def missing(results: list[dict]) -> list[str]:
    have = {(r["task"], r["info"].get("variant", "real" if r["kind"] == "real" else "emdm"), _steps(r))
            for r in results if r["task"] in ("text", "action")}
    out = []
    for task, variant, steps, why in EXPECTED:
        ok = any(t == task and v == variant and (steps is None or s == steps) for t, v, s in have)
        if not ok:
            out.append(f"{why} ({task}, {VARIANT_LABEL[variant]}{'' if steps is None else f', {steps} steps'})")
    runtimes = {(f["runtime"], f["variant"]) for f in timing_rows(results)}
    for runtime, variant in EXPECTED_TIMING:
        if (runtime, variant) not in runtimes:
            out.append(f"timing: {VARIANT_LABEL[variant]} on {runtime}")
    if not any(r.get("plausibility") for r in results if r["task"] in ("text", "action") and r["kind"] == "real"):
        out.append("Tab. D5: plausibility of real data")
    if not any(r.get("plausibility") for r in results if r["task"] in ("text", "action") and r["kind"] != "real"):
        out.append("Tab. D5: plausibility of generated motions")
    return out


def clips_per_row(rows: list[dict]) -> str:
    """Which rows used how many test clips, e.g. '892 (Real motion, EMDM (10 steps)); 128 (Real motion, ...)',
    largest count first: rows measured on a subset are compared with the real row of the same count."""
    by_n: dict = {}
    for r in sorted(rows, key=_sort_key):
        names = by_n.setdefault(r.get("n", "?"), [])
        if r["name"] not in names:
            names.append(r["name"])
    order = sorted(by_n, key=lambda n: -n if isinstance(n, int) else 0)
    return "; ".join(f"{n} ({', '.join(by_n[n])})" for n in order)


def _describe(results: list[dict]) -> list[str]:
    lines = []
    seen = set()
    for r in sorted(results, key=lambda r: r["task"] != "text"):
        if r["task"] not in ("text", "action"):
            continue
        d = r.get("dataset", {})
        key = (r["task"], json.dumps(d, sort_keys=True))
        if key in seen:
            continue
        seen.add(key)
        same = [q for q in results if q["task"] == r["task"] and json.dumps(q.get("dataset", {}), sort_keys=True) == key[1]]
        lines.append(f"- {r['task']}: dataset `{d.get('name', '?')}` ({d.get('description', '')}), split "
                     f"`{d.get('split', '?')}`, clips evaluated (≥ 40 frames): {clips_per_row(same)}; evaluator: "
                     f"{r.get('evaluator', {}).get('summary', '?')}")
    hw = sorted({r.get("hardware", "?") for r in results if r["task"] != "coverage"})
    if hw:
        lines.append("- hardware: " + "; ".join(hw))
    return lines


def models_table(results: list[dict]) -> str:
    rows, seen = [], set()
    for r in sorted((r for r in results if r["task"] in ("text", "action") and r["kind"] != "real"),
                    key=lambda r: (r["task"], _sort_key(r))):
        i = r["info"]
        where = i.get("checkpoint") or i.get("model") or "?"
        key = (r["task"], where)
        if key in seen:
            continue
        seen.add(key)
        rows.append([r["task"], VARIANT_LABEL.get(i.get("variant"), str(i.get("variant"))), f"`{where}`",
                     str(i.get("train_steps", "–")), str(i.get("train_wall_min", "–")), str(i.get("device", "–")),
                     "continued" if "cont" in Path(str(where)).stem else ""])
    if not rows:
        return ""
    return _table(["Task", "Variant", "Weights", "Train steps", "Train wall (min)", "Device", ""], rows)


def headlines(results: list[dict]) -> list[str]:
    """One line per model row: its key metrics next to the real row measured on the same clips."""
    out = []
    keys = {"text": [("top1", "R-precision top-1"), ("fid", "FID"), ("mm_dist", "MM-Dist")],
            "action": [("accuracy", "accuracy"), ("fid", "FID"), ("diversity", "diversity")]}
    for r in sorted((r for r in results if r["task"] in keys and r["kind"] != "real"), key=lambda r: (r["task"], _sort_key(r))):
        real = next((q for q in results if q["task"] == r["task"] and q["kind"] == "real" and q.get("n") == r.get("n")), None)
        if real is None:
            continue
        parts = [f"{label} {np.mean(r['metrics'][k]):.3f} (real {np.mean(real['metrics'][k]):.3f})"
                 for k, label in keys[r["task"]] if k in r["metrics"] and k in real["metrics"]]
        out.append(f"{r['task']}, {r['name']}, {r.get('n')} clips × {r.get('repeats')} repeat(s): " + ", ".join(parts))
    return out


def render(results: list[dict], plots: dict[str, str]) -> str:
    out = ["# Results", "",
           "<!-- generated by `python -m emdm.eval.report` from docs/results/json/*.json; do not edit by hand -->", "",
           "Every number below was measured in this repository by `python -m emdm.eval.evaluate` (JSON files in "
           "`docs/results/json/`). Values are mean ±95 % half-interval (1.96·σ/√n) over the repeats listed; "
           "plausibility intervals are over motions.", "", "## Setup", ""]
    out += _describe(results) or ["- no evaluation results yet"]
    out += ["", "Metrics follow Guo et al. (text: R-precision with 1 true motion + 31 distractors, FID on the "
            "motion encoder's features, MM-Dist, Diversity over 300 pairs, MultiModality over 10 pairs of "
            "generations per caption) and ACTOR (action: classifier accuracy, FID on its penultimate features, "
            "Diversity over 200 pairs, Multimodality over 20 pairs per label). The evaluators are our own, "
            "trained on this dataset's train split (`python -m emdm.eval.evaluators`), so the numbers are not "
            "comparable with the paper's HumanML3D/HumanAct12 figures, only with each other. Embeddings are "
            "L2-normalised, so FID and distances are on the unit sphere. The real row's FID is between two "
            "random halves of the test split (the estimator's noise floor; with few clips and 128-d features "
            "it is strongly biased upwards, so compare a model's FID with the real row of the same clip "
            "count). Rows with one repeat carry no interval. The \"Train steps\" column says how long each "
            "generator was trained: read every model row in that light.", ""]
    models = models_table(results)
    if models:
        out += ["## Models evaluated", "", "Each generator row's training (from its checkpoint): the comparisons "
                "(EMDM vs its baselines) use models trained side by side on one GPU for the same wall-clock "
                "budget (`scripts/gpu/train-all.sh`); rows marked *continued* were trained further from those "
                "weights (the models shipped before L_bone). The models shipped now were trained further still, "
                "with the rigidity term L_bone: docs/MODELS.md describes them and compares them with these.",
                "", models, ""]
    heads = headlines(results)
    if heads:
        out += ["## Headline", "", "Each model row against the real row measured on the same test clips "
                "(for FID: the real-vs-real noise floor of that many clips):", ""] + [f"- {h}" for h in heads] + [""]
    out += ["## Text-to-motion (the seed's Tab. D2–D4 comparisons)", ""]
    out += [text_table(results) if any(r["task"] == "text" for r in results) else "_no text-to-motion results yet_", ""]
    if "fid" in plots:
        out += [f"![FID vs steps]({plots['fid']})", ""]
    out += ["## Action-to-motion (ACTOR protocol)", ""]
    out += [action_table(results) if any(r["task"] == "action" for r in results) else "_no action-to-motion results yet_", ""]
    cov = sorted((r for r in results if r["task"] == "coverage"), key=lambda r: (r.get("condition") != "text", r["name"]))
    if cov:
        out += ["## Coverage per action (issue 12)", "",
                "Does every action of the dataset come out of its prompt? `python -m emdm.eval.coverage` asks each "
                "model for every action of the vocabulary and lets the action classifier (the evaluator above) "
                "name each motion. An action is *covered* when at least half its motions are recognised.", ""]
        for r in cov:
            out += coverage_section(r, plots.get("coverage:" + r["_file"]))
    real = sorted((r for r in results if r["task"] == "realism"), key=lambda r: r["name"])
    if real:
        from emdm.eval import realism

        out += ["## Realism per action: speed, jitter, ground, and a second judge of meaning (issue 28)", "",
                "`python -m emdm.eval.realism` generates the coverage benchmark's motions and sets each action's against "
                "its real test clips: root speed, per-frame joint steps, airborne frames, and a kinematic rule per action "
                "(independent of the classifier) beside the classifier's verdict.", ""]
        out += realism.comparison(real) if len(real) > 1 else []
        for r in real:
            out += realism.section(r, plots.get("realism:" + r["_file"]))
        out += realism.rules_section(real[-1])
    edits = [r for r in results if r["task"] == "editing"]
    if edits:
        from emdm.eval.editing import section as editing_section, time_section

        out += ["## Beyond one prompt: timelines, in-betweening, body-part edits, loops (issue 14)", "",
                "`python -m emdm.eval.editing` makes 3-segment timelines, in-betweens, body-part edits and loops with "
                "`emdm.motion.edit` (the algorithms the page runs, parity-tested against `src/edit.ts`) and measures "
                "them against the issue's bars.", ""]
        for r in sorted(edits, key=lambda r: (r["name"], r.get("seed", 0))):
            out += editing_section(r)
        out += time_section([r for r in results if r["task"] == "editing-time"])
    seams = [r for r in results if r["task"] == "seams"]
    if seams:
        from emdm.eval.seams import section as seams_section

        out += ["## Seams and loops (issue 33)", "",
                "`python -m emdm.eval.seams` makes timelines (walk → wave both hands → bow over 8 seeds, and 50 prompt "
                "changes drawn from the coverage prompts) and loops of \"a person walks\" (8 seeds, travelling and in "
                "place) with `emdm.motion.edit` on the page's emdm-t2m-web file, decoded as the page shows them "
                "(`emdm.motion.decode`), and sets each seam's joint acceleration and joint step against the 95th "
                "percentile elsewhere in its timeline, and each loop's wrap against its largest in-loop step. "
                "`-before`: the code before the loop decode (`decode_joints(loop=True)`) and the seam velocity "
                "(`SEAM_BLEND_VELOCITY`) fixes. A loop re-generates all but its ends, so its gait against the plain "
                "walk varies with the seed either way; in place keeps the gait of the same loop travelling.", ""]
        out += seams_section(seams)
    grids = sorted((r for r in results if r["task"] == "poses"), key=lambda r: r["name"])
    if grids:
        from emdm.eval.poses import BONE_TOL, FLOOR_TOL, LEG_TOL, section as poses_section

        out += ["## Impossible poses over the page's settings (issue 12)", "",
                "`python -m emdm.eval.poses` samples every step count × guidance (1, 2.5, 6: the page's slider range) × "
                "length (2, 6, 9.8 s) and flags a frame as impossible when a bone is more than "
                f"{BONE_TOL:.0%} off its reference length, a hip–ankle distance exceeds {LEG_TOL:g}× the straight leg, or "
                f"a joint is more than {FLOOR_TOL * 100:.0f} cm under the floor (real clips: none of the three).", ""]
        for r in grids:
            out += poses_section(r)
    out += ["## Physical plausibility (the seed's Tab. D5)", "",
            "Penetration: depth of the lowest joint below the floor; Float: height of the lowest joint beyond "
            "5 cm above it; Skate: horizontal speed of a toe joint while below 5 cm in two consecutive frames; "
            "Skate ratio: frames with a contact foot sliding faster than 0.5 m/s; Phys-Err: penetration + float + "
            "skate displacement per frame (mm), as PhysDiff sums them. Joints from the 263-d features' "
            "`recover_joints`, 20 fps (`emdm/eval/plausibility.py`).", ""]
    has_p = any(r.get("plausibility") for r in results if r["task"] in ("text", "action"))
    out += [plausibility_table(results) if has_p else "_no plausibility results yet_", ""]
    out += ["## Running time", ""]
    table, ratios = timing_table(results)
    if timing_rows(results):
        out += [table, ""]
        if ratios:
            out += ["Headline ratios:", ""] + [f"- {r}" for r in ratios] + [""]
        if "time" in plots:
            out += [f"![time per frame vs steps]({plots['time']})", ""]
    else:
        out += ["_no timing results yet_", ""]
    miss = missing(results)
    out += ["## Not measured yet", ""]
    out += ([f"- {m}" for m in miss] if miss else ["- nothing: every row of the seed's comparisons is measured"]) + [""]
    out += ["## Regenerate", "",
            "The baselines are trained with the project's training code and flags (same backbone, data and "
            "budget as the EMDM run they are compared with), then the suite measures every row. On a GPU "
            "machine, the recipe of the shipped models and of these tables (five generators side by side "
            "within one wall-clock budget, then every row in parallel):", "", "```",
            "python -m emdm.data.pack data/dataset dataset.tar.xz       # 32 MB: the dataset, to carry there",
            "scripts/gpu/train-all.sh dataset.tar.xz runs/gpu 8          # t2m, a2m, t2m-ddim, t2m-naive, t2m-nodcond",
            "scripts/gpu/eval-all.sh runs/dataset runs/gpu 20            # needs runs/gpu/eval/{matcher,classifier}.pt",
            "```", "", "or, step by step (any machine):", "", "```",
            "python -m emdm.eval.evaluators matcher       # the evaluators (once; runs/eval/*.pt)",
            "python -m emdm.eval.evaluators classifier",
            "python -m emdm.train --task text --objective diffusion --out runs/t2m-diffusion   # Tab. D2 baseline",
            "python -m emdm.train --task text --geo-weight 0 --no-d-cond --out runs/t2m-naive  # Tab. D3",
            "python -m emdm.train --task text --no-d-cond --out runs/t2m-nodcond                # Tab. D4",
            "python -m emdm.eval.suite --text runs/t2m-web/ckpt.pt --action runs/a2m-web/ckpt.pt \\",
            "    --diffusion runs/t2m-diffusion/ckpt.pt --naive runs/t2m-naive/ckpt.pt --nodcond runs/t2m-nodcond/ckpt.pt",
            "python -m emdm.eval.coverage --model emdm-t2m-web   # coverage per action, 1/2/4/10 steps (--seeds, default 8)",
            "python -m emdm.eval.coverage --model emdm-a2m-web",
            "python -m emdm.eval.realism --model emdm-t2m-web --variant int8 --name emdm-t2m-web-int8-pose1   # realism per action at the page's settings (issue 28)",
            "python -m emdm.eval.realism --model emdm-t2m-web --variant int8 --x0-smoothing 0 --name emdm-t2m-web-int8-pose0   # ... plain sampling (2: pose2)",
            "python -m emdm.eval.realism --model emdm-t2m-web --variant int8 --x0-smoothing 0 --decode raw --name emdm-t2m-web-int8-x0s0-raw   # ... the model's own joints",
            "python -m emdm.eval.realism --model emdm-a2m-web --variant int8 --name emdm-a2m-web-int8-pose0   # the action model (--x0-smoothing 2: pose2; --decode raw: raw)",
            "python -m emdm.eval.realism --model diffusion-t2m-web --steps 10 --name diffusion-t2m-web-10   # the DDIM baseline",
            "python -m emdm.eval.kinematics              # the kinematic rules' pass rates on the real train and test clips",
            "python -m emdm.eval.editing --model emdm-t2m-web   # timelines, in-betweens, body-part edits, loops (issue 14)",
            "python -m emdm.eval.editing --time-only --ckpt public/models/emdm-t2m-web.weights.f16.pt   # its time bar on PyTorch",
            "scripts/gpu/editing-time.sh runs/editing-time       # ... on a GPU machine (PyTorch CUDA, and ORT on its cores)",
            "node scripts/bench/timeline-bench.mjs              # issue 14's time bar on the library's WASM runtime (printed)",
            "EMDM_BENCH=1 npx playwright test tests/e2e/page-bench.spec.ts -g \"timeline against\"   # ... and in the page",
            "python -m emdm.eval.editing --import-page test-results/<that test>/timeline-time.json   # ... as a RESULTS row",
            "node scripts/bench/core-bench.mjs --json bench.json && python -m emdm.eval.evaluate import-bench bench.json",
            "# browser-wasm, issue 7: EMDM at 1/2/4/5/8/10 and diffusion + DDIM at 10/50/100 steps in one run of the demo",
            "# page (window.emdm.generate, needs diffusion-t2m-web in public/models); replaces the browser-wasm rows above",
            "EMDM_BENCH=1 EMDM_BENCH_JSON=bench-page.json npx playwright test tests/e2e/page-bench.spec.ts -g \"EMDM vs DDIM\"",
            "python -m emdm.eval.evaluate import-bench bench-page.json",
            "python -m emdm.eval.report                   # this file + docs/results/*.png from docs/results/json/",
            "```", "",
            "(add the EMDM run's other training flags to each baseline command so that only the named flag differs)", ""]
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m emdm.eval.report", description="regenerate docs/RESULTS.md")
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="folder with json/ (and where PNGs go)")
    ap.add_argument("--out", type=Path, default=RESULTS_MD)
    a = ap.parse_args(argv)
    results = load_results(a.results / "json")
    plots = {}
    rel = lambda p: os.path.relpath(p, a.out.parent.resolve())  # noqa: E731 - links relative to the .md
    if plot_fid_vs_steps(results, a.results / "fid_vs_steps.png"):
        plots["fid"] = rel((a.results / "fid_vs_steps.png").resolve())
    if plot_time_vs_steps(results, a.results / "time_vs_steps.png"):
        plots["time"] = rel((a.results / "time_vs_steps.png").resolve())
    for r in results:
        if r["task"] == "realism":
            from emdm.eval.realism import plot as plot_realism

            png = a.results / (Path(r["_file"]).stem + ".png")
            if plot_realism(r, png):
                plots["realism:" + r["_file"]] = rel(png.resolve())
        if r["task"] == "coverage":
            png = a.results / (Path(r["_file"]).stem + ".png")
            if plot_coverage(r, png):
                plots["coverage:" + r["_file"]] = rel(png.resolve())
    text = render(results, plots)
    a.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = a.out.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(a.out)
    print(f"wrote {a.out} from {len(results)} result files; {len(missing(results))} rows not measured yet")
    return 0


if __name__ == "__main__":
    sys.exit(main())
