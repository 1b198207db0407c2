#!/usr/bin/env bash
# The recipe of the shipped models and of issue 7's baselines: train all five generators side by side on
# one GPU within a wall-clock budget, with the project's one training command (flags, not forks).
#
#   scripts/gpu/train-all.sh DATASET RUNS MINUTES [CACHE]
#
# DATASET  a dataset folder, or an archive from `python -m emdm.data.pack` (unpacked beside RUNS)
# RUNS     output folder: <name>/ckpt.pt + log.csv per run, and <name>.pt = the EMA generator alone
# MINUTES  wall-clock budget for the training phase (a short probe, then the real runs)
# CACHE    optional folder of precomputed caption embeddings (text-*.npy) to seed the text runs with
#
# Runs (same data, preset, batch, learning rates and step budget; see docs/RESULTS.md):
#   t2m          EMDM text-to-motion (DDGAN + L_geo, conditional D)       -> public/models/emdm-t2m-web
#   a2m          EMDM action-to-motion                                     -> public/models/emdm-a2m-web
#   t2m-ddim     plain diffusion, x0 objective (sampled with DDIM)         -> public/models/diffusion-t2m-web
#   t2m-naive    naive DDGAN: R = 0, D without condition                   (Tab. D3)
#   t2m-nodcond  DDGAN + L_geo, D without condition                        (Tab. D4)
# The probe (50 steps each, all at once) measures seconds per step under this sharing; each run's cosine
# horizon (--steps) is then set to what fits the rest of the budget, so every schedule decays fully.
# PYTHON (default python3) must hold torch with CUDA; nothing is installed. EMDM_TRAIN_EXTRA (e.g.
# "--device cpu --limit 64 --batch 4 --d-width 64") is appended to every run: for a smoke test on a CPU.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
data_in="${1:?usage: train-all.sh DATASET RUNS MINUTES [CACHE]}"
runs="${2:?RUNS folder}"
minutes="${3:?MINUTES}"
cache="${4:-}"
t_begin=$(date +%s)
# shellcheck source=scripts/gpu/common.sh
source "$here/scripts/gpu/common.sh"
declare -A flags=(
  [t2m]="--task text --lr-g 1e-4"
  [a2m]="--task action --lr-g 1.5e-4"
  [t2m-ddim]="--task text --lr-g 1e-4 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100"
  [t2m-naive]="--task text --lr-g 1e-4 --geo-weight 0 --no-d-cond"
  [t2m-nodcond]="--task text --lr-g 1e-4 --no-d-cond"
)
declare -A dtype=([t2m]=float32 [a2m]=float32 [t2m-ddim]=float32 [t2m-naive]=float16 [t2m-nodcond]=float16)
names=(t2m a2m t2m-ddim t2m-naive t2m-nodcond)
seed_cache

echo "probe: 50 steps each, all five at once"
for n in "${names[@]}"; do launch "$n" --steps 100000 --stop-at 50; done
wait_all

left=$(( minutes * 60 - ($(date +%s) - t_begin) ))
echo "budget left for the runs: ${left} s"
pids=()
for n in "${names[@]}"; do
  sps=$(tail -1 "$runs/$n/log.csv" | awk -F, '{print $4}')
  steps=$("$py" -c "print(int(50 + 0.9 * $left / $sps))")
  echo "$n: ${sps} s/step in the probe -> --steps $steps"
  launch "$n" --steps "$steps" --time-limit-min "$("$py" -c "print(round(($left - 30) / 60, 2))")" \
    --weights-out "$runs/$n.pt" --weights-dtype "${dtype[$n]}"
done
wait_all

for n in "${names[@]}"; do
  echo "== $n: $(tail -1 "$runs/$n/log.csv")"
done
echo "header: $(head -1 "$runs/t2m/log.csv")"
echo "train-all: done in $(( $(date +%s) - t_begin )) s"
