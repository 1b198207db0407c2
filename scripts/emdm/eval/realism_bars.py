"""Issue 28's bars, per shipped generator, read from the realism results of its current weights (docs/RESULTS.md,
"Where the bars stand"): walking and running at real speed, per-frame joint steps within the real clips', the
page's sampling default no worse than plain sampling on either judge of meaning, and the benchmark's time.

A generator's results are those of ``python -m emdm.eval.realism`` whose model, file (the manifest's default
variant), step count, guidance and decode are the page's, and whose weights are the shipped ones (``info.train_steps``
equal to the manifest entry's training steps, continuations included): the newest with the manifest's x̂0 smoothing
and root speed cap is the *default*, the newest with neither is *plain* (the same file where the default is plain
sampling; a result from before the cap had none). Results of
older weights or other settings are left out, so a retrained model shows "not measured" until it is measured.
"""

from __future__ import annotations

from emdm.eval.models_report import total_steps

SPEED_ACTIONS = ("walk", "run")
SPEED_BAND = (0.8, 1.2)        # median speed ÷ the real clips' of the action
STEP_P99_BAR = 1.5             # the joint steps' 99th percentile ≤ this × the real clips'
OVER_MAX_BAR = 0.001           # no more than 1 step in 1,000 over the real clips' largest
WORSE_BAR = 1 / 8              # no action's pass rate lower than plain sampling's by more than 1 motion in 8
MINUTES_BAR = 10.0             # the realism benchmark's run time, per model and step count


def _guidance(r: dict):
    return r.get("info", {}).get("guidance", r.get("key", {}).get("guidance"))


def _sigma(v) -> float:
    return float(v or 0.0)


def pick(results: list[dict], model: str, entry: dict) -> tuple[dict | None, dict | None]:
    """(default, plain) realism results of ``model``'s shipped weights at the page's settings, newest first."""
    want_variant = entry.get("defaultVariant") or "fp32"
    steps = int(entry.get("defaultSteps", 10))
    trained = total_steps(entry) if entry.get("training") else None
    mine = [r for r in results if r.get("task") == "realism" and r.get("model") == model
            and r.get("variant", "fp32") == want_variant and int(r.get("steps", 0)) == steps
            and r.get("decode", "page") == "page"
            and (entry.get("guidance") is None or _guidance(r) == entry.get("guidance"))
            and (trained is None or r.get("info", {}).get("train_steps") == trained)]
    mine.sort(key=lambda r: r.get("created", ""), reverse=True)
    page = (_sigma(entry.get("x0Smoothing")), _sigma(entry.get("speedCap")))
    default = next((r for r in mine if _settings(r) == page), None)
    plain = next((r for r in mine if _settings(r) == (0.0, 0.0)), None)
    return default, plain


def _settings(r: dict) -> tuple[float, float]:
    """A result's (x̂0 smoothing σ, root speed cap); a result from before the cap has none."""
    return _sigma(r.get("x0_smoothing")), _sigma(r.get("speed_cap"))


def worst_drop(default: dict, plain: dict) -> dict[str, tuple[float, str | None]]:
    """Per judge ('classifier', 'kinematic'): the largest drop of an action's pass rate, plain → default, and the
    action (0 and None when none drops)."""
    out = {}
    for judge in ("classifier", "kinematic"):
        d, p = default["generated"].get(judge, {}), plain["generated"].get(judge, {})
        drops = [(p[a] - d[a], a) for a in d if a in p and d[a] is not None and p[a] is not None]
        worst = max(drops, default=(0.0, None))
        out[judge] = (max(worst[0], 0.0), worst[1] if worst[0] > 0 else None)
    return out


def bars(default: dict, plain: dict | None) -> list[tuple[str, str, bool | None]]:
    """(bar, figure, met: True / False / None for not measured) for one generator."""
    g, real = default["generated"], default["real"]
    rows = []
    for a in SPEED_ACTIONS:
        ratio = g.get("per_action", {}).get(a, {}).get("speed_ratio")
        met = None if ratio is None else SPEED_BAND[0] <= ratio <= SPEED_BAND[1]
        rows.append((f"{a}: median speed within ±20 % of its real clips'",
                     "–" if ratio is None else f"× {ratio:.2f}", met))
    p99, rp99 = g["all"]["step_p99"], real["all"]["step_p99"]
    rows.append((f"joint step p99 ≤ {STEP_P99_BAR:g}× the real clips'", f"{p99:.3f} m (real {rp99:.3f}; × {p99 / rp99:.2f})",
                 p99 <= STEP_P99_BAR * rp99))
    over = g["all"]["over_all"]
    rows.append(("steps over the real clips' largest ≤ 1 in 1,000", f"{over:.3%}", over <= OVER_MAX_BAR))
    if plain is None:
        rows.append(("no action below plain sampling by more than 1 motion in 8 (classifier / kinematic)",
                     "plain sampling not measured on these weights", None))
    elif plain is default:
        rows.append(("no action below plain sampling by more than 1 motion in 8 (classifier / kinematic)",
                     "the default is plain sampling", True))
    else:
        w = worst_drop(default, plain)
        fig = " / ".join(f"{v:.2f}" + (f" ({a})" if a else "") for v, a in (w["classifier"], w["kinematic"]))
        rows.append(("no action below plain sampling by more than 1 motion in 8 (classifier / kinematic)",
                     f"largest drop {fig}", all(v <= WORSE_BAR + 1e-9 for v, _ in w.values())))
    minutes = g.get("seconds", 0.0) / 60
    rows.append((f"the benchmark ≤ {MINUTES_BAR:g} min on the CPU", f"{minutes:.1f} min ({default.get('hardware', '?')})",
                 minutes <= MINUTES_BAR))
    return rows


def _mark(met: bool | None) -> str:
    return "not measured" if met is None else ("**met**" if met else "**not met**")


def section(results: list[dict], manifest: dict) -> list[str]:
    """The "Where the bars stand" lines: one table per shipped generator of the manifest."""
    out = ["### Where the bars stand (issue 28), per shipped generator", "",
           "Each shipped generator at the page's settings (its default file, steps, guidance, x̂0 smoothing and root "
           "speed cap), from the newest realism result of its current weights, against plain sampling (neither) of the same "
           "weights. `emdm.eval.realism_bars` picks the files; results of older weights are not used.", ""]
    for model, entry in manifest.get("models", {}).items():
        default, plain = pick(results, model, entry)
        if default is None:
            out += [f"`{model}`: not measured on its current weights at the page's settings.", ""]
            continue
        names = f"`{default['_file']}`" if plain is None or plain is default else \
            f"`{default['_file']}` against `{plain['_file']}`"
        out += [f"`{model}` ({names}):", "", "| Bar | Figure | Verdict |", "| --- | --- | --- |"]
        out += [f"| {b} | {f} | {_mark(m)} |" for b, f, m in bars(default, plain)]
        out.append("")
    return out
