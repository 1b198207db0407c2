"""A GPU slice rehearsed on the CPU (issue 27, steps 0 and 1): scripts/gpu/lease.sh makes what a device call copies
fit its 64 MiB and puts the checkout back as it was; scripts/gpu/lease-train.sh, run from exactly the files that
would travel (no text encoder, no ONNX files), continues the shipped text model and writes its weights where the
device call returns them. A slice is then lost neither to a tree over the limit nor to a missing file or a typo."""

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from emdm import paths
from emdm.checkpoints import load_weights_file
from test_data_prepare import _run, _user_folder

LIMIT = 64 * 1024 * 1024
# the real packed dataset (emdm.data.pack of the full dataset) is 31.9 MB and the caption cache 4.1 MB: the
# shrunk tree must leave room for both
CARRIED = 37 * 1024 * 1024


def git(repo: Path, *args: str) -> str:
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True).stdout


def lease(repo: Path, *args: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", str(repo / "scripts/gpu/lease.sh"), *args], cwd=repo, capture_output=True, text=True,
                          env={**os.environ, "PYTHON": sys.executable, **(env or {})}, timeout=900)


@pytest.fixture(scope="module")
def repo(tmp_path_factory) -> Path:
    """A git repository holding this checkout's working tree as it is now (tracked and untracked-not-ignored
    files, committed), so the rehearsal sees uncommitted changes too."""
    dst = tmp_path_factory.mktemp("lease") / "repo"
    files = subprocess.run(["git", "-C", str(paths.REPO_ROOT), "ls-files", "-z", "-c", "-o", "--exclude-standard"],
                           check=True, capture_output=True).stdout.decode().split("\0")
    for f in filter(None, files):
        src = paths.REPO_ROOT / f
        if src.is_file():
            (dst / f).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dst / f)
    git(dst, "init", "-q")
    git(dst, "-c", "user.email=t@t", "-c", "user.name=t", "add", "-A")
    git(dst, "-c", "user.email=t@t", "-c", "user.name=t", "commit", "-q", "-m", "snapshot")
    return dst


def travel_bytes(repo: Path) -> int:
    out = lease(repo, "files")
    assert out.returncode == 0, out.stderr
    return sum((repo / f).stat().st_size for f in out.stdout.splitlines())


def cpu_env(**extra: str) -> dict:
    """The device command's environment for a CPU rehearsal: a tiny model, batch and step count, weights written at
    every step (WEIGHTS_MINUTES 0), the checkout's PYTHONPATH left out (the script sets its own); ``extra`` on top."""
    env = {**os.environ, "PYTHON": sys.executable, "AMP": "off", "BATCH": "2", "PROBE_STEPS": "2", "MAX_STEPS": "3",
           "WEIGHTS_MINUTES": "0", "LEASE_SECONDS": "300",
           "EMDM_TRAIN_EXTRA": "--device cpu --d-width 32 --threads 1 --log-every 1", **extra}
    env.pop("PYTHONPATH", None)
    return env


def prepared_without_starts(repo: Path, tmp_path: Path) -> None:
    """.lease holds a packed dataset (a small one prepared here if the checkout has none) and no init-*.pt: a run
    continues from the shipped weights."""
    if not (repo / ".lease/dataset.emdmpack").is_file():
        data = _run(tmp_path, *_user_folder(tmp_path))
        prep = lease(repo, "prepare", str(data))
        assert prep.returncode == 0, prep.stdout[-2000:] + prep.stderr[-2000:]
    for f in (repo / ".lease").glob("init-*.pt"):
        f.unlink()


def test_shrink_fits_the_lease_and_restore_puts_everything_back(repo):
    before = git(repo, "ls-files")
    assert travel_bytes(repo) > LIMIT                         # today's tree would be refused
    assert lease(repo, "size").returncode == 1
    out = lease(repo, "shrink")
    assert out.returncode == 0, out.stderr
    try:
        small = travel_bytes(repo)
        assert small + CARRIED <= LIMIT, f"{small / 2**20:.1f} MiB travel before the carried dataset and cache"
        size = lease(repo, "size")
        assert size.returncode == 0 and "would travel" in size.stdout
        travelling = set(lease(repo, "files").stdout.splitlines())
        # what a run reads stays; what it does not read stays behind
        assert {"public/models/manifest.json", "public/models/emdm-t2m-web.weights.f16.pt",
                "public/models/emdm-t2m-web.meanstd.f32", "scripts/gpu/lease-train.sh"} <= travelling
        assert not any(f.endswith(".onnx") or f.startswith("public/models/text/") for f in travelling)
        # nothing on disk was touched, and a commit in the meantime is refused (it would delete the models)
        assert (repo / "public/models/emdm-t2m-web.onnx").is_file()
        (repo / "note.txt").write_text("x")
        git(repo, "add", "note.txt")
        commit = subprocess.run(["git", "-C", str(repo), "-c", "user.email=t@t", "-c", "user.name=t", "commit", "-q",
                                 "-m", "during a lease"], capture_output=True, text=True)
        assert commit.returncode != 0 and "lease.sh restore" in commit.stderr
        git(repo, "reset", "-q", "--", "note.txt")
        (repo / "note.txt").unlink()
    finally:
        assert lease(repo, "restore").returncode == 0
    assert git(repo, "ls-files") == before
    assert git(repo, "status", "--porcelain") == ""
    assert not (repo / ".git/hooks/pre-commit").exists()
    assert lease(repo, "restore").returncode == 0            # idempotent


def test_shrink_refuses_a_staged_change(repo):
    (repo / "README.md").write_text((repo / "README.md").read_text() + "\nstaged\n")
    git(repo, "add", "README.md")
    try:
        out = lease(repo, "shrink")
        assert out.returncode == 2 and "staged changes" in out.stderr
    finally:
        git(repo, "checkout", "-q", "HEAD", "--", "README.md")


def test_the_slice_runs_from_exactly_what_travels(repo, tmp_path):
    """prepare (pack + caption cache through the trainer's own loading), shrink, copy what would travel, and
    run the device command there on the CPU: the weights come back in $OUT, continued from the shipped model,
    written during the run (--weights-minutes) and loadable by export."""
    data = _run(tmp_path, *_user_folder(tmp_path))             # a small dataset through emdm.data.prepare
    prep = lease(repo, "prepare", str(data))
    assert prep.returncode == 0, prep.stdout[-2000:] + prep.stderr[-2000:]
    assert (repo / ".lease/dataset.emdmpack").is_file() and list((repo / ".lease/cache").glob("text-*.npy"))
    assert lease(repo, "shrink").returncode == 0
    try:
        travel = tmp_path / "travel"
        assert lease(repo, "stage", str(travel)).returncode == 0
    finally:
        assert lease(repo, "restore").returncode == 0
    assert not (travel / "public/models/text").exists() and (travel / ".lease/dataset.emdmpack").is_file()
    out_dir = tmp_path / "OUT"
    env = cpu_env(OUT=str(out_dir), MAX_STEPS="4", LEASE_WORK=str(tmp_path / "work"))
    run = subprocess.run(["bash", "scripts/gpu/lease-train.sh", "t2m"], cwd=travel, env=env, capture_output=True,
                         text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "lease-train: done" in run.stdout
    st = load_weights_file(out_dir / "emdm-t2m-web.pt")
    assert st["step"] == 4 and st["meta"]["task"] == "text"
    assert st["meta"]["init"]["runs"], "the run must record the shipped weights it continued from"
    assert st["meta"]["args"]["balance_alpha"] == 0.25 and st["meta"]["args"]["batch"] == 2
    assert all(torch.isfinite(v).all() for v in st["G_ema"].values())
    assert (out_dir / "emdm-t2m-web.pt").stat().st_size <= 16 * 2**20      # what a device call returns per file
    for f in ("log.csv", "train.out", "env.txt"):
        assert (out_dir / f).is_file(), f
    # written during the run, not only at its end: train.out names every write
    log = (out_dir / "train.out").read_text()
    assert "weights at step 3 -> " in log and "weights at step 4 -> " in log

    # a second call of the same lease continues from what the first returned: `init` makes it float16 in .lease
    init = lease(repo, "init", "t2m", str(out_dir / "emdm-t2m-web.pt"))
    assert init.returncode == 0, init.stderr
    carried = repo / ".lease/init-t2m.pt"
    st_init = load_weights_file(carried)
    assert st_init["meta"]["weights_dtype"] == "float16" and st_init["step"] == 4
    assert carried.stat().st_size < (out_dir / "emdm-t2m-web.pt").stat().st_size * 0.6
    shutil.copy2(carried, travel / ".lease/init-t2m.pt")
    out2 = tmp_path / "OUT2"
    second = subprocess.run(["bash", "scripts/gpu/lease-train.sh", "t2m"], cwd=travel, capture_output=True, text=True,
                            env={**env, "OUT": str(out2), "LEASE_WORK": str(tmp_path / "work2")}, timeout=900)
    assert second.returncode == 0, second.stdout[-3000:] + second.stderr[-3000:]
    assert "emdm-t2m-web from init-t2m.pt" in second.stdout
    runs = load_weights_file(out2 / "emdm-t2m-web.pt")["meta"]["init"]["runs"]
    assert runs[-1]["file"] == "init-t2m.pt" and runs[-1]["weights_dtype"] == "float16" and runs[-1]["steps"] == 4


def test_init_refuses_a_file_that_is_not_weights(repo, tmp_path):
    bad = tmp_path / "returned.pt"
    bad.write_bytes(b"not a torch file")
    out = lease(repo, "init", "t2m", str(bad))
    assert out.returncode == 2 and "returned.pt" in out.stderr and "cannot read" in out.stderr, out.stderr
    assert not (repo / ".lease/init-t2m.pt").exists() or (repo / ".lease/init-t2m.pt").stat().st_size > 1000
    wrong = lease(repo, "init", "t2x", str(bad))
    assert wrong.returncode == 2 and "unknown run 't2x'" in wrong.stderr


def test_the_slice_says_what_is_missing(tmp_path):
    env = {**os.environ, "PYTHON": sys.executable, "OUT": str(tmp_path / "OUT")}
    bad = subprocess.run(["bash", str(paths.REPO_ROOT / "scripts/gpu/lease-train.sh"), "t2x"], env=env,
                         capture_output=True, text=True)
    assert bad.returncode == 2 and "unknown run 't2x'" in bad.stderr


# the next slice's call (MODELS, "Slice 5"): L_geo's weight falling from 100 at t = 0 to 10 at t = 1 (hi), or rising
# from 10 to 100 (lo), beside the recipe as it is; hi also checks that a variant's flags override the recipe's
VARIANTS = "base:;hi:--geo-weight-t1 10 --random-crop 0.9 --crop-min 20;lo:--geo-weight 10 --geo-weight-t1 100"
NAMES = ("base", "hi", "lo")


def test_variants_train_side_by_side_from_one_call(repo, tmp_path):
    """VARIANTS: two recipes from the same start in one call, each its own weights and logs in $OUT/<name>/, its
    flags on top of the recipe's; a second call continues each from its own float16 start, and `shrink t2m` then
    leaves every shipped weights file behind (room for several starts in 64 MiB)."""
    prepared_without_starts(repo, tmp_path)
    assert lease(repo, "shrink", "t2m").returncode == 0
    try:
        travel = tmp_path / "travel"
        assert lease(repo, "stage", str(travel)).returncode == 0
        files = set(lease(repo, "files").stdout.splitlines())
        assert "public/models/emdm-t2m-web.weights.f16.pt" in files
        assert "public/models/emdm-a2m-web.weights.f16.pt" not in files        # another run's start stays behind
    finally:
        assert lease(repo, "restore").returncode == 0
    env = cpu_env(VARIANTS=VARIANTS)

    def call(out: Path, work: str) -> subprocess.CompletedProcess:
        r = subprocess.run(["bash", "scripts/gpu/lease-train.sh", "t2m"], cwd=travel, capture_output=True, text=True,
                           env={**env, "OUT": str(out), "LEASE_WORK": str(tmp_path / work)}, timeout=900)
        assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
        return r

    first = call(tmp_path / "OUT", "w1")
    args = {}
    for v in NAMES:
        st = load_weights_file(tmp_path / "OUT" / v / "emdm-t2m-web.pt")
        assert st["step"] == 3 and st["meta"]["init"]["runs"]
        args[v] = st["meta"]["args"]
        assert (tmp_path / "OUT" / v / "log.csv").is_file(), v
        assert f"== t2m-{v}" in (tmp_path / "OUT/train.out").read_text()
        assert f"[t2m-{v}] emdm-t2m-web from emdm-t2m-web.weights.f16.pt" in first.stdout
    # a device call returns at most 8 files: env.txt, train.out and two per variant (three variants fit)
    assert len([f for f in (tmp_path / "OUT").rglob("*") if f.is_file()]) == 8
    assert args["base"]["random_crop"] == 0.3 and args["hi"]["random_crop"] == 0.9 and args["hi"]["crop_min"] == 20
    for v in NAMES:
        assert args[v]["time_draw"] == "pairs" and args[v]["balance_alpha"] == 0.25, v     # the recipe's since slice 4
    # the next slice's variants: L_geo's weight falling towards t = 1 (hi: 100 -> 10) or rising (lo: 10 -> 100)
    assert (args["base"]["geo_weight"], args["base"]["geo_weight_t1"]) == (100, None)
    assert (args["hi"]["geo_weight"], args["hi"]["geo_weight_t1"]) == (100, 10)
    assert (args["lo"]["geo_weight"], args["lo"]["geo_weight_t1"]) == (10, 100)

    # call 2: each variant from its own returned weights, made ready in one step (`next`: init each, shrink, size)
    empty = tmp_path / "empty"
    empty.mkdir()
    refused = lease(repo, "next", "t2m", str(empty))
    assert refused.returncode == 2 and "no emdm-t2m-web.pt" in refused.stderr, refused.stderr
    nxt = lease(repo, "next", "t2m", str(tmp_path / "OUT"))
    assert nxt.returncode == 0, nxt.stdout + nxt.stderr
    assert "would travel" in nxt.stdout
    for v in NAMES:
        assert load_weights_file(repo / f".lease/init-t2m-{v}.pt")["meta"]["weights_dtype"] == "float16"
        shutil.copy2(repo / f".lease/init-t2m-{v}.pt", travel / f".lease/init-t2m-{v}.pt")
    try:
        files = set(lease(repo, "files").stdout.splitlines())
        assert not any(f.endswith(".weights.f16.pt") for f in files), "the starts are in .lease now"
        assert {f".lease/init-t2m-{v}.pt" for v in NAMES} <= files
        assert not any(f.startswith("docs/results/") for f in files)
    finally:
        assert lease(repo, "restore").returncode == 0
        for f in (repo / ".lease").glob("init-*.pt"):
            f.unlink()
    second = call(tmp_path / "OUT2", "w2")
    for v in NAMES:
        assert f"[t2m-{v}] emdm-t2m-web from init-t2m-{v}.pt" in second.stdout
        runs = load_weights_file(tmp_path / "OUT2" / v / "emdm-t2m-web.pt")["meta"]["init"]["runs"]
        assert runs[-1]["file"] == f"init-t2m-{v}.pt" and runs[-1]["steps"] == 3

    bad = subprocess.run(["bash", "scripts/gpu/lease-train.sh", "t2m"], cwd=travel, capture_output=True, text=True,
                         env={**env, "OUT": str(tmp_path / "OUT3"), "VARIANTS": "Crop!:--random-crop 0.5"})
    assert bad.returncode == 2 and "bad name 'Crop!'" in bad.stderr
    assert lease(repo, "shrink", "t2x").returncode == 2


@pytest.mark.parametrize("run, model, task", [("a2m", "emdm-a2m-web", "action"),
                                              ("ddim", "diffusion-t2m-web", "text")])
def test_the_later_slices_run_from_what_travels(repo, tmp_path, run, model, task):
    """The slices after the text model's (issue 27, step 3): the action model and the DDIM baseline, each through
    `shrink RUN` and the same device command, continue their own shipped weights with their own objective."""
    prepared_without_starts(repo, tmp_path)
    assert lease(repo, "shrink", run).returncode == 0
    try:
        travel = tmp_path / "travel"
        assert lease(repo, "stage", str(travel)).returncode == 0
        files = set(lease(repo, "files").stdout.splitlines())
        assert f"public/models/{model}.weights.f16.pt" in files
        assert not any(f.endswith(".weights.f16.pt") and model not in f for f in files)   # the others stay behind
    finally:
        assert lease(repo, "restore").returncode == 0
    out = tmp_path / "OUT"
    env = cpu_env(OUT=str(out), LEASE_WORK=str(tmp_path / "work"))
    r = subprocess.run(["bash", "scripts/gpu/lease-train.sh", run], cwd=travel, env=env, capture_output=True,
                       text=True, timeout=900)
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-3000:]
    assert f"[{run}] {model} from {model}.weights.f16.pt" in r.stdout
    st = load_weights_file(out / f"{model}.pt")
    assert st["step"] == 3 and st["meta"]["task"] == task and st["meta"]["init"]["runs"]
    assert st["meta"]["args"]["objective"] == ("diffusion" if run == "ddim" else "ddgan")
    assert all(torch.isfinite(v).all() for v in st["G_ema"].values())
    assert (out / f"{model}.pt").stat().st_size <= 16 * 2**20
