"""How hard each term of the generator's loss pulls: the gradient norm of every geometric term of the G step, as
the recipe's flags weight it (R·L_recon, R·λ·w_pos·L_pos, R·λ·w_vel·L_vel, R·λ·w_foot·L_foot, R·λ·w_bone·L_bone), on
real batches drawn exactly as training draws them, from given weights. A term's loss value says little about what
it does to the weights: on the shipped text model (slice 3, 8 batches of 64) L_foot's gradient was 0.17 against
L_pos's 157 and L_bone's 163, so ``--w-foot 3`` would change nothing. Read this before choosing a weight for a GPU
slice's variant.

    python -m emdm.train_gradients --data data/dataset --task text --out runs/grads \\
        --init-weights public/models/emdm-t2m-web.weights.f16.pt --w-bone 300 --balance-alpha 0.25 --batches 8
    ... --w-foot 50 --json runs/grads/foot50.json          # any training flag, as the run would take it

Takes every flag of ``python -m emdm.train`` (``--out`` only holds the text-embedding cache; nothing else is
written there, and no checkpoint in it is resumed) plus ``--batches`` and ``--json``. Each batch draws its noise
levels as the G step does; the norms are given for the whole batch and split by noise level: t = 1 (the first of
any step count's steps, where the generator cannot know the real clip's phase, so a term on the clip's own
frames asks for the mean) and t < 1. The adversarial term is not measured: a weights file holds no discriminator.
Nothing is updated.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import torch

from emdm.checkpoints import CheckpointError
from emdm.data.dataset import DatasetError
from emdm.model.objectives import pairs
from emdm.train import Trainer
from emdm.train_options import build_parser, check_args

TERMS = ("recon", "pos", "vel", "foot", "bone")
GROUPS = ("all", "t=1", "t<1")


def term_weights(args) -> dict[str, float]:
    """Each term's factor in the G loss under ``args`` (emdm.model.objectives: R·(L_recon + λ·Σ w·L)); with
    --geo-weight-t1 each sample's terms carry GanWeights.geo_scale(t) on top, as in training."""
    r, lam = args.geo_weight, args.lambda_geo
    return {"recon": r, "pos": r * lam * args.w_pos, "vel": r * lam * args.w_vel,
            "foot": r * lam * args.w_foot, "bone": r * lam * args.w_bone}


def _norm(grads) -> float:
    return float(torch.sqrt(sum((g.float() ** 2).sum() for g in grads if g is not None)))


def measure(trainer: Trainer, batches: int) -> dict:
    """Per term and noise group: mean loss, mean weighted loss, mean gradient norm over ``batches`` batches; and the
    norm of the summed geometric gradient."""
    G, weights = trainer.G, term_weights(trainer.args)
    G.eval()                                     # no dropout: the groups' figures are of the same function
    params = [p for p in G.parameters() if p.requires_grad]
    acc = {g: {t: {"loss": [], "grad": []} for t in TERMS} for g in GROUPS}
    total = {g: [] for g in GROUPS}
    for _ in range(batches):
        x0, mask, c = trainer.next_batch()
        _, x_k1, slot, k = pairs(trainer.tables, x0, mask)
        t_cur = trainer.tables.get("time", slot, k)
        z = torch.randn(x0.shape[0], G.z_dim, device=x0.device)
        first = t_cur >= 1.0 - 1e-6
        for group, sel in (("all", torch.ones_like(first)), ("t=1", first), ("t<1", ~first)):
            if not bool(sel.any()):
                continue
            pred = G(x_k1[sel], z[sel], c[sel], t_cur[sel], mask[sel]).float()
            terms = trainer.geo.terms(pred, x0[sel], mask[sel], trainer.gan.geo_scale(t_cur[sel]))
            summed = None
            for name in TERMS:
                if name not in terms:            # λ = 0 or every joint weight 0: only recon is computed
                    acc[group][name]["loss"].append(0.0)
                    acc[group][name]["grad"].append(0.0)
                    continue
                weighted = weights[name] * terms[name]
                summed = weighted if summed is None else summed + weighted
                acc[group][name]["loss"].append(float(terms[name].detach()))
                acc[group][name]["grad"].append(
                    _norm(torch.autograd.grad(weighted, params, retain_graph=True, allow_unused=True)))
            total[group].append(_norm(torch.autograd.grad(summed, params, allow_unused=True)))
    out: dict = {"batches": batches, "batch": trainer.args.batch, "weights": weights, "groups": {}}
    for group in GROUPS:
        if not total[group]:
            out["groups"][group] = None
            continue
        rows = {}
        for name in TERMS:
            loss = float(np.mean(acc[group][name]["loss"]))
            rows[name] = {"loss": loss, "weighted": weights[name] * loss, "grad": float(np.mean(acc[group][name]["grad"]))}
        out["groups"][group] = {"batches": len(total[group]), "terms": rows, "sum_grad": float(np.mean(total[group]))}
    return out


def table(res: dict) -> str:
    lines = [f"gradient norms of the G loss's geometric terms, mean over {res['batches']} batches of {res['batch']} "
             "(adversarial term not measured)",
             f"{'term':6s} {'factor':>8s} {'loss':>10s} {'weighted':>9s} {'|grad|':>9s} {'t=1':>9s} {'t<1':>9s} "
             f"{'of sum':>7s}"]
    g = res["groups"]
    norms = sum(r["grad"] for r in g["all"]["terms"].values()) or 1.0
    for name in TERMS:
        a = g["all"]["terms"][name]
        by_t = [f"{g[k]['terms'][name]['grad']:9.3g}" if g[k] else f"{'–':>9s}" for k in ("t=1", "t<1")]
        lines.append(f"{name:6s} {res['weights'][name]:8.3g} {a['loss']:10.3g} {a['weighted']:9.3g} {a['grad']:9.3g} "
                     f"{' '.join(by_t)} {100 * a['grad'] / norms:6.1f}%")
    lines.append(f"|grad of the sum| {g['all']['sum_grad']:.3g} (the terms' norms add to {norms:.3g}: the rest cancels)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    parser.prog = "python -m emdm.train_gradients"
    parser.add_argument("--batches", type=int, default=8, help="batches to average over")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures here")
    args = parser.parse_args(argv)
    check_args(parser, args)
    if args.batches < 1:
        parser.error(f"--batches: expected ≥ 1, got {args.batches}")
    if args.objective != "ddgan":
        parser.error("--objective diffusion: its loss has no noise levels of a step count; this measures the ddgan G step")
    args.no_resume = True                        # --out holds the caption cache only: never a run to resume
    try:
        trainer = Trainer(args)
        res = measure(trainer, args.batches)
    except (CheckpointError, DatasetError) as e:
        print(f"emdm.train_gradients: {e}", file=sys.stderr)
        return 2
    print(table(res))
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(res, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
