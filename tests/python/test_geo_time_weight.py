"""--geo-weight-t1: L_geo's weight changes with the step's time t, R^(1−t)·R1^t per sample (GanWeights.geo_scale on
top of R), so the noisiest steps can lean on the discriminator instead of the mean motion MSE asks for."""

import csv

import numpy as np
import pytest
import torch

from emdm.model.geometry import geometric_losses
from emdm.model.objectives import GanWeights, masked_mse
from emdm.motion.features import extract_features
from emdm.train import main as train_main
from model_synth_data import synth_clip, write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--log-every", "1", "--no-progress"]


def test_geo_scale_interpolates_geometrically_from_r_at_t0_to_r1_at_t1():
    t = torch.tensor([0.0, 0.5, 1.0])
    s = GanWeights(geo_weight=100.0, geo_weight_t1=10.0).geo_scale(t)
    assert torch.allclose(100.0 * s, torch.tensor([100.0, 10 ** 1.5, 10.0]))
    assert GanWeights(geo_weight=100.0).geo_scale(t) is None                       # the recipe as before
    assert GanWeights(geo_weight=30.0, geo_weight_t1=30.0).geo_scale(t) is None


def _pair(seed: int):
    feats = torch.from_numpy(extract_features(synth_clip(50, 0, np.random.default_rng(seed))))[None].float()
    return feats + 0.05 * torch.randn_like(feats), feats


def test_a_samples_scale_multiplies_its_share_of_every_term():
    (p1, t1), (p2, t2) = _pair(4), _pair(5)
    pred, target, mask = torch.cat([p1, p2]), torch.cat([t1, t2]), torch.ones(2, p1.shape[1])
    plain = geometric_losses(pred, target, mask)
    ones = geometric_losses(pred, target, mask, torch.ones(2))
    first = geometric_losses(p1, t1, mask[:1])
    only_first = geometric_losses(pred, target, mask, torch.tensor([1.0, 0.0]))
    doubled = geometric_losses(pred, target, mask, torch.tensor([2.0, 2.0]))
    for k in ("pos", "vel", "foot", "bone"):
        assert torch.equal(plain[k], ones[k]), k
        assert torch.allclose(doubled[k], 2 * plain[k]), k
        # the divisor stays both samples' entries: the first alone, counted over twice the entries, is half its mean
        # (the foot term's divisor is its contact frames, which differ between the clips: only pos/vel/bone exactly)
        if k != "foot":
            assert torch.allclose(only_first[k], first[k] / 2, rtol=1e-5), k
    assert torch.allclose(masked_mse(pred, target, mask, torch.tensor([1.0, 0.0])),
                          masked_mse(p1, t1, mask[:1]) / 2, rtol=1e-6)
    assert torch.equal(masked_mse(pred, target, mask, torch.ones(2)), masked_mse(pred, target, mask))


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def _loss_g(run) -> list[float]:
    with open(run / "log.csv") as f:
        return [float(r["loss_g"]) for r in csv.DictReader(f)]


def test_one_step_training_with_r1_equals_training_with_r_set_to_r1(dataset, tmp_path):
    """Every sample of a one-step recipe is at t = 1, so R = 100 with R1 = 10 is R = 10: the same losses and the
    same weights, step for step."""
    runs = {}
    for name, flags in (("t1", ["--geo-weight", "100", "--geo-weight-t1", "10"]), ("r10", ["--geo-weight", "10"])):
        runs[name] = tmp_path / name
        assert train_main(["--data", str(dataset), "--task", "action", "--out", str(runs[name]), "--steps", "3",
                           "--supported-steps", "1", "--seed", "3", *TINY, *flags]) == 0
    a, b = _loss_g(runs["t1"]), _loss_g(runs["r10"])
    assert len(a) == 3 and np.allclose(a, b, rtol=1e-5), (a, b)
    ga = torch.load(runs["t1"] / "ckpt.pt", weights_only=True)
    gb = torch.load(runs["r10"] / "ckpt.pt", weights_only=True)
    assert ga["meta"]["args"]["geo_weight_t1"] == 10.0 and gb["meta"]["args"]["geo_weight_t1"] is None
    # Adam moves each weight by about the learning rate per step (3e-5 here) whatever its gradient's size, so a float
    # rounding apart (R·0.1 against 10) shows as up to ~1e-6 on a weight; a different weight would show ~1e-4
    worst = max(float((ga["G"][k] - gb["G"][k]).abs().max()) for k in ga["G"])
    assert worst < 1e-5, worst


@pytest.mark.parametrize("flags, said", [(["--geo-weight-t1", "0"], "needs a number > 0"),
                                         (["--geo-weight-t1", "10", "--geo-weight", "0"], "--geo-weight > 0"),
                                         (["--geo-weight-t1", "10", "--objective", "diffusion"], "ddgan objective")])
def test_unusable_r1_is_refused_naming_the_flag(dataset, tmp_path, capsys, flags, said):
    with pytest.raises(SystemExit) as e:
        train_main(["--data", str(dataset), "--task", "action", "--out", str(tmp_path / "r"), "--steps", "1", *TINY,
                    *flags])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "--geo-weight-t1" in err and said in err, err
    assert not (tmp_path / "r").exists()
