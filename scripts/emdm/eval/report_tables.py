"""RESULTS.md's tables from the result JSONs (:mod:`emdm.eval.report` loads them and lays out the document):
quality (text, action, plausibility), running time, coverage per action and the models evaluated.

    text_table(results)              # Markdown: one row per text-to-motion result, mean ±95 % half-interval
    table, ratios = timing_table(results)
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from emdm.eval import markdown as md
from emdm.eval.coverage import COVERED
from emdm.eval.metrics import mean_ci95

VARIANT_LABEL = {
    "real": "Real motion",
    "emdm": "EMDM (DDGAN + L_geo, D conditioned)",
    "diffusion": "Diffusion (same transformer) + DDIM",
    "ddgan-naive": "Naive DDGAN (R = 0, D unconditioned)",
    "ddgan-nodcond": "DDGAN + L_geo, D unconditioned",
}
VARIANT_ORDER = ["real", "emdm", "diffusion", "ddgan-naive", "ddgan-nodcond"]


class ReportError(ValueError):
    pass



# ----------------------------------------------------------------------------- formatting

def fmt(values, digits: int = 3) -> str:
    """'mean ±ci' over repeats (ci = 95 % half-interval); '–' when there are no values."""
    if values is None or len(values) == 0:
        return "–"
    m, h = mean_ci95(values)
    return f"{m:.{digits}f} ±{h:.{digits}f}" if len(values) > 1 else f"{m:.{digits}f}"


def steps_of(r: dict):
    """A quality result's sampling steps (None for the real rows)."""
    return r["info"].get("steps")


def sort_key(r: dict):
    """Rows in VARIANT_ORDER, then by steps and name."""
    v = r["info"].get("variant", "real" if r["kind"] == "real" else "emdm")
    return (VARIANT_ORDER.index(v) if v in VARIANT_ORDER else 99, steps_of(r) or 0, r["name"])


def _method_cells(r: dict) -> list[str]:
    info = r["info"]
    steps = steps_of(r)
    return [r["name"], "–" if steps is None else str(steps), str(r.get("n", "–")), str(info.get("train_steps", "–"))]


def text_table(results: list[dict]) -> str:
    rows = []
    for r in sorted((r for r in results if r["task"] == "text"), key=sort_key):
        m = r["metrics"]
        rows.append(_method_cells(r) + [fmt(m.get("top1")), fmt(m.get("top2")), fmt(m.get("top3")),
                                         fmt(m.get("fid")), fmt(m.get("mm_dist")), fmt(m.get("diversity")),
                                         fmt(m.get("multimodality")), str(r.get("repeats", len(m.get("top1", []))))])
    return md.table(["Method", "Steps", "Clips", "Train steps", "R-prec top-1 ↑", "top-2 ↑", "top-3 ↑", "FID ↓",
                   "MM-Dist ↓", "Diversity →", "MModality ↑", "Repeats"], rows)


def action_table(results: list[dict]) -> str:
    rows = []
    for r in sorted((r for r in results if r["task"] == "action"), key=sort_key):
        m = r["metrics"]
        rows.append(_method_cells(r) + [fmt(m.get("accuracy")), fmt(m.get("fid")), fmt(m.get("diversity")),
                                         fmt(m.get("multimodality")), str(r.get("repeats", len(m.get("accuracy", []))))])
    return md.table(["Method", "Steps", "Clips", "Train steps", "Accuracy ↑", "FID ↓", "Diversity →", "Multimodality →",
                   "Repeats"], rows)


def plausibility_table(results: list[dict]) -> str:
    rows, seen = [], set()
    for r in sorted((r for r in results if r["task"] in ("text", "action") and r.get("plausibility")),
                    key=lambda r: (r["task"] != "text", sort_key(r))):
        p = r["plausibility"]
        key = (r["name"], json.dumps(p, sort_keys=True))
        if key in seen:                 # e.g. the real clips measured by both the text and action runs
            continue
        seen.add(key)
        n = len(p.get("penetration_mm", []))
        rows.append([r["name"], r["task"], "–" if steps_of(r) is None else str(steps_of(r)), str(n),
                     fmt(p.get("penetration_mm"), 1), fmt(p.get("floating_mm"), 1), fmt(p.get("skate_cm_s"), 1),
                     fmt(p.get("skate_ratio"), 3), fmt(p.get("phys_err_mm"), 1)])
    return md.table(["Method", "Task", "Steps", "Motions", "Penetrate (mm) ↓", "Float (mm) ↓", "Skate (cm/s) ↓",
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
    table = md.table(["Runtime", "Method", "Steps", "Threads", "Frames", "ms / motion", "ms / frame", "× EMDM", "Runs",
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
    out += [md.table(header, rows), ""]
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


def clips_per_row(rows: list[dict]) -> str:
    """Which rows used how many test clips, e.g. '892 (Real motion, EMDM (10 steps)); 128 (Real motion, ...)',
    largest count first: rows measured on a subset are compared with the real row of the same count."""
    by_n: dict = {}
    for r in sorted(rows, key=sort_key):
        names = by_n.setdefault(r.get("n", "?"), [])
        if r["name"] not in names:
            names.append(r["name"])
    order = sorted(by_n, key=lambda n: -n if isinstance(n, int) else 0)
    return "; ".join(f"{n} ({', '.join(by_n[n])})" for n in order)


def models_table(results: list[dict]) -> str:
    rows, seen = [], set()
    for r in sorted((r for r in results if r["task"] in ("text", "action") and r["kind"] != "real"),
                    key=lambda r: (r["task"], sort_key(r))):
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
    return md.table(["Task", "Variant", "Weights", "Train steps", "Train wall (min)", "Device", ""], rows)


def headlines(results: list[dict]) -> list[str]:
    """One line per model row: its key metrics next to the real row measured on the same clips."""
    out = []
    keys = {"text": [("top1", "R-precision top-1"), ("fid", "FID"), ("mm_dist", "MM-Dist")],
            "action": [("accuracy", "accuracy"), ("fid", "FID"), ("diversity", "diversity")]}
    for r in sorted((r for r in results if r["task"] in keys and r["kind"] != "real"), key=lambda r: (r["task"], sort_key(r))):
        real = next((q for q in results if q["task"] == r["task"] and q["kind"] == "real" and q.get("n") == r.get("n")), None)
        if real is None:
            continue
        parts = [f"{label} {np.mean(r['metrics'][k]):.3f} (real {np.mean(real['metrics'][k]):.3f})"
                 for k, label in keys[r["task"]] if k in r["metrics"] and k in real["metrics"]]
        out.append(f"{r['task']}, {r['name']}, {r.get('n')} clips × {r.get('repeats')} repeat(s): " + ", ".join(parts))
    return out
