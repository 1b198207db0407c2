#!/usr/bin/env bash
# Issue 12's retraining: the text and action generators and the DDIM baseline, drawn by action with
# P ∝ n_action^α (train --balance-alpha), on the GPU-efficient loop (data on the device, bf16 autocast, larger
# batch with the learning rates scaled), at an equal GPU budget: each run alone on the GPU for a third of it.
#
#   scripts/gpu/train-balanced.sh DATASET RUNS MINUTES [CACHE]
#
# DATASET, RUNS, CACHE as in train-all.sh; MINUTES is the wall-clock budget of all three runs together.
# Runs (same data, preset, batch, α, learning rates as train-all.sh scaled by --lr-scale, equal wall clock):
#   t2m-bal       EMDM text-to-motion (DDGAN + L_geo, conditional D)   candidate for public/models/emdm-t2m-web
#   a2m-bal       EMDM action-to-motion                                 candidate for public/models/emdm-a2m-web
#   t2m-ddim-bal  plain diffusion, x0 objective (sampled with DDIM)     candidate for public/models/diffusion-t2m-web
# Each run first probes 50 steps (the last 25 timed, after compilation), then its cosine horizon (--steps) is
# set to what fits its share of the budget, and it continues from the probe's checkpoint until the horizon or
# its time limit. Settings (environment): ALPHA (0.5), BATCH (256), LR_SCALE (sqrt), AMP (bf16), COMPILE (0;
# 1: --compile, if emdm.model.bench_train shows it pays on this GPU), W_BONE (300: the shipped models' final
# rigidity weight), TIME_DRAW (steps; pairs: every (T, k) equally often, see train --time-draw). PYTHON and
# EMDM_TRAIN_EXTRA as in train-all.sh (EMDM_TRAIN_EXTRA="--device cpu ..." with AMP=off for a CPU smoke test).
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
data_in="${1:?usage: train-balanced.sh DATASET RUNS MINUTES [CACHE]}"
runs="${2:?RUNS folder}"
minutes="${3:?MINUTES}"
cache="${4:-}"
t_begin=$(date +%s)
# shellcheck source=scripts/gpu/common.sh
source "$here/scripts/gpu/common.sh"
alpha="${ALPHA:-0.5}"
new_loop=(--balance-alpha "$alpha" --batch "${BATCH:-256}" --lr-scale "${LR_SCALE:-sqrt}" --amp "${AMP:-bf16}"
          --w-bone "${W_BONE:-300}" --time-draw "${TIME_DRAW:-steps}")
[[ "${COMPILE:-0}" == 1 ]] && new_loop+=(--compile)
common+=("${new_loop[@]}")
declare -A flags=(
  [t2m-bal]="--task text --lr-g 1e-4"
  [a2m-bal]="--task action --lr-g 1.5e-4"
  [t2m-ddim-bal]="--task text --lr-g 1e-4 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100"
)
names=(t2m-bal a2m-bal t2m-ddim-bal)
seed_cache
echo "train-balanced: alpha $alpha; ${new_loop[*]}; ${minutes} min for ${#names[@]} runs, one at a time"

left_runs=${#names[@]}
for n in "${names[@]}"; do
  share=$(( (minutes * 60 - ($(date +%s) - t_begin)) / left_runs ))
  t_run=$(date +%s)
  launch "$n" --steps 100000 --stop-at 50
  wait_all
  sps=$(tail -1 "$runs/$n/log.csv" | awk -F, '{print $4}')
  rest=$(( share - ($(date +%s) - t_run) ))
  steps=$("$py" -c "print(max(51, int(50 + 0.9 * $rest / $sps)))")
  limit=$("$py" -c "print(round(max($rest - 20, 1) / 60, 2))")
  echo "$n: ${sps} s/step in the probe, ${share} s share -> --steps $steps (time limit ${limit} min)"
  launch "$n" --steps "$steps" --time-limit-min "$limit" --weights-out "$runs/$n.pt" --weights-dtype float32
  wait_all
  grep -m1 "^sampling:" "$runs/$n/train.out" || true
  echo "== $n: $(tail -1 "$runs/$n/log.csv")"
  left_runs=$(( left_runs - 1 ))
done
echo "header: $(head -1 "$runs/t2m-bal/log.csv")"
echo "train-balanced: done in $(( $(date +%s) - t_begin )) s"
