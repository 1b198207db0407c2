"""RESULTS.md's figures (PNG, matplotlib): FID and time per frame against steps, coverage per action. Each
``plot_*`` returns False, writing nothing, when the results hold nothing to draw."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from emdm.eval.coverage import COVERED
from emdm.eval.metrics import mean_ci95
from emdm.eval.report_tables import VARIANT_LABEL, steps_of, timing_rows



def save_figure(fig, path: Path) -> bool:
    """Lay ``fig`` out, write it to ``path`` (its folder made) and free it; True, what a plot function returns once
    its file is written."""
    import matplotlib.pyplot as plt

    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return True

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
    return save_figure(fig, path)


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
        elif steps_of(r) is not None:
            key = (r["info"].get("variant"), r.get("n", 0), r["info"].get("train_steps"))
            series.setdefault(key, []).append((steps_of(r), m, h))
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
    return save_figure(fig, path)


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
    return save_figure(fig, path)
