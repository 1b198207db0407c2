"""Train the EMDM generator (DDGAN with geometric losses, or the plain diffusion baseline).

    python -m emdm.train --data data/dataset --task text --out runs/t2m-web --steps 20000
    torchrun --nproc_per_node 2 -m emdm.train ...          # DDP (gloo on CPU, nccl on GPU)

Objectives (``--objective``):
  ddgan      alternate D and G updates. D: softplus(−D(real)) + softplus(D(fake)), lazy R1 on the real x_k
             (γ ``--r1-gamma`` every ``--r1-every`` steps). G: softplus(−D(fake)) + R·L_geo with
             L_geo = L_recon + λ(w_pos L_pos + w_vel L_vel + w_foot L_foot + w_bone L_bone) (``--geo-weight``
             R = 0 gives the naive DDGAN; L_bone, off by default, is this project's rigidity term). Each
             sample draws a step count T from ``--supported-steps`` and k ∈ 0..T−1, so one model serves
             every step count; G sees the continuous time t_{k+1} (ARCHITECTURE.md).
  diffusion  the same transformer trained on the plain x0 objective at t ~ U(ε, 1) (z = 0), sampled with DDIM.

Checkpoints (``<out>/ckpt.pt``, atomic) hold models, EMA, optimisers, RNG states and the data order, so a
resumed run continues exactly as if it had not stopped. Losses go to ``<out>/log.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F

from emdm.data.dataset import BucketBatcher, caption_table, cached_text_embeddings, collate, load_split
from emdm.model.discriminator import Discriminator
from emdm.model.generator import Generator, count_parameters
from emdm.model.geometry import geometric_losses
from emdm.model.schedule import EPS_SMALL, SUPPORTED_STEPS, make_schedule, marginal_coeffs

LOG_FIELDS = ["step", "epoch", "wall_s", "sec_per_step", "lr_g", "lr_d", "loss_d", "d_real", "d_fake", "r1",
              "loss_g", "g_adv", "recon", "pos", "vel", "foot", "bone"]
DEFAULT_LR_G = {"text": 2e-5, "action": 3e-5}


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m emdm.train", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--data", type=Path, default=None, help="HumanML3D-layout dataset folder (default: emdm.paths.DATASET_DIR)")
    p.add_argument("--split", default="train")
    p.add_argument("--task", choices=["text", "action"], default="text")
    p.add_argument("--encoder", default="all-MiniLM-L6-v2", help="text encoder id (emdm.text)")
    p.add_argument("--out", type=Path, required=True, help="run folder (checkpoint, log, text-embedding cache)")
    p.add_argument("--preset", default="web", help="generator preset: web | paper | tiny")
    p.add_argument("--objective", choices=["ddgan", "diffusion"], default="ddgan")
    p.add_argument("--steps", type=int, default=20000, help="total optimisation steps (cosine LR horizon)")
    p.add_argument("--batch", type=int, default=64, help="batch per process")
    p.add_argument("--lr-g", type=float, default=None, help="generator LR (default 2e-5 text, 3e-5 action)")
    p.add_argument("--lr-d", type=float, default=1.25e-4)
    p.add_argument("--lr-min", type=float, default=1e-5, help="cosine decay floor")
    p.add_argument("--warmup", type=int, default=0, help="linear LR warm-up steps")
    p.add_argument("--betas", type=float, nargs=2, default=(0.5, 0.9))
    p.add_argument("--ema", type=float, default=0.9999)
    p.add_argument("--ema-warmup", action=argparse.BooleanOptionalAction, default=True,
                   help="use decay min(ema, (1+n)/(10+n)) so short runs do not keep the initial weights")
    p.add_argument("--geo-weight", type=float, default=100.0, help="R: weight of L_geo in the G loss (0 = naive DDGAN)")
    p.add_argument("--lambda-geo", type=float, default=1.0, help="λ: weight of the joint terms inside L_geo")
    p.add_argument("--w-pos", type=float, default=1.0)
    p.add_argument("--w-vel", type=float, default=1.0)
    p.add_argument("--w-foot", type=float, default=1.0)
    p.add_argument("--w-bone", type=float, default=0.0,
                   help="weight of L_bone, the squared relative bone-length error (not in the paper: 0 = its recipe)")
    p.add_argument("--adv-weight", type=float, default=1.0, help="weight of the G adversarial term")
    p.add_argument("--r1-gamma", type=float, default=0.02)
    p.add_argument("--r1-every", type=int, default=15)
    p.add_argument("--d-cond", action=argparse.BooleanOptionalAction, default=True, help="condition D on c")
    p.add_argument("--d-width", type=int, default=1024, help="D's first hidden width (released: 1024)")
    p.add_argument("--cond-drop", type=float, default=0.1, help="probability of the zero (unconditional) condition")
    p.add_argument("--supported-steps", default=",".join(map(str, SUPPORTED_STEPS)))
    p.add_argument("--min-frames", type=int, default=40)
    p.add_argument("--random-crop", type=float, default=0.0,
                   help="probability of training on a random sub-window (≥ --min-frames) of a clip; teaches short "
                        "lengths and saves compute")
    p.add_argument("--crop-min", type=int, default=40, help="shortest random sub-window (frames)")
    p.add_argument("--limit", type=int, default=None, help="use at most this many clips (smoke tests)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None, help="torch CPU threads per process")
    p.add_argument("--device", default=None, help="cpu | cuda (default: cuda when available)")
    p.add_argument("--log-every", type=int, default=10)
    p.add_argument("--ckpt-every", type=int, default=0, help="also checkpoint every N steps (0 = off)")
    p.add_argument("--ckpt-minutes", type=float, default=5.0, help="checkpoint every M minutes of wall time")
    p.add_argument("--time-limit-min", type=float, default=None, help="checkpoint and stop after M minutes")
    p.add_argument("--stop-at", type=int, default=None, help="checkpoint and stop at this step (testing resume)")
    p.add_argument("--no-resume", action="store_true", help="start fresh even if <out>/ckpt.pt exists")
    p.add_argument("--init-weights", type=Path, default=None,
                   help="start G (and its EMA) from a --weights-out file of an earlier run of the same model; "
                        "D and the optimisers start fresh. Its steps are recorded as the run's 'init' in meta")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=True, help="tqdm progress bar")
    p.add_argument("--weights-out", type=Path, default=None,
                   help="at the end also write the EMA generator alone (+ meta) to this file: what export, sample "
                        "and the evaluation read, ~1/50 of ckpt.pt (D and the optimisers stay out)")
    p.add_argument("--weights-dtype", choices=["float32", "float16"], default="float32",
                   help="storage type of --weights-out (float16 halves it again; loaded back as float32)")
    return p


# ---------------------------------------------------------------------------------------------- helpers

def cosine_lr(step: int, total: int, base: float, floor: float, warmup: int = 0) -> float:
    if warmup and step < warmup:
        return base * (step + 1) / warmup
    frac = min(max(step - warmup, 0) / max(total - warmup, 1), 1.0)
    if base <= floor:
        return base
    return floor + (base - floor) * 0.5 * (1.0 + math.cos(math.pi * frac))


class Dist:
    """torchrun environment (rank/world) and a gradient all-reduce (average) for plain modules."""

    def __init__(self, device: torch.device):
        self.world = int(os.environ.get("WORLD_SIZE", "1"))
        self.rank = int(os.environ.get("RANK", "0"))
        if self.world > 1 and not torch.distributed.is_initialized():
            backend = "nccl" if device.type == "cuda" else "gloo"
            torch.distributed.init_process_group(backend)

    @property
    def main(self) -> bool:
        return self.rank == 0

    def average_grads(self, module: torch.nn.Module) -> None:
        if self.world == 1:
            return
        grads = [p.grad for p in module.parameters() if p.grad is not None]
        flat = torch.cat([g.reshape(-1) for g in grads])
        torch.distributed.all_reduce(flat)
        flat /= self.world
        off = 0
        for g in grads:
            n = g.numel()
            g.copy_(flat[off:off + n].view_as(g))
            off += n

    def broadcast_module(self, module: torch.nn.Module) -> None:
        if self.world > 1:
            for t in list(module.parameters()) + list(module.buffers()):
                torch.distributed.broadcast(t.data, 0)

    def mean_scalars(self, values: dict[str, float]) -> dict[str, float]:
        if self.world == 1:
            return values
        keys = sorted(values)
        t = torch.tensor([values[k] for k in keys], dtype=torch.float64)
        torch.distributed.all_reduce(t)
        return {k: float(v) / self.world for k, v in zip(keys, t)}

    def gather(self, obj):
        if self.world == 1:
            return [obj]
        out = [None] * self.world
        torch.distributed.all_gather_object(out, obj)
        return out

    def barrier(self) -> None:
        if self.world > 1:
            torch.distributed.barrier()

    def close(self) -> None:
        if self.world > 1 and torch.distributed.is_initialized():
            torch.distributed.destroy_process_group()


class ScheduleTables:
    """Per-T schedule coefficients stacked so a batch can mix step counts: index [T slot, i]."""

    def __init__(self, steps: list[int], device: torch.device):
        self.steps = steps
        n = max(steps) + 1
        keys = ["time", "time_prev", "coef1", "coef2", "sigma"]
        cum = ["a_cum", "s_cum", "a_step", "s_step"]
        self.tab = {k: torch.zeros(len(steps), n, dtype=torch.float32) for k in keys + cum}
        for i, T in enumerate(steps):
            s = make_schedule(T)
            for k in keys + cum:
                v = torch.tensor(getattr(s, k), dtype=torch.float32)
                self.tab[k][i, : len(v)] = v
        self.tab = {k: v.to(device) for k, v in self.tab.items()}

    def draw(self, b: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
        slot = torch.randint(len(self.steps), (b,))
        T = torch.tensor(self.steps)[slot]
        k = (torch.rand(b) * T).long().clamp(max=T - 1)
        return slot.to(device), k.to(device)

    def get(self, name: str, slot: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
        return self.tab[name][slot, idx]


def bcast(v: torch.Tensor) -> torch.Tensor:
    return v[:, None, None]


def masked_mse(a: torch.Tensor, b: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    return (((a - b) ** 2).mean(-1) * mask).sum() / mask.sum().clamp_min(1.0)


def atomic_save(obj, path: Path) -> None:
    tmp = path.with_name(path.name + ".tmp")
    torch.save(obj, tmp)
    os.replace(tmp, path)


def save_weights_file(path: Path, state: dict, *, step: int, wall: float, meta: dict, last_losses: dict,
                      dtype: str = "float32") -> None:
    """The --weights-out format: a generator's state dict (on the CPU, as ``dtype``) with its meta and
    progress, read by ``emdm.export.load_generator`` and ``--init-weights`` (tensors and plain values only)."""
    dt = getattr(torch, dtype)
    weights = {k: v.detach().to("cpu", dt) for k, v in state.items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_save({"step": int(step), "wall": float(wall), "meta": {**meta, "weights_dtype": dtype},
                 "last_losses": last_losses, "G_ema": weights}, path)


# ---------------------------------------------------------------------------------------------- trainer

class Trainer:
    def __init__(self, args: argparse.Namespace):
        self.args = args
        self.device = torch.device(args.device or ("cuda" if torch.cuda.is_available() else "cpu"))
        if args.threads:
            torch.set_num_threads(args.threads)
        self.dist = Dist(self.device)
        args.out.mkdir(parents=True, exist_ok=True)
        self.supported = sorted({int(s) for s in str(args.supported_steps).split(",") if s.strip()})
        if not self.supported or min(self.supported) < 1:
            raise SystemExit(f"--supported-steps: expected positive integers, got {args.supported_steps!r}")
        lr_g = args.lr_g if args.lr_g is not None else DEFAULT_LR_G[args.task]
        self.lr_g = lr_g

        from emdm import paths
        data = args.data or paths.DATASET_DIR
        self.data_dir = Path(data)
        self.ms = load_split(self.data_dir, args.split, min_frames=args.min_frames, limit=args.limit,
                             require_action=args.task == "action")
        if args.task == "text":
            captions, self.clip_caps = caption_table(self.ms)
            if self.dist.main:
                emb = cached_text_embeddings(captions, args.encoder, args.out)
            self.dist.barrier()
            if not self.dist.main:
                emb = cached_text_embeddings(captions, args.encoder, args.out)
            self.text_emb = torch.from_numpy(emb).to(self.device)
            self.cond_dim = int(emb.shape[1])
        else:
            if not self.ms.action_labels:
                raise SystemExit(f"{self.data_dir}: --task action needs actions.json and metadata.csv")
            self.cond_dim = len(self.ms.action_labels)
        self.motions = [torch.from_numpy(m) for m in self.ms.motions]
        self.mean = torch.from_numpy(self.ms.mean).to(self.device)
        self.std = torch.from_numpy(self.ms.std).to(self.device)

        torch.manual_seed(args.seed)                         # identical init on every rank
        self.G = Generator(self.cond_dim, args.preset).to(self.device)
        self.G_ema = Generator(self.cond_dim, args.preset).to(self.device)
        self.G_ema.load_state_dict(self.G.state_dict())
        self.G_ema.eval().requires_grad_(False)
        self.D = None
        self.opt_d = None
        if args.objective == "ddgan":
            self.D = Discriminator(self.cond_dim if args.d_cond else 0, width=args.d_width).to(self.device)
            self.opt_d = torch.optim.Adam(self.D.parameters(), lr=args.lr_d, betas=tuple(args.betas))
        self.opt_g = torch.optim.Adam(self.G.parameters(), lr=lr_g, betas=tuple(args.betas))
        self.tables = ScheduleTables(self.supported, self.device)
        self.batcher = BucketBatcher(self.ms.lengths, args.batch, seed=args.seed, rank=self.dist.rank, world=self.dist.world)
        self.step = 0
        self.wall = 0.0
        self.last_losses: dict[str, float] = {}
        self.init: dict | None = None
        if args.init_weights is not None:
            self.init_from(args.init_weights)
        torch.manual_seed(args.seed * 1000 + 17 + self.dist.rank)   # per-rank noise stream
        ckpt = args.out / "ckpt.pt"
        if ckpt.exists() and not args.no_resume:
            self.load(ckpt)

    def init_from(self, path: Path) -> None:
        try:                                   # tensors and plain values only: no code runs from the file
            st = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as e:  # noqa: BLE001 - re-raised with the file name
            raise SystemExit(f"{path}: cannot read as a --weights-out file: {e}") from e
        if not isinstance(st, dict) or "G_ema" not in st or "meta" not in st:
            raise SystemExit(f"{path}: not a --weights-out file (needs G_ema and meta)")
        m = st["meta"]
        if m["generator"] != self.G.config() or m["task"] != self.args.task or m["objective"] != self.args.objective:
            raise SystemExit(f"{path}: weights of another model/task/objective ({m['task']}, {m['objective']}, "
                             f"{m['generator']}); --init-weights needs the same")
        weights = {k: v.float() for k, v in st["G_ema"].items()}
        self.G.load_state_dict(weights)
        self.G_ema.load_state_dict(weights)
        prior = m.get("init") or {"steps": 0, "wall_s": 0.0, "runs": []}
        self.init = {"steps": prior["steps"] + int(st["step"]), "wall_s": prior["wall_s"] + float(st.get("wall", 0.0)),
                     "runs": prior["runs"] + [{"file": path.name, "steps": int(st["step"]), "device": m.get("device"),
                                                "batch": m.get("batch"), "weights_dtype": m.get("weights_dtype")}]}

    # -- conditions ---------------------------------------------------------------------------------
    def conditions(self, idx: np.ndarray) -> torch.Tensor:
        b = len(idx)
        if self.args.task == "text":
            pick = [int(self.clip_caps[i][int(torch.randint(len(self.clip_caps[i]), ()))]) for i in idx]
            c = self.text_emb[pick]
        else:
            c = F.one_hot(torch.from_numpy(self.ms.actions[idx]), self.cond_dim).float().to(self.device)
        keep = (torch.rand(b, device=self.device) >= self.args.cond_drop).float()
        return c * keep[:, None]

    def crop(self, m: np.ndarray) -> np.ndarray:
        a = self.args
        if a.random_crop <= 0 or len(m) <= a.crop_min or float(torch.rand(())) >= a.random_crop:
            return m
        n = int(torch.randint(a.crop_min, len(m) + 1, ()))
        s = int(torch.randint(0, len(m) - n + 1, ()))
        return m[s:s + n]

    # -- diffusion pairs ------------------------------------------------------------------------------
    def pairs(self, x0: torch.Tensor, mask: torch.Tensor):
        b = x0.shape[0]
        slot, k = self.tables.draw(b, self.device)
        g = self.tables.get
        x_k = bcast(g("a_cum", slot, k)) * x0 + bcast(g("s_cum", slot, k)) * torch.randn_like(x0)
        x_k1 = bcast(g("a_step", slot, k + 1)) * x_k + bcast(g("s_step", slot, k + 1)) * torch.randn_like(x0)
        m = mask.unsqueeze(-1)
        return x_k * m, x_k1 * m, slot, k

    def posterior(self, x0_pred: torch.Tensor, x_k1: torch.Tensor, slot, k, mask) -> torch.Tensor:
        g = self.tables.get
        x = bcast(g("coef1", slot, k)) * x0_pred + bcast(g("coef2", slot, k)) * x_k1
        x = x + bcast(g("sigma", slot, k)) * torch.randn_like(x)
        return x * mask.unsqueeze(-1)

    def geo(self, x0_pred: torch.Tensor, x0: torch.Tensor, mask: torch.Tensor) -> dict[str, torch.Tensor]:
        a = self.args
        out = {"recon": masked_mse(x0_pred, x0, mask)}
        need_joints = a.lambda_geo > 0 and (a.w_pos or a.w_vel or a.w_foot or a.w_bone)
        if need_joints:
            out.update(geometric_losses(x0_pred * self.std + self.mean, x0 * self.std + self.mean, mask))
        return out

    def geo_total(self, terms: dict[str, torch.Tensor]) -> torch.Tensor:
        a = self.args
        total = terms["recon"]
        if "pos" in terms:
            total = total + a.lambda_geo * (a.w_pos * terms["pos"] + a.w_vel * terms["vel"] + a.w_foot * terms["foot"]
                                            + a.w_bone * terms["bone"])
        return total

    # -- one optimisation step ---------------------------------------------------------------------------
    def set_lr(self) -> tuple[float, float]:
        a = self.args
        lr_g = cosine_lr(self.step, a.steps, self.lr_g, a.lr_min, a.warmup)
        for grp in self.opt_g.param_groups:
            grp["lr"] = lr_g
        lr_d = 0.0
        if self.opt_d is not None:
            lr_d = cosine_lr(self.step, a.steps, a.lr_d, a.lr_min, a.warmup)
            for grp in self.opt_d.param_groups:
                grp["lr"] = lr_d
        return lr_g, lr_d

    def train_step(self) -> dict[str, float]:
        a = self.args
        idx = self.batcher.next()
        x0_np, mask_np = collate([self.crop(self.ms.motions[i]) for i in idx])
        x0 = torch.from_numpy(x0_np).to(self.device)
        mask = torch.from_numpy(mask_np).to(self.device)
        c = self.conditions(idx)
        b = x0.shape[0]
        lr_g, lr_d = self.set_lr()
        logs: dict[str, float] = {"lr_g": lr_g, "lr_d": lr_d}
        self.G.train()

        if a.objective == "diffusion":
            t = torch.rand(b, device=self.device) * (1 - EPS_SMALL) + EPS_SMALL
            a_t, s_t = marginal_coeffs(t)
            x_t = (bcast(a_t) * x0 + bcast(s_t) * torch.randn_like(x0)) * mask.unsqueeze(-1)
            x0_pred = self.G(x_t, torch.zeros(b, self.G.z_dim, device=self.device), c, t, mask)
            terms = self.geo(x0_pred, x0, mask)
            loss_g = self.geo_total(terms)
            self.opt_g.zero_grad(set_to_none=True)
            loss_g.backward()
            self.dist.average_grads(self.G)
            self.opt_g.step()
            logs.update({k: float(v.detach()) for k, v in terms.items()})
            logs["loss_g"] = float(loss_g.detach())
            self.update_ema()
            return logs

        # ---- D step
        self.D.requires_grad_(True)
        x_k, x_k1, slot, k = self.pairs(x0, mask)
        t_cur, t_prev = self.tables.get("time", slot, k), self.tables.get("time_prev", slot, k)
        do_r1 = a.r1_gamma > 0 and a.r1_every > 0 and self.step % a.r1_every == 0
        x_k.requires_grad_(do_r1)
        d_real = self.D(x_k, x_k1, c, t_cur, t_prev, mask)
        loss_real = F.softplus(-d_real).mean()
        r1 = torch.zeros((), device=self.device)
        if do_r1:
            (grad,) = torch.autograd.grad(d_real.sum(), x_k, create_graph=True)
            r1 = a.r1_gamma / 2 * grad.pow(2).reshape(b, -1).sum(1).mean()
        with torch.no_grad():
            z = torch.randn(b, self.G.z_dim, device=self.device)
            fake = self.posterior(self.G(x_k1, z, c, t_cur, mask), x_k1, slot, k, mask)
        d_fake = self.D(fake, x_k1, c, t_cur, t_prev, mask)
        loss_fake = F.softplus(d_fake).mean()
        loss_d = loss_real + loss_fake + r1
        self.opt_d.zero_grad(set_to_none=True)
        loss_d.backward()
        self.dist.average_grads(self.D)
        self.opt_d.step()
        logs.update(loss_d=float((loss_real + loss_fake).detach()), d_real=float(d_real.detach().mean()), d_fake=float(d_fake.detach().mean()))
        if do_r1:
            logs["r1"] = float(r1.detach())

        # ---- G step
        self.D.requires_grad_(False)
        x_k, x_k1, slot, k = self.pairs(x0, mask)
        t_cur, t_prev = self.tables.get("time", slot, k), self.tables.get("time_prev", slot, k)
        z = torch.randn(b, self.G.z_dim, device=self.device)
        x0_pred = self.G(x_k1, z, c, t_cur, mask)
        fake = self.posterior(x0_pred, x_k1, slot, k, mask)
        g_adv = F.softplus(-self.D(fake, x_k1, c, t_cur, t_prev, mask)).mean()
        loss_g = a.adv_weight * g_adv
        terms = {}
        if a.geo_weight > 0:
            terms = self.geo(x0_pred, x0, mask)
            loss_g = loss_g + a.geo_weight * self.geo_total(terms)
        self.opt_g.zero_grad(set_to_none=True)
        loss_g.backward()
        self.dist.average_grads(self.G)
        self.opt_g.step()
        self.update_ema()
        logs.update({k: float(v.detach()) for k, v in terms.items()})
        logs.update(loss_g=float(loss_g.detach()), g_adv=float(g_adv.detach()))
        return logs

    @torch.no_grad()
    def update_ema(self) -> None:
        decay = self.args.ema
        if self.args.ema_warmup:
            decay = min(decay, (1 + self.step) / (10 + self.step))
        for pe, p in zip(self.G_ema.parameters(), self.G.parameters()):
            pe.mul_(decay).add_(p.detach(), alpha=1 - decay)

    # -- checkpoints -----------------------------------------------------------------------------------
    def meta(self) -> dict:
        a = self.args
        return {
            "task": a.task, "objective": a.objective, "cond_dim": self.cond_dim,
            "condition": ({"type": "text", "encoder": a.encoder, "dim": self.cond_dim} if a.task == "text"
                          else {"type": "action", "labels": list(self.ms.action_labels), "dim": self.cond_dim}),
            "generator": self.G.config(), "supported_steps": self.supported,
            "mean": self.ms.mean.tolist(), "std": self.ms.std.tolist(),
            "dataset": self.data_dir.name, "clips": len(self.ms), "device": self.device_name(),
            "world": self.dist.world, "batch": a.batch, "init": self.init,
            "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(a).items()},
        }

    def device_name(self) -> str:
        if self.device.type == "cuda":
            return torch.cuda.get_device_name(self.device)
        return f"cpu ({torch.get_num_threads()} threads × {self.dist.world} processes)"

    def save(self) -> None:
        rng = self.dist.gather({"torch": torch.get_rng_state(),
                                "cuda": torch.cuda.get_rng_state_all() if self.device.type == "cuda" else None})
        if not self.dist.main:
            return
        state = {
            "step": self.step, "wall": self.wall, "meta": self.meta(), "last_losses": self.last_losses,
            "G": self.G.state_dict(), "G_ema": self.G_ema.state_dict(), "opt_g": self.opt_g.state_dict(),
            "D": self.D.state_dict() if self.D is not None else None,
            "opt_d": self.opt_d.state_dict() if self.opt_d is not None else None,
            "batcher": [self.batcher.state()], "rng": rng,
        }
        atomic_save(state, self.args.out / "ckpt.pt")

    def save_weights(self, path: Path, dtype: str = "float32") -> None:
        """The EMA generator and meta only (a checkpoint ``emdm.export.load_generator`` reads)."""
        if not self.dist.main:
            return
        save_weights_file(path, self.G_ema.state_dict(), step=self.step, wall=self.wall, meta=self.meta(),
                          last_losses=self.last_losses, dtype=dtype)

    def load(self, path: Path) -> None:
        st = torch.load(path, map_location=self.device, weights_only=False)
        meta = st["meta"]
        if meta["generator"] != self.G.config() or meta["task"] != self.args.task or meta["objective"] != self.args.objective:
            raise SystemExit(f"{path}: checkpoint was trained with a different model/task/objective "
                             f"({meta['task']}, {meta['objective']}, {meta['generator']}); use another --out or --no-resume")
        self.G.load_state_dict(st["G"])
        self.G_ema.load_state_dict(st["G_ema"])
        self.opt_g.load_state_dict(st["opt_g"])
        if self.D is not None:
            self.D.load_state_dict(st["D"])
            self.opt_d.load_state_dict(st["opt_d"])
        self.step, self.wall, self.last_losses = st["step"], st["wall"], st.get("last_losses", {})
        self.batcher.load_state(st["batcher"][0])
        rng = st["rng"][self.dist.rank] if self.dist.rank < len(st["rng"]) else st["rng"][0]
        torch.set_rng_state(rng["torch"].cpu())          # map_location may have moved it to the GPU
        if rng.get("cuda") is not None and self.device.type == "cuda":
            torch.cuda.set_rng_state_all([s.cpu() for s in rng["cuda"]])
        if self.dist.main:
            print(f"resumed {path} at step {self.step}", file=sys.stderr)

    # -- loop ------------------------------------------------------------------------------------------
    def run(self) -> None:
        a = self.args
        log_path = a.out / "log.csv"
        new_log = not log_path.exists() or self.step == 0
        fields = LOG_FIELDS
        if not new_log:              # appending: keep the columns the file already has (an older run's log)
            with open(log_path, newline="") as f:
                fields = next(csv.reader(f), None) or LOG_FIELDS
        logf = open(log_path, "w" if new_log else "a", newline="") if self.dist.main else None
        writer = csv.DictWriter(logf, fieldnames=fields) if logf else None
        if writer and new_log:
            writer.writeheader()
        if self.dist.main:
            print(f"G {count_parameters(self.G):,} params, D {count_parameters(self.D) if self.D else 0:,}; "
                  f"{len(self.ms)} clips; device {self.device_name()}", file=sys.stderr)
        bar = None
        if a.progress and self.dist.main:
            from tqdm import tqdm
            bar = tqdm(total=a.steps, initial=self.step, mininterval=5.0, dynamic_ncols=True, file=sys.stderr)
        stop_at = min(a.steps, a.stop_at) if a.stop_at is not None else a.steps
        t_start, t_ckpt = time.time(), time.time()
        wall0 = self.wall
        acc: dict[str, list[float]] = {}
        t_log = time.time()
        while self.step < stop_at:
            logs = self.train_step()
            self.step += 1
            self.wall = wall0 + time.time() - t_start
            for k, v in logs.items():
                acc.setdefault(k, []).append(v)
            if bar:
                bar.update(1)
            if self.step % a.log_every == 0 or self.step == stop_at:
                means = self.dist.mean_scalars({k: float(np.mean(v)) for k, v in acc.items()})
                n = len(next(iter(acc.values())))
                means["sec_per_step"] = (time.time() - t_log) / max(n, 1)
                t_log = time.time()
                acc = {}
                self.last_losses = {k: round(v, 6) for k, v in means.items() if not k.startswith("lr")}
                if writer:
                    writer.writerow({"step": self.step, "epoch": self.batcher.epoch, "wall_s": round(self.wall, 1),
                                     **{k: f"{v:.6g}" for k, v in means.items() if k in fields}})
                    logf.flush()
                if bar:
                    bar.set_postfix({k: f"{means[k]:.3g}" for k in ("loss_d", "g_adv", "recon") if k in means})
                if any(not math.isfinite(v) for v in means.values()):
                    self.save()
                    raise SystemExit(f"step {self.step}: non-finite loss {means}; checkpoint saved, stopping")
            timed_out = a.time_limit_min is not None and (time.time() - t_start) > a.time_limit_min * 60
            due = (a.ckpt_every and self.step % a.ckpt_every == 0) or (time.time() - t_ckpt) > a.ckpt_minutes * 60
            if self.dist.world > 1:      # all ranks must agree (save gathers RNG states)
                flag = torch.tensor([float(bool(due)), float(bool(timed_out))])
                torch.distributed.all_reduce(flag, op=torch.distributed.ReduceOp.MAX)
                due, timed_out = bool(flag[0]), bool(flag[1])
            if due or timed_out or self.step == stop_at:
                self.save()
                t_ckpt = time.time()
            if timed_out:
                if self.dist.main:
                    print(f"time limit reached at step {self.step}", file=sys.stderr)
                break
        if bar:
            bar.close()
        if logf:
            logf.close()
        self.check_replicas()

    def check_replicas(self) -> None:
        """DDP: every rank must hold identical generator weights (gradients are averaged each step)."""
        if self.dist.world == 1:
            return
        sums = self.dist.gather(float(sum(p.double().sum() for p in self.G.parameters())))
        if max(sums) - min(sums) > 1e-6 * max(1.0, abs(sums[0])):
            raise RuntimeError(f"DDP replicas diverged: generator weight sums per rank {sums}")
        if self.dist.main:
            print(f"DDP: {self.dist.world} replicas in sync (weight sum {sums[0]:.6f})", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    trainer = Trainer(args)
    try:
        trainer.run()
        if args.weights_out is not None:
            trainer.save_weights(args.weights_out, args.weights_dtype)
    finally:
        trainer.dist.close()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
