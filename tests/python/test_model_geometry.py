import numpy as np
import pytest
import torch

from emdm.model.geometry import geometric_losses, recover_joints
from emdm.motion.features import extract_features, recover_joints as recover_np
from model_synth_data import synth_clip


def test_torch_recovery_equals_numpy_on_a_motion():
    joints = synth_clip(80, 2, np.random.default_rng(1))          # walking while turning
    feats = extract_features(joints)
    got = recover_joints(torch.from_numpy(feats).double()[None])[0].numpy()
    np.testing.assert_allclose(got, recover_np(feats), atol=1e-9)
    np.testing.assert_allclose(got, joints[:-1], atol=1e-4)       # and it is the original motion


def test_torch_recovery_equals_numpy_on_arbitrary_features_batched():
    f = np.random.default_rng(0).normal(size=(3, 40, 263)) * 0.4
    got = recover_joints(torch.from_numpy(f))
    np.testing.assert_allclose(got.numpy(), np.stack([recover_np(x) for x in f]), atol=1e-12)


def test_real_dataset_clips_recover_their_joints(real_dataset):
    # every clip of a small dataset prepared from the shared mocap (conftest.real_dataset): the torch recovery
    # used by L_geo gives back the joints prepare wrote, on real motion (turns, bends, all three sources)
    ids = [cid for split in ("train", "val", "test") for cid in (real_dataset / f"{split}.txt").read_text().split()]
    assert len(ids) >= 10, f"{real_dataset}: only {len(ids)} clips prepared"
    worst = (0.0, "")
    for cid in ids:
        feats = np.load(real_dataset / "new_joint_vecs" / f"{cid}.npy")
        joints = np.load(real_dataset / "new_joints" / f"{cid}.npy")
        got = recover_joints(torch.from_numpy(feats).double()[None])[0].numpy()
        err = float(np.abs(got - joints[: len(feats)]).max())
        worst = max(worst, (err, cid))
    assert worst[0] < 1e-4, f"clip {worst[1]}: recovered joints off by {worst[0] * 1000:.2f} mm"


def test_geometric_losses_vanish_for_the_truth_and_have_gradients():
    feats = torch.from_numpy(extract_features(synth_clip(60, 0, np.random.default_rng(2))))[None].float()
    mask = torch.ones(1, feats.shape[1])
    zero = geometric_losses(feats, feats, mask)
    assert float(zero["pos"]) < 1e-10 and float(zero["vel"]) < 1e-10 and float(zero["bone"]) < 1e-10
    # the truth's feet move less than the contact threshold (0.002 m² per frame) on contact frames
    assert 0 <= float(zero["foot"]) < 0.002 / 3
    pred = (feats + 0.05 * torch.randn_like(feats)).requires_grad_(True)
    losses = geometric_losses(pred, feats, mask)
    assert float(losses["pos"]) > 0 and float(losses["vel"]) > 0 and float(losses["foot"]) > float(zero["foot"])
    assert float(losses["bone"]) > 0
    sum(losses.values()).backward()
    assert torch.isfinite(pred.grad).all() and pred.grad.abs().sum() > 0


def test_padding_is_ignored_by_the_losses():
    feats = torch.from_numpy(extract_features(synth_clip(60, 0, np.random.default_rng(3))))[None].float()
    mask = torch.ones(1, feats.shape[1])
    mask[:, 40:] = 0
    pred = feats.clone()
    pred[:, 41:] += 10.0                    # garbage only in the padding (frame 40 is the first pad frame,
    losses = geometric_losses(pred, feats, mask)   # its velocity pair with frame 39 is masked too)
    truth = geometric_losses(feats, feats, mask)
    for k in ("pos", "vel", "foot", "bone"):
        assert abs(float(losses[k]) - float(truth[k])) < 1e-10, k


def test_bone_loss_is_the_squared_relative_length_error_and_ignores_the_pose():
    feats = torch.from_numpy(extract_features(synth_clip(60, 1, np.random.default_rng(4))))[None].double()
    mask = torch.ones(1, feats.shape[1], dtype=torch.double)
    # the body scaled by 1.1 about the root's floor point (root height and the joints' xz-relative, y-absolute
    # positions): every bone is 10% long, so L_bone = 0.01 exactly
    longer = feats.clone()
    longer[..., 3:67] *= 1.1
    # the same skeleton turned about the vertical through the root: a different pose, bones unchanged, L_bone = 0 while L_pos is not
    rel = feats[..., 4:67].reshape(1, -1, 21, 3)
    c, s = np.cos(0.7), np.sin(0.7)
    turned = feats.clone()
    turned[..., 4:67] = torch.stack([c * rel[..., 0] + s * rel[..., 2], rel[..., 1], -s * rel[..., 0] + c * rel[..., 2]],
                                    dim=-1).reshape(1, -1, 63)
    assert abs(float(geometric_losses(longer, feats, mask)["bone"]) - 0.01) < 1e-9
    got = geometric_losses(turned, feats, mask)
    assert float(got["bone"]) < 1e-12 and float(got["pos"]) > 1e-3
