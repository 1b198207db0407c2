"""Differentiable torch port of ``emdm.motion.features.recover_joints`` (features → joint positions),
plus the geometric losses EMDM adds to the DDGAN generator loss.

The recovery uses only features [0:67] and follows emdm.motion.features exactly (half-angle root
rotation velocity, root xz velocity in the root frame of the next frame, Ry right-handed about +Y).
All functions take batched de-normalised features (B, L, 263) and a frame mask (B, L).
"""

from __future__ import annotations

import torch

from emdm.skeleton import PARENTS

FOOT_JOINTS = (7, 10, 8, 11)       # l_ankle, l_foot, r_ankle, r_foot == contact channels 259..262
CONTACT_CHANNELS = slice(259, 263)


def rot_y(angle: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """Rotate v (..., 3) about +Y by angle (broadcast to v[..., 0]); same as features.rot_y."""
    c, s = torch.cos(angle), torch.sin(angle)
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    return torch.stack([c * x + s * z, y, -s * x + c * z], dim=-1)


def recover_root(feats: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """(B, N, ≥4) → theta (B, N), root (B, N, 3) with theta_0 = 0 and root_xz_0 = 0."""
    a = torch.cumsum(feats[..., 0], dim=-1) - feats[..., 0]          # exclusive cumsum: a_t = Σ_{k<t} f[k,0]
    theta = -2.0 * a
    zeros = torch.zeros_like(feats[..., :1, 1])
    sx = torch.cat([zeros, feats[..., :-1, 1]], dim=-1)
    sz = torch.cat([zeros, feats[..., :-1, 2]], dim=-1)
    step = torch.stack([sx, torch.zeros_like(sx), sz], dim=-1)
    root = torch.cumsum(rot_y(theta, step), dim=-2)
    root = torch.stack([root[..., 0], feats[..., 3], root[..., 2]], dim=-1)
    return theta, root


def recover_joints(feats: torch.Tensor) -> torch.Tensor:
    """(..., N, ≥67) features → (..., N, 22, 3) joints. Matches the numpy recover_joints."""
    if feats.shape[-1] < 67:
        raise ValueError(f"recover_joints: expected feature dim ≥ 67 (263), got {feats.shape[-1]}")
    theta, root = recover_root(feats)
    rel = feats[..., 4:67].reshape(*feats.shape[:-1], 21, 3)
    world = rot_y(theta.unsqueeze(-1), rel)
    offset = torch.stack([root[..., 0], torch.zeros_like(root[..., 0]), root[..., 2]], dim=-1).unsqueeze(-2)
    return torch.cat([root.unsqueeze(-2), world + offset], dim=-2)


def _masked_mean(err: torch.Tensor, weight: torch.Tensor, scale: torch.Tensor | None = None) -> torch.Tensor:
    """Mean of err (B, N, ...) over entries where weight (B, N) (broadcast) is nonzero; with ``scale`` (B,), each
    sample's entries count ``scale`` times in the sum (the divisor stays the entries' count, so scale 1 is the mean)."""
    while weight.dim() < err.dim():
        weight = weight.unsqueeze(-1)
    w = weight.expand_as(err)
    num = err * w
    if scale is not None:
        num = num * scale.reshape(-1, *([1] * (err.dim() - 1)))
    return num.sum() / w.sum().clamp_min(1.0)


def bone_lengths(joints: torch.Tensor) -> torch.Tensor:
    """(..., 22, 3) joints → (..., 21) lengths of the bones joint j ← PARENTS[j], j = 1..21."""
    return torch.linalg.vector_norm(joints[..., 1:, :] - joints[..., PARENTS[1:], :], dim=-1)


def geometric_losses(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor,
                     scale: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
    """L_pos, L_vel, L_foot, L_bone on de-normalised features (B, L, 263) with mask (B, L); ``scale`` (B,) weights
    each sample's share (``_masked_mean``; None: every sample alike).

    pos: MSE of recovered joints (m²); vel: MSE of joint velocities between consecutive real frames;
    foot: squared velocity of the predicted foot joints on the target's contact frames (MDM's foot loss);
    bone: squared relative error of the predicted bone lengths against the target's (a rigidity term this
    project adds, off in the paper's recipe: the 263-d features carry joint positions with nothing that keeps
    a forearm one length, and unlike L_pos it asks nothing of the pose, so it holds at every noise level).
    """
    jp, jt = recover_joints(pred), recover_joints(target)
    bt = bone_lengths(jt)
    bone = _masked_mean((bone_lengths(jp) / bt.clamp_min(1e-3) - 1.0) ** 2, mask, scale)
    pos = _masked_mean((jp - jt) ** 2, mask, scale)
    pair = mask[:, 1:] * mask[:, :-1]
    vp, vt = jp[:, 1:] - jp[:, :-1], jt[:, 1:] - jt[:, :-1]
    vel = _masked_mean((vp - vt) ** 2, pair, scale)
    contact = (target[:, :-1, CONTACT_CHANNELS] > 0.5).float() * pair.unsqueeze(-1)     # (B, L-1, 4)
    foot_v = vp[:, :, list(FOOT_JOINTS)]                                                 # (B, L-1, 4, 3)
    foot = _masked_mean(foot_v ** 2, contact, scale)
    return {"pos": pos, "vel": vel, "foot": foot, "bone": bone}
