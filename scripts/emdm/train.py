"""Train the EMDM generator (DDGAN with geometric losses, or the plain diffusion baseline).

    python -m emdm.train --data data/dataset --task text --out runs/t2m-web --steps 20000
    python -m emdm.train ... --batch 256 --lr-scale sqrt --amp bf16 --balance-alpha 0.5   # a GPU run
    torchrun --nproc_per_node 2 -m emdm.train ...          # DDP (gloo on CPU, nccl on GPU)

Objectives (``--objective``, one step each in ``emdm.model.objectives``): ``ddgan`` alternates D and G updates
(G: adversarial + R·L_geo; each sample draws a step count T from ``--supported-steps`` and k ∈ 0..T−1, so one
model serves every step count); ``diffusion`` is the same transformer on the plain x0 objective, sampled with DDIM.

Data: the whole split lives on the training device as one padded tensor; each epoch's batches (similar lengths
bucketed together, clips drawn by action with P ∝ n_action^α, ``--balance-alpha``; α = 1 is the plain epoch) and
their random crops are planned on the host once per epoch and uploaded, so a step gathers its batch on the device.
Loss terms are accumulated on the device and read back every ``--log-every`` steps; a non-finite term is caught
by an on-device flag checked at every log and before every checkpoint: the run then stops with exit status 2,
naming the step and the term, and leaves the last good ``ckpt.pt`` as it was.

Checkpoints (``<out>/ckpt.pt``, atomic, ``emdm.checkpoints``) hold models, EMA, optimisers, RNG states and the data
order, so a resumed run continues exactly as if it had not stopped. Losses go to ``<out>/log.csv``.
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

from emdm import paths
from emdm.checkpoints import (CheckpointError, TRAIN_KEYS, atomic_save, check_same_model, dataset_identity,
                              first_non_finite, load_file, load_state_dict, load_weights_file, save_weights_file)
from emdm.data.dataset import (BucketBatcher, DatasetError, DeviceClips, action_shares, caption_table,
                               cached_text_embeddings, crop_plan, load_split)
from emdm.distributed import Dist
from emdm.model.discriminator import Discriminator
from emdm.model.generator import Generator, count_parameters
from emdm.model.objectives import GanWeights, Geo, Nets, ScheduleTables, ddgan_step, diffusion_step
from emdm.outdir import OutputRefused, check_writable, missing_folders, remove_made_folders
from emdm.sampler.schedule import SUPPORTED_STEPS
from emdm.train_log import LOG_FIELDS, NonFiniteLoss, StepLog, truncate_log
from emdm.train_options import build_parser, check_args, supported_steps

__all__ = ["main", "build_parser", "Trainer", "cosine_lr", "save_weights_file", "atomic_save"]   # save_weights_file: re-exported

DEFAULT_LR_G = {"text": 2e-5, "action": 3e-5}
REFERENCE_BATCH = 64               # the batch the default learning rates were tuned for (--lr-scale)


# ---------------------------------------------------------------------------------------------- helpers

def cosine_lr(step: int, total: int, base: float, floor: float, warmup: int = 0) -> float:
    if warmup and step < warmup:
        return base * (step + 1) / warmup
    frac = min(max(step - warmup, 0) / max(total - warmup, 1), 1.0)
    if base <= floor:
        return base
    return floor + (base - floor) * 0.5 * (1.0 + math.cos(math.pi * frac))


def lr_factor(rule: str, global_batch: int) -> float:
    r = global_batch / REFERENCE_BATCH
    return {"none": 1.0, "sqrt": math.sqrt(r), "linear": r}[rule]


# ---------------------------------------------------------------------------------------------- trainer

class Trainer:
    def __init__(self, args: argparse.Namespace):
        self.args = args
        self.device = torch.device(args.device or ("cuda" if torch.cuda.is_available() else "cpu"))
        if args.threads:
            torch.set_num_threads(args.threads)
        self.dist = Dist(self.device)
        self.supported = supported_steps(args.supported_steps)      # checked by check_args (ValueError)
        self.lr_scale = lr_factor(args.lr_scale, args.batch * self.dist.world)
        self.lr_g = (args.lr_g if args.lr_g is not None else DEFAULT_LR_G[args.task]) * self.lr_scale
        self.lr_d = args.lr_d * self.lr_scale
        self._init_st: dict | None = None          # the --init-weights file once read (init_state)
        if args.init_weights is not None:
            self.init_state()                       # a bad file is refused before the captions are embedded
        self.load_data()
        self.build_models()
        self.batcher = BucketBatcher(self.ms.lengths, args.batch, seed=args.seed, rank=self.dist.rank,
                                     world=self.dist.world, groups=self.ms.actions, alpha=args.balance_alpha)
        self.sampling = action_shares(self.ms.actions, args.balance_alpha, self.ms.action_labels)
        self.step = 0
        self.wall = 0.0
        self.last_losses: dict[str, float] = {}
        self.init: dict | None = None
        self._plan_epoch = -1
        if args.init_weights is not None:
            self.init_from(args.init_weights)
        torch.manual_seed(args.seed * 1000 + 17 + self.dist.rank)   # per-rank noise stream
        ckpt = args.out / "ckpt.pt"
        if ckpt.exists() and not args.no_resume:
            self.load(ckpt)

    def load_data(self) -> None:
        a = self.args
        self.data_dir = Path(a.data or paths.DATASET_DIR)
        self.data_id = dataset_identity(self.data_dir, a.split)
        self.ms = load_split(self.data_dir, a.split, min_frames=a.min_frames, limit=a.limit,
                             require_action=a.task == "action")
        clip_caps = None
        if a.task == "text":
            captions, clip_caps = caption_table(self.ms)
            if self.dist.main:
                emb = cached_text_embeddings(captions, a.encoder, a.out)
            self.dist.barrier()
            if not self.dist.main:
                emb = cached_text_embeddings(captions, a.encoder, a.out)
            self.text_emb = torch.from_numpy(emb).to(self.device)
            self.cond_dim = int(emb.shape[1])
        else:
            if not self.ms.action_labels:
                raise DatasetError(f"{self.data_dir}: --task action needs actions.json and metadata.csv")
            if a.init_weights is not None:
                self.take_labels_of(a.init_weights, self.init_state()["meta"])
            self.cond_dim = len(self.ms.action_labels)
        self.clips = DeviceClips(self.ms, self.device, clip_caps)
        if a.task == "action":      # per clip, once: F.one_hot checks its indices with a host sync on every call
            self.action_onehot = F.one_hot(self.clips.actions, self.cond_dim).float()
        self.geo = Geo(torch.from_numpy(self.ms.mean).to(self.device), torch.from_numpy(self.ms.std).to(self.device),
                       a.lambda_geo, a.w_pos, a.w_vel, a.w_foot, a.w_bone)

    def init_state(self) -> dict:
        """The --init-weights file, read once: an action model's labels are needed before the models are built
        (take_labels_of), its weights after (init_from)."""
        if self._init_st is None:
            self._init_st = load_weights_file(self.args.init_weights)   # tensors and plain values only
        return self._init_st

    def take_labels_of(self, path: Path, meta: dict) -> None:
        """An action model continued (--init-weights ``path``, its ``meta``) keeps its one-hot labels: this dataset's
        actions are renumbered to the model's order (a dataset of some of its actions, or the same ones listed
        otherwise, trains the model's own inputs); an action the model does not know is a CheckpointError naming it."""
        cond = meta.get("condition") or {}
        labels = cond.get("labels") if cond.get("type") == "action" else None
        if not isinstance(labels, list):
            return                                     # not an action model's file: check_same_model says so
        unknown = [x for x in self.ms.action_labels if x not in labels]
        if unknown:
            raise CheckpointError(f"{path}: its action model does not know this dataset's action(s) "
                                  f"{', '.join(unknown[:5])}{' …' if len(unknown) > 5 else ''} ({len(labels)} labels: "
                                  f"{', '.join(labels[:5])} …); --init-weights needs the dataset's actions among them")
        if self.ms.action_labels != labels:
            to = np.array([labels.index(x) for x in self.ms.action_labels], dtype=np.int64)
            self.ms.actions = np.where(self.ms.actions >= 0, to[np.maximum(self.ms.actions, 0)], -1)
            if self.dist.main:
                print(f"actions: this dataset's {len(self.ms.action_labels)} renumbered to the {len(labels)} labels of "
                      f"{path.name}", file=sys.stderr)
            self.ms.action_labels = list(labels)

    def build_models(self) -> None:
        a = self.args
        torch.manual_seed(a.seed)                         # identical init on every rank
        self.G = Generator(self.cond_dim, a.preset).to(self.device)
        self.G_ema = Generator(self.cond_dim, a.preset).to(self.device)
        self.G_ema.load_state_dict(self.G.state_dict())
        self.G_ema.eval().requires_grad_(False)
        self.D = None
        self.opt_d = None
        if a.objective == "ddgan":
            self.D = Discriminator(self.cond_dim if a.d_cond else 0, width=a.d_width).to(self.device)
            self.opt_d = torch.optim.Adam(self.D.parameters(), lr=self.lr_d, betas=tuple(a.betas))
        self.opt_g = torch.optim.Adam(self.G.parameters(), lr=self.lr_g, betas=tuple(a.betas))
        self.tables = ScheduleTables(self.supported, self.device, a.time_draw)
        g_fwd, d_fwd = self.G, self.D
        if a.compile:
            g_fwd = torch.compile(self.G, dynamic=True)
            d_fwd = torch.compile(self.D, dynamic=True) if self.D is not None else None
        self.nets = Nets(self.G, self.opt_g, self.D, self.opt_d, g_fwd, d_fwd, self.dist.average_grads,
                         torch.bfloat16 if a.amp == "bf16" else None)
        self.gan = GanWeights(a.geo_weight, a.adv_weight, a.r1_gamma, a.r1_every, a.geo_weight_t1)
        self._ema_pairs = (list(self.G_ema.parameters()), list(self.G.parameters()))

    def init_from(self, path: Path) -> None:
        st, self._init_st = self.init_state(), None    # read once; not kept after the weights are in G
        m = st["meta"]
        check_same_model(path, m, self.G.config(), self.args.task, self.args.objective,
                         "--init-weights needs the same")
        enc = (m.get("condition") or {}).get("encoder")
        if self.args.task == "text" and enc is not None and enc != self.args.encoder:
            raise CheckpointError(f"{path}: its text model reads {enc!r} embeddings, this run --encoder "
                                  f"{self.args.encoder!r}; --init-weights needs the same encoder")
        load_state_dict(path, self.G, st["G_ema"], "G_ema")
        self.G_ema.load_state_dict(st["G_ema"])
        bad = first_non_finite(self.G_ema)
        if bad is not None:
            raise CheckpointError(f"{path}: 'G_ema' weight {bad!r} holds NaN/Infinity; refusing to train on from it")
        prior = m.get("init") or {"steps": 0, "wall_s": 0.0, "runs": []}
        self.init = {"steps": prior["steps"] + int(st["step"]), "wall_s": prior["wall_s"] + float(st.get("wall", 0.0)),
                     "runs": prior["runs"] + [{"file": path.name, "steps": int(st["step"]), "device": m.get("device"),
                                                "batch": m.get("batch"), "weights_dtype": m.get("weights_dtype")}]}

    # -- batches -------------------------------------------------------------------------------------
    def next_batch(self) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        """(x0, mask, c) gathered on the device; the epoch's plan (order and crops) is uploaded once per epoch."""
        a = self.args
        epoch, row, _ = self.batcher.next_row()
        if epoch != self._plan_epoch:
            order = self.batcher.epoch_order()
            rng = np.random.default_rng([a.seed, epoch, self.dist.rank, 7])
            start, length = crop_plan(self.ms.lengths[order], a.random_crop, a.crop_min, rng)
            plan = torch.from_numpy(np.stack([order, start, length]))
            self._plan = plan.to(self.device)
            self._frames = length.max(1)                # host copy: the padded length of each batch
            self._plan_epoch = epoch
        frames = int(self._frames[row])
        if a.compile:                                   # fewer distinct shapes for the compiled graphs
            frames = min(-(-frames // 8) * 8, self.G.max_frames)
        idx, start, length = self._plan[:, row]
        x0, mask = self.clips.gather(idx, start, length, frames)
        return x0, mask, self.conditions(idx)

    def conditions(self, idx: torch.Tensor) -> torch.Tensor:
        b = idx.shape[0]
        if self.args.task == "text":
            c = self.text_emb[self.clips.pick_captions(idx)]
        else:
            c = self.action_onehot[idx]
        keep = (torch.rand(b, device=self.device) >= self.args.cond_drop).float()
        return c * keep[:, None]

    # -- one optimisation step ---------------------------------------------------------------------------
    def set_lr(self) -> tuple[float, float]:
        a = self.args
        lr_g = cosine_lr(self.step, a.steps, self.lr_g, a.lr_min, a.warmup)
        for grp in self.opt_g.param_groups:
            grp["lr"] = lr_g
        lr_d = 0.0
        if self.opt_d is not None:
            lr_d = cosine_lr(self.step, a.steps, self.lr_d, a.lr_min, a.warmup)
            for grp in self.opt_d.param_groups:
                grp["lr"] = lr_d
        return lr_g, lr_d

    def train_step(self) -> dict[str, torch.Tensor]:
        """One step; its loss terms as 0-d device tensors (the learning rates it used in ``self.lrs``)."""
        x0, mask, c = self.next_batch()
        self.lrs = self.set_lr()
        self.G.train()
        if self.args.objective == "diffusion":
            logs = diffusion_step(self.nets, self.geo, x0, mask, c)
        else:
            logs = ddgan_step(self.nets, self.geo, self.gan, self.tables, x0, mask, c, self.step)
        self.update_ema()
        return logs

    @torch.no_grad()
    def update_ema(self) -> None:
        decay = self.args.ema
        if self.args.ema_warmup:
            decay = min(decay, (1 + self.step) / (10 + self.step))
        ema, cur = self._ema_pairs
        torch._foreach_mul_(ema, decay)
        torch._foreach_add_(ema, cur, alpha=1 - decay)

    # -- checkpoints -----------------------------------------------------------------------------------
    def meta(self) -> dict:
        a = self.args
        return {
            "task": a.task, "objective": a.objective, "cond_dim": self.cond_dim,
            "condition": ({"type": "text", "encoder": a.encoder, "dim": self.cond_dim} if a.task == "text"
                          else {"type": "action", "labels": list(self.ms.action_labels), "dim": self.cond_dim}),
            "generator": self.G.config(), "supported_steps": self.supported,
            "mean": self.ms.mean.tolist(), "std": self.ms.std.tolist(),
            "dataset": self.data_dir.name, "data": self.data_id, "clips": len(self.ms), "device": self.device_name(),
            "world": self.dist.world, "batch": a.batch, "init": self.init,
            "lr": {"g": self.lr_g, "d": self.lr_d if self.D is not None else None, "scale": self.lr_scale},
            "sampling": {"balance_alpha": a.balance_alpha, "actions": self.sampling},
            "args": {k: (str(v) if isinstance(v, Path) else v) for k, v in vars(a).items()},
        }

    def device_name(self) -> str:
        if self.device.type == "cuda":
            return torch.cuda.get_device_name(self.device)
        return f"cpu ({torch.get_num_threads()} threads × {self.dist.world} processes)"

    def save(self) -> None:
        """Write ckpt.pt, after checking that no loss term has gone non-finite since the last check."""
        self.check_finite()
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
        self.saved_step = self.step

    def save_weights(self, path: Path, dtype: str = "float32") -> None:
        """The EMA generator and meta only (a checkpoint ``emdm.export.load_generator`` reads)."""
        self.check_finite()
        if not self.dist.main:
            return
        save_weights_file(path, self.G_ema.state_dict(), step=self.step, wall=self.wall, meta=self.meta(),
                          last_losses=self.last_losses, dtype=dtype)

    def check_finite(self) -> None:
        bad = self.steplog.first_non_finite(self.dist) if hasattr(self, "steplog") else None
        if bad is None:
            return
        step, terms = bad
        ckpt = self.args.out / "ckpt.pt"
        kept = (f"{ckpt} left as it was (step {self.saved_step})" if getattr(self, "saved_step", None) is not None
                else (f"{ckpt} left as it was" if ckpt.exists() else "no checkpoint written"))
        also = f" (then {', '.join(terms[1:])})" if len(terms) > 1 else ""
        raise NonFiniteLoss(f"step {step}: loss term {terms[0]} is not finite{also}; stopped, {kept}")

    def load(self, path: Path) -> None:
        st = load_file(path, TRAIN_KEYS, map_location=self.device)
        check_same_model(path, st["meta"], self.G.config(), self.args.task, self.args.objective,
                         "use another --out or --no-resume")
        self.check_same_data(path, st["meta"])
        for key, module in (("G", self.G), ("G_ema", self.G_ema), ("opt_g", self.opt_g), ("D", self.D),
                            ("opt_d", self.opt_d)):
            if module is not None:
                load_state_dict(path, module, st[key], key)
        for key, module in (("G", self.G), ("G_ema", self.G_ema), ("D", self.D)):
            bad = first_non_finite(module)
            if bad is not None:
                raise CheckpointError(f"{path}: {key!r} weight {bad!r} holds NaN/Infinity; refusing to resume from it "
                                      "(use --no-resume, or --init-weights an earlier good weights file)")
        self.step, self.wall, self.last_losses = st["step"], st["wall"], st.get("last_losses", {})
        try:
            self.batcher.load_state(st["batcher"][0])
        except (ValueError, KeyError, TypeError, IndexError) as e:
            raise CheckpointError(f"{path}: data order: {e}") from e
        rng = st["rng"][self.dist.rank] if self.dist.rank < len(st["rng"]) else st["rng"][0]
        torch.set_rng_state(rng["torch"].cpu())          # map_location may have moved it to the GPU
        if rng.get("cuda") is not None and self.device.type == "cuda":
            torch.cuda.set_rng_state_all([s.cpu() for s in rng["cuda"]])
        self.saved_step = self.step
        if self.dist.main:
            print(f"resumed {path} at step {self.step}", file=sys.stderr)

    def check_same_data(self, path: Path, meta: dict) -> None:
        """CheckpointError if the checkpoint was trained on another dataset than --data (unless --allow-other-data)."""
        if self.args.allow_other_data:
            return
        old = meta.get("data")
        if isinstance(old, dict):
            same = old.get("sha256") == self.data_id["sha256"]
            was = f"{old.get('path')} (sha256 {str(old.get('sha256'))[:12]})"
        else:                                          # a checkpoint from before the identity was recorded: the name
            same = meta.get("dataset") == self.data_dir.name
            was = f"a dataset named {meta.get('dataset')!r}"
        if not same:
            raise CheckpointError(f"{path}: trained on {was}, but --data is {self.data_dir} (sha256 "
                                  f"{self.data_id['sha256'][:12]}); give the same --data, or --allow-other-data to go on "
                                  "with this one")

    # -- loop ------------------------------------------------------------------------------------------
    def describe(self) -> None:
        a = self.args
        print(f"G {count_parameters(self.G):,} params, D {count_parameters(self.D) if self.D else 0:,}; "
              f"{len(self.ms)} clips; device {self.device_name()}; batch {a.batch}×{self.dist.world}, "
              f"LR G {self.lr_g:.3g} D {self.lr_d:.3g} (×{self.lr_scale:.3g}, --lr-scale {a.lr_scale}); "
              f"amp {a.amp}{', compiled' if a.compile else ''}", file=sys.stderr)
        rows = self.sampling

        def fmt(r: dict) -> str:
            return f"{r['action']} {100 * r['share']:.1f}% ({r['clips']} clips; α=1: {100 * r['share_clips']:.1f}%)"
        listed = ("; ".join(map(fmt, rows)) if len(rows) <= 8 else
                  "top " + "; ".join(map(fmt, rows[:4])) + " … bottom " + "; ".join(map(fmt, rows[-4:])))
        print(f"sampling: --balance-alpha {a.balance_alpha} over {len(rows)} actions: {listed}", file=sys.stderr)

    def run(self) -> None:
        a = self.args
        a.out.mkdir(parents=True, exist_ok=True)      # only now: a run refused while setting up leaves no folder
        log_path = a.out / "log.csv"
        new_log = not log_path.exists() or self.step == 0
        fields = LOG_FIELDS
        if not new_log:              # appending: keep the columns the file already has (an older run's log)
            if self.dist.main:       # rows logged after the checkpoint (a killed run) are logged again from here
                truncate_log(log_path, self.step)
            with open(log_path, newline="") as f:
                fields = next(csv.reader(f), None) or LOG_FIELDS
        logf = open(log_path, "w" if new_log else "a", newline="") if self.dist.main else None
        writer = csv.DictWriter(logf, fieldnames=fields) if logf else None
        if writer and new_log:
            writer.writeheader()
        if self.dist.main:
            self.describe()
        bar = None
        if a.progress and self.dist.main:
            from tqdm import tqdm
            bar = tqdm(total=a.steps, initial=self.step, mininterval=5.0, dynamic_ncols=True, file=sys.stderr)
        stop_at = min(a.steps, a.stop_at) if a.stop_at is not None else a.steps
        t_start, t_ckpt = time.time(), time.time()
        t_weights = t_start
        wall0 = self.wall
        self.steplog = StepLog(self.device)
        n_log, lr_sum, t_log = 0, np.zeros(2), time.time()
        try:
            while self.step < stop_at:
                logs = self.train_step()
                self.step += 1
                self.steplog.add(self.step, logs)
                n_log += 1
                lr_sum += self.lrs
                self.wall = wall0 + time.time() - t_start
                if bar:
                    bar.update(1)
                if self.step % a.log_every == 0 or self.step == stop_at:
                    means = self.dist.mean_scalars(self.steplog.means())
                    means.update(lr_g=lr_sum[0] / n_log, lr_d=lr_sum[1] / n_log,
                                 sec_per_step=(time.time() - t_log) / max(n_log, 1))
                    n_log, lr_sum, t_log = 0, np.zeros(2), time.time()
                    self.last_losses = {k: round(v, 6) for k, v in means.items() if not k.startswith("lr")}
                    if writer:
                        writer.writerow({"step": self.step, "epoch": self.batcher.epoch, "wall_s": round(self.wall, 1),
                                         **{k: f"{v:.6g}" for k, v in means.items() if k in fields}})
                        logf.flush()
                    if bar:
                        bar.set_postfix({k: f"{means[k]:.3g}" for k in ("loss_d", "g_adv", "recon") if k in means})
                    self.check_finite()
                    if a.weights_out is not None and a.weights_minutes is not None \
                            and time.time() - t_weights >= a.weights_minutes * 60:
                        self.save_weights(a.weights_out, a.weights_dtype)
                        t_weights = time.time()
                        if self.dist.main:
                            print(f"weights at step {self.step} -> {a.weights_out}", file=sys.stderr)
                timed_out, due = False, bool(a.ckpt_every and self.step % a.ckpt_every == 0)
                if self.dist.world == 1 or self.step % a.log_every == 0:     # DDP: the clocks agreed on at log steps
                    timed_out = a.time_limit_min is not None and (time.time() - t_start) > a.time_limit_min * 60
                    due = due or (time.time() - t_ckpt) > a.ckpt_minutes * 60
                if self.dist.world > 1 and self.step % a.log_every == 0:    # all ranks must agree (save gathers RNG)
                    flag = self.dist.all_reduce(torch.tensor([float(bool(due)), float(bool(timed_out))],
                                                             device=self.device), torch.distributed.ReduceOp.MAX)
                    due, timed_out = (bool(v) for v in flag.tolist())
                if due or timed_out or self.step == stop_at:
                    self.save()
                    t_ckpt = time.time()
                if timed_out:
                    if self.dist.main:
                        print(f"time limit reached at step {self.step}", file=sys.stderr)
                    break
        finally:
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
    """Train; 0 on success, 2 (one line on stderr) for an unusable checkpoint, dataset or output or a NaN loss."""
    parser = build_parser()
    args = parser.parse_args(argv)
    check_args(parser, args)
    made, trainer = missing_folders(args.out), None
    try:
        check_writable(args.out, folder=True, option="--out")
        if args.weights_out is not None:
            check_writable(args.weights_out, option="--weights-out")
        trainer = Trainer(args)
        trainer.run()
        if args.weights_out is not None:
            trainer.save_weights(args.weights_out, args.weights_dtype)
    except (CheckpointError, DatasetError, NonFiniteLoss, OutputRefused) as e:
        print(f"emdm.train: {e}", file=sys.stderr)
        return 2
    finally:
        if trainer is not None:
            trainer.dist.close()
        elif os.environ.get("RANK", "0") == "0":   # Trainer(args) failed: the --out folders it made go, with its cache
            remove_made_folders(made, ours=("text-*.npy",))
    ckpt = args.out / "ckpt.pt"
    if trainer.dist.main:
        print((f"checkpoint {ckpt} (step {trainer.step})" if ckpt.is_file() else "no checkpoint written")
              + (f"; weights {args.weights_out}" if args.weights_out is not None else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
