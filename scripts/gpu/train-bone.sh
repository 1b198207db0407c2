#!/usr/bin/env bash
# How the shipped models got their rigidity term (L_bone, train --w-bone), in two rounds side by side on
# one GPU. Round 1 continues the text and action generators from their training weights as shipped before
# L_bone (train --init-weights; D starts fresh) at two L_bone weights each, and trains the DDIM baseline
# afresh with it; round 2 continues round 1's w 30 (text, action) and the DDIM run at heavier weights;
# round 3 continues round 2's DDIM run alone at w 300 (the text and action models met the bar at w 300).
#
#   scripts/gpu/train-bone.sh DATASET RUNS MINUTES [CACHE] [ROUND1] [ROUND2]
#
# ROUND1   round 1's RUNS folder (its *.pt): given, round 2 runs
# ROUND2   round 2's RUNS folder: given (with ROUND1), round 3 runs
# DATASET, RUNS, CACHE as in train-all.sh (whose flags these runs share); MINUTES bounds every run's wall
# clock (--time-limit-min), and the step horizons below were sized from train-all.sh's figures on one H100
# (five runs at once: ~0.12 s per DDGAN step, ~0.05 s per diffusion step) so the cosine decay completes.
# Each run writes RUNS/<name>.pt (float16 EMA weights) for `python -m emdm.export --ship-weights`.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
data_in="${1:?usage: train-bone.sh DATASET RUNS MINUTES [CACHE] [ROUND1] [ROUND2]}"
runs="${2:?RUNS folder}"
minutes="${3:?MINUTES}"
cache="${4:-}"
r1="${5:-}"
r2="${6:-}"
t_begin=$(date +%s)
# shellcheck source=scripts/gpu/common.sh
source "$here/scripts/gpu/common.sh"
common+=(--weights-dtype float16)
m="$here/public/models"
declare -A flags=(
  [t2m-b10]="--task text --lr-g 1e-4 --w-bone 10 --steps 4200 --init-weights $m/emdm-t2m-web.weights.f16.pt"
  [t2m-b30]="--task text --lr-g 1e-4 --w-bone 30 --steps 4200 --init-weights $m/emdm-t2m-web.weights.f16.pt"
  [a2m-b10]="--task action --lr-g 1.5e-4 --w-bone 10 --steps 4200 --init-weights $m/emdm-a2m-web.weights.f16.pt"
  [a2m-b30]="--task action --lr-g 1.5e-4 --w-bone 30 --steps 4200 --init-weights $m/emdm-a2m-web.weights.f16.pt"
  [ddim-b20]="--task text --lr-g 1e-4 --w-bone 20 --steps 9000 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100"
)
names=(t2m-b10 t2m-b30 a2m-b10 a2m-b30 ddim-b20)
if [[ -n "$r1" ]]; then
  flags=(
    [t2m-b100]="--task text --lr-g 1e-4 --w-bone 100 --steps 4200 --init-weights $r1/t2m-b30.pt"
    [t2m-b300]="--task text --lr-g 1e-4 --w-bone 300 --steps 4200 --init-weights $r1/t2m-b30.pt"
    [a2m-b100]="--task action --lr-g 1.5e-4 --w-bone 100 --steps 4200 --init-weights $r1/a2m-b30.pt"
    [a2m-b300]="--task action --lr-g 1.5e-4 --w-bone 300 --steps 4200 --init-weights $r1/a2m-b30.pt"
    [ddim-b100]="--task text --lr-g 1e-4 --w-bone 100 --steps 9000 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100 --init-weights $r1/ddim-b20.pt"
  )
  names=(t2m-b100 t2m-b300 a2m-b100 a2m-b300 ddim-b100)
fi
if [[ -n "$r2" ]]; then      # alone on the GPU: ~0.03 s per diffusion step
  flags=([ddim-b300]="--task text --lr-g 1e-4 --w-bone 300 --steps 11000 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100 --init-weights $r2/ddim-b100.pt")
  names=(ddim-b300)
fi
limit=$("$py" -c "print(round(($minutes * 60 - ($(date +%s) - $t_begin) - 25) / 60, 2))")
seed_cache
for n in "${names[@]}"; do launch "$n" --time-limit-min "$limit" --weights-out "$runs/$n.pt"; done
wait_all
for n in "${names[@]}"; do echo "== $n: $(tail -1 "$runs/$n/log.csv")"; done
echo "header: $(head -1 "$runs/${names[0]}/log.csv")"
echo "train-bone: done in $(( $(date +%s) - t_begin )) s"
