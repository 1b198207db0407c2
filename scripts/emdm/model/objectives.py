"""The two training objectives of ``emdm.train``, one optimisation step each, on a batch already on the device.

  ddgan      alternate D and G updates. D: softplus(−D(real)) + softplus(D(fake)), lazy R1 on the real x_k
             (γ ``--r1-gamma`` every ``--r1-every`` steps). G: softplus(−D(fake)) + R·L_geo with
             L_geo = L_recon + λ(w_pos L_pos + w_vel L_vel + w_foot L_foot + w_bone L_bone). Each sample draws a
             step count T from the supported set and k ∈ 0..T−1; G sees the continuous time t_{k+1}.
  diffusion  the same transformer on the plain x0 objective at t ~ U(ε, 1) (z = 0), sampled with DDIM.

The pairs (x_k, x_{k+1}) come from the forward process of :mod:`emdm.sampler.schedule` and the fake x_k from its
posterior q(x_k | x_{k+1}, x̂_0) — exactly the transition ``emdm.sampler.sample_features`` takes (a test holds the
two together). Every step function returns its loss terms as 0-d tensors still on the device (no host sync).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Callable

import torch
import torch.nn.functional as F

from emdm.model.geometry import geometric_losses
from emdm.sampler.schedule import EPS_SMALL, make_schedule, marginal_coeffs

TABLE_KEYS = ("time", "time_prev", "coef1", "coef2", "sigma", "a_cum", "s_cum", "a_step", "s_step")


class ScheduleTables:
    """Per-T schedule coefficients stacked so a batch can mix step counts: index [T slot, i]."""

    def __init__(self, steps: list[int], device: torch.device, draw: str = "steps"):
        if draw not in ("steps", "pairs"):
            raise ValueError(f"time draw must be 'steps' or 'pairs', got {draw!r}")
        self.steps, self.mode = list(steps), draw
        n = max(steps) + 1
        tab = {k: torch.zeros(len(steps), n, dtype=torch.float32) for k in TABLE_KEYS}
        for i, T in enumerate(steps):
            s = make_schedule(T)
            for k in TABLE_KEYS:
                v = torch.tensor(getattr(s, k), dtype=torch.float32)
                tab[k][i, : len(v)] = v
        self.tab = {k: v.to(device) for k, v in tab.items()}
        self.steps_t = torch.tensor(self.steps, dtype=torch.int64, device=device)
        self.pair_w = self.steps_t.double() / sum(self.steps)

    def draw(self, b: int, device: torch.device) -> tuple[torch.Tensor, torch.Tensor]:
        """(slot, k) per sample, device RNG. "steps": T uniform over the supported step counts, then k uniform in
        0..T−1 (t = 1 gets 36 % of the samples for 1,2,4,5,8,10, and 10 steps' t = 0.9 only 1.7 %); "pairs": every
        (T, k) equally likely (t = 1: 20 %, t = 0.9: 3.3 %)."""
        if self.mode == "pairs":
            slot = torch.multinomial(self.pair_w, b, replacement=True)
        else:
            slot = torch.randint(len(self.steps), (b,), device=device)
        T = self.steps_t[slot]
        k = torch.minimum((torch.rand(b, device=device) * T).long(), T - 1)
        return slot, k

    def get(self, name: str, slot: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
        return self.tab[name][slot, idx]


def bcast(v: torch.Tensor) -> torch.Tensor:
    return v[:, None, None]


def masked_mse(a: torch.Tensor, b: torch.Tensor, mask: torch.Tensor, scale: torch.Tensor | None = None) -> torch.Tensor:
    """Mean squared error over the frames of ``mask`` (B, L); ``scale`` (B,): each sample's frames count that many
    times in the sum (the divisor stays the frames' count)."""
    err = ((a - b) ** 2).mean(-1) * mask
    if scale is not None:
        err = err * scale[:, None]
    return err.sum() / mask.sum().clamp_min(1.0)


def pairs(tables: ScheduleTables, x0: torch.Tensor, mask: torch.Tensor):
    """Forward-process pairs: x_k ~ q(x_k | x_0), x_{k+1} ~ q(x_{k+1} | x_k); (x_k, x_{k+1}, slot, k)."""
    slot, k = tables.draw(x0.shape[0], x0.device)
    g = tables.get
    x_k = bcast(g("a_cum", slot, k)) * x0 + bcast(g("s_cum", slot, k)) * torch.randn_like(x0)
    x_k1 = bcast(g("a_step", slot, k + 1)) * x_k + bcast(g("s_step", slot, k + 1)) * torch.randn_like(x0)
    m = mask.unsqueeze(-1)
    return x_k * m, x_k1 * m, slot, k


def posterior(tables: ScheduleTables, x0_pred: torch.Tensor, x_k1: torch.Tensor, slot, k, mask,
              noise: torch.Tensor | None = None) -> torch.Tensor:
    """x_k ~ q(x_k | x_{k+1}, x̂_0) = coef1·x̂_0 + coef2·x_{k+1} + σ·ε (σ = 0 at k = 0): the sampler's update."""
    g = tables.get
    x = bcast(g("coef1", slot, k)) * x0_pred + bcast(g("coef2", slot, k)) * x_k1
    x = x + bcast(g("sigma", slot, k)) * (torch.randn_like(x) if noise is None else noise)
    return x * mask.unsqueeze(-1)


@dataclass
class Geo:
    """L_geo's weights and the de-normalisation the joint terms need (mean/std on the device)."""
    mean: torch.Tensor
    std: torch.Tensor
    lambda_geo: float = 1.0
    w_pos: float = 1.0
    w_vel: float = 1.0
    w_foot: float = 1.0
    w_bone: float = 0.0

    def terms(self, x0_pred: torch.Tensor, x0: torch.Tensor, mask: torch.Tensor,
              scale: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
        """Each term's batch mean; ``scale`` (B,) weights each sample's share (GanWeights.geo_scale)."""
        x0_pred = x0_pred.float()                     # the losses in float32 also under bf16 autocast
        out = {"recon": masked_mse(x0_pred, x0, mask, scale)}
        if self.lambda_geo > 0 and (self.w_pos or self.w_vel or self.w_foot or self.w_bone):
            with _no_autocast(x0.device):
                out.update(geometric_losses(x0_pred * self.std + self.mean, x0 * self.std + self.mean, mask, scale))
        return out

    def total(self, terms: dict[str, torch.Tensor]) -> torch.Tensor:
        total = terms["recon"]
        if "pos" in terms:
            total = total + self.lambda_geo * (self.w_pos * terms["pos"] + self.w_vel * terms["vel"]
                                               + self.w_foot * terms["foot"] + self.w_bone * terms["bone"])
        return total


@dataclass
class Nets:
    """What one step updates. ``g_fwd``/``d_fwd`` are the forward functions (compiled or the modules themselves);
    ``sync_grads(module)`` averages gradients over DDP ranks; ``autocast`` the mixed-precision context."""
    G: torch.nn.Module
    opt_g: torch.optim.Optimizer
    D: torch.nn.Module | None = None
    opt_d: torch.optim.Optimizer | None = None
    g_fwd: Callable | None = None
    d_fwd: Callable | None = None
    sync_grads: Callable[[torch.nn.Module], None] = lambda m: None
    amp: torch.dtype | None = None

    def __post_init__(self):
        self.g_fwd = self.G if self.g_fwd is None else self.g_fwd
        self.d_fwd = self.D if self.d_fwd is None else self.d_fwd

    def autocast(self, device: torch.device):
        if self.amp is None:
            return contextlib.nullcontext()
        return torch.autocast(device_type=device.type, dtype=self.amp)


def _no_autocast(device: torch.device):
    return torch.autocast(device_type=device.type, enabled=False)


def diffusion_step(nets: Nets, geo: Geo, x0: torch.Tensor, mask: torch.Tensor, c: torch.Tensor) -> dict[str, torch.Tensor]:
    b, dev = x0.shape[0], x0.device
    t = torch.rand(b, device=dev) * (1 - EPS_SMALL) + EPS_SMALL
    a_t, s_t = marginal_coeffs(t)
    x_t = (bcast(a_t) * x0 + bcast(s_t) * torch.randn_like(x0)) * mask.unsqueeze(-1)
    with nets.autocast(dev):
        x0_pred = nets.g_fwd(x_t, torch.zeros(b, nets.G.z_dim, device=dev), c, t, mask)
    terms = geo.terms(x0_pred, x0, mask)
    loss_g = geo.total(terms)
    nets.opt_g.zero_grad(set_to_none=True)
    loss_g.backward()
    nets.sync_grads(nets.G)
    nets.opt_g.step()
    return {**{k: v.detach() for k, v in terms.items()}, "loss_g": loss_g.detach()}


@dataclass
class GanWeights:
    geo_weight: float = 100.0      # R
    adv_weight: float = 1.0
    r1_gamma: float = 0.02
    r1_every: int = 15
    geo_weight_t1: float | None = None   # R at t = 1 (None: R at every t); between, R^(1−t)·R1^t

    def geo_scale(self, t: torch.Tensor) -> torch.Tensor | None:
        """Per sample (t: its step's time, (B,)), the factor on R that gives R^(1−t)·geo_weight_t1^t: 1 at t = 0,
        geo_weight_t1 / R at t = 1, geometric between. None where the weight is the same at every t."""
        if self.geo_weight_t1 is None or self.geo_weight_t1 == self.geo_weight:
            return None
        return (self.geo_weight_t1 / self.geo_weight) ** t.float()


def ddgan_step(nets: Nets, geo: Geo, w: GanWeights, tables: ScheduleTables, x0: torch.Tensor, mask: torch.Tensor,
               c: torch.Tensor, step: int) -> dict[str, torch.Tensor]:
    """One D update then one G update on the batch (x0, mask, c); ``step`` (0-based) decides the lazy R1."""
    b, dev = x0.shape[0], x0.device
    G, D = nets.G, nets.D
    # ---- D step
    D.requires_grad_(True)
    x_k, x_k1, slot, k = pairs(tables, x0, mask)
    t_cur, t_prev = tables.get("time", slot, k), tables.get("time_prev", slot, k)
    do_r1 = w.r1_gamma > 0 and w.r1_every > 0 and step % w.r1_every == 0
    x_k.requires_grad_(do_r1)
    with nets.autocast(dev):
        # R1 needs a double backward, which compiled graphs do not support: the eager D on those steps
        d_real = (D if do_r1 else nets.d_fwd)(x_k, x_k1, c, t_cur, t_prev, mask).float()
    loss_real = F.softplus(-d_real).mean()
    logs: dict[str, torch.Tensor] = {}
    r1 = torch.zeros((), device=dev)
    if do_r1:
        (grad,) = torch.autograd.grad(d_real.sum(), x_k, create_graph=True)
        r1 = w.r1_gamma / 2 * grad.float().pow(2).reshape(b, -1).sum(1).mean()
        logs["r1"] = r1.detach()
    with torch.no_grad(), nets.autocast(dev):
        z = torch.randn(b, G.z_dim, device=dev)
        fake = posterior(tables, nets.g_fwd(x_k1, z, c, t_cur, mask).float(), x_k1, slot, k, mask)
    with nets.autocast(dev):
        d_fake = nets.d_fwd(fake, x_k1, c, t_cur, t_prev, mask).float()
    loss_fake = F.softplus(d_fake).mean()
    loss_d = loss_real + loss_fake + r1
    nets.opt_d.zero_grad(set_to_none=True)
    loss_d.backward()
    nets.sync_grads(D)
    nets.opt_d.step()
    logs.update(loss_d=(loss_real + loss_fake).detach(), d_real=d_real.detach().mean(), d_fake=d_fake.detach().mean())

    # ---- G step
    D.requires_grad_(False)
    x_k, x_k1, slot, k = pairs(tables, x0, mask)
    t_cur, t_prev = tables.get("time", slot, k), tables.get("time_prev", slot, k)
    z = torch.randn(b, G.z_dim, device=dev)
    with nets.autocast(dev):
        x0_pred = nets.g_fwd(x_k1, z, c, t_cur, mask).float()
        fake = posterior(tables, x0_pred, x_k1, slot, k, mask)
        g_adv = F.softplus(-nets.d_fwd(fake, x_k1, c, t_cur, t_prev, mask).float()).mean()
    loss_g = w.adv_weight * g_adv
    terms: dict[str, torch.Tensor] = {}
    if w.geo_weight > 0:
        terms = geo.terms(x0_pred, x0, mask, w.geo_scale(t_cur))   # with geo_weight_t1 logged as weighted per sample
        loss_g = loss_g + w.geo_weight * geo.total(terms)
    nets.opt_g.zero_grad(set_to_none=True)
    loss_g.backward()
    nets.sync_grads(G)
    nets.opt_g.step()
    logs.update({k_: v.detach() for k_, v in terms.items()})
    logs.update(loss_g=loss_g.detach(), g_adv=g_adv.detach())
    return logs
