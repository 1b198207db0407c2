"""python -m emdm.train_gradients: each geometric term's gradient norm as the recipe weights it. Known answers: a
term's norm doubles with its weight and no other term's moves; with λ = 0 the joint terms pull nothing; the figures
come out of real batches of the training loader (the same seed, the same numbers)."""

import json

import pytest

from emdm import train_gradients
from emdm.train import main as train_main
from model_synth_data import write_synthetic_dataset

TINY = ["--preset", "tiny", "--d-width", "32", "--batch", "4", "--threads", "1", "--no-progress", "--task", "action",
        "--device", "cpu", "--w-bone", "10"]


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return write_synthetic_dataset(tmp_path_factory.mktemp("ds"), n_clips=12)


def run(dataset, tmp_path, *flags, name="g.json"):
    out = tmp_path / name
    rc = train_gradients.main(["--data", str(dataset), "--out", str(tmp_path / "cache"), "--batches", "3",
                               "--json", str(out), *TINY, *flags])
    assert rc == 0
    return json.loads(out.read_text())


def grads(res, group="all"):
    return {k: v["grad"] for k, v in res["groups"][group]["terms"].items()}


def test_a_terms_norm_follows_its_weight_and_no_other(dataset, tmp_path, capsys):
    one = run(dataset, tmp_path, "--w-foot", "1", name="a.json")
    two = run(dataset, tmp_path, "--w-foot", "2", name="b.json")
    g1, g2 = grads(one), grads(two)
    assert all(g1[t] > 0 for t in ("recon", "pos", "vel", "bone")), g1
    assert g2["foot"] == pytest.approx(2 * g1["foot"], rel=1e-5)
    for t in ("recon", "pos", "vel", "bone"):
        assert g2[t] == pytest.approx(g1[t], rel=1e-6), t
    assert two["weights"]["foot"] == 200.0 and two["weights"]["bone"] == 1000.0
    text = capsys.readouterr().out
    assert "gradient norms of the G loss" in text and all(f"\n{t} " in text for t in ("pos", "vel", "foot", "bone"))
    again = run(dataset, tmp_path, "--w-foot", "1", name="c.json")
    assert grads(again) == g1                           # the loader's batches and noise are seeded


def test_without_lambda_only_recon_pulls(dataset, tmp_path):
    res = run(dataset, tmp_path, "--lambda-geo", "0")
    g = grads(res)
    assert g["recon"] > 0 and g["pos"] == g["vel"] == g["foot"] == g["bone"] == 0.0
    assert res["groups"]["all"]["sum_grad"] == pytest.approx(g["recon"], rel=1e-5)


def test_noise_groups_split_the_batch(dataset, tmp_path):
    res = run(dataset, tmp_path, "--supported-steps", "1")      # one step: every sample at t = 1
    assert res["groups"]["t<1"] is None and res["groups"]["t=1"]["batches"] == 3
    assert grads(res, "t=1") == pytest.approx(grads(res), rel=1e-4)


def test_weights_are_read_and_bad_ones_named(dataset, tmp_path, capsys):
    assert train_main(["--data", str(dataset), "--out", str(tmp_path / "r"), "--steps", "2",
                       "--weights-out", str(tmp_path / "w.pt"), *TINY]) == 0
    base = run(dataset, tmp_path, name="fresh.json")
    loaded = run(dataset, tmp_path, "--init-weights", str(tmp_path / "w.pt"), name="init.json")
    assert grads(loaded) != grads(base)                 # the trained weights, not a fresh generator
    (tmp_path / "bad.pt").write_bytes(b"not weights")
    capsys.readouterr()
    rc = train_gradients.main(["--data", str(dataset), "--out", str(tmp_path / "cache"), *TINY,
                               "--init-weights", str(tmp_path / "bad.pt")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err[-1].startswith("emdm.train_gradients: ") and "bad.pt" in err[-1]
    with pytest.raises(SystemExit):
        train_gradients.main(["--data", str(dataset), "--out", str(tmp_path / "cache"), *TINY, "--batches", "0"])
