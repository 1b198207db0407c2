#!/usr/bin/env bash
# One GPU slice of issue 27's retraining: what the device call runs (see scripts/gpu/lease.sh for the slice).
#
#   bash scripts/gpu/lease-train.sh t2m|a2m|ddim      (run from the repository root; $OUT: the folder that comes back)
#
# Unpacks .lease/dataset.emdmpack, seeds the caption cache from .lease/cache, continues the shipped model
# (public/models/<model>.weights.f16.pt, or .lease/init-<run>.pt when a slice before returned float32 weights)
# with the balanced recipe of train-balanced.sh, and leaves in $OUT: <model>.pt (the EMA generator, float32,
# written every WEIGHTS_MINUTES and at the end, so a run cut short still returns its latest weights), log.csv,
# train.out and env.txt. The whole call keeps within LEASE_SECONDS (default 480) from its start: training gets
# what is left after the unpack, less a margin for the last write.
# Settings (environment): as train-balanced.sh (ALPHA 0.5, BATCH 256, LR_SCALE sqrt, AMP bf16, W_BONE 300,
# TIME_DRAW steps, COMPILE 0), WEIGHTS_MINUTES (2), LEASE_SECONDS (480), PROBE_STEPS (25: the steps timed to set
# the cosine horizon), MAX_STEPS (no cap), PYTHON (python3) and EMDM_TRAIN_EXTRA. The CPU rehearsal in CI runs this
# same script with EMDM_TRAIN_EXTRA="--device cpu --d-width 32 ...", AMP=off, BATCH=2, PROBE_STEPS=2, MAX_STEPS=4.
set -euo pipefail
t_begin=$(date +%s)
here="$(cd "$(dirname "$0")/../.." && pwd)"
run="${1:?usage: lease-train.sh t2m|a2m|ddim}"
out="${OUT:?OUT: the folder that comes back from the device}"
budget="${LEASE_SECONDS:-480}"
declare -A models=([t2m]=emdm-t2m-web [a2m]=emdm-a2m-web [ddim]=diffusion-t2m-web)
declare -A run_flags=(
  [t2m]="--task text --lr-g 1e-4"
  [a2m]="--task action --lr-g 1.5e-4"
  [ddim]="--task text --lr-g 1e-4 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100"
)
model="${models[$run]:-}"
[[ -n "$model" ]] || { echo "lease-train.sh: unknown run '$run' (t2m, a2m or ddim)" >&2; exit 2; }
pack="$here/.lease/dataset.emdmpack"
[[ -f "$pack" ]] || { echo "lease-train.sh: $pack missing: run scripts/gpu/lease.sh prepare here and carry .lease" >&2; exit 2; }
init="$here/.lease/init-$run.pt"
[[ -f "$init" ]] || init="$here/public/models/$model.weights.f16.pt"
[[ -f "$init" ]] || { echo "lease-train.sh: no weights to continue from ($init)" >&2; exit 2; }
mkdir -p "$out"
keep_logs() {  # whatever happens, the logs come back with the weights
  [[ -f "${runs:-}/$run/log.csv" ]] && cp "$runs/$run/log.csv" "$out/log.csv"
  [[ -f "${runs:-}/$run/train.out" ]] && tail -c 200000 "$runs/$run/train.out" >"$out/train.out"
  return 0
}
trap keep_logs EXIT
work="${LEASE_WORK:-$(mktemp -d)}"
data_in="$pack" runs="$work/runs" cache="$here/.lease/cache"
# shellcheck source=scripts/gpu/common.sh
source "$here/scripts/gpu/common.sh"
{ date -u; nvidia-smi --query-gpu=name,memory.total --format=csv,noheader 2>/dev/null || echo "no nvidia-smi";
  "$py" -c 'import torch; print("torch", torch.__version__, "cuda", torch.cuda.is_available())'; } >"$out/env.txt" 2>&1
names=("$run")
declare -A flags=([$run]="${run_flags[$run]}")
seed_cache
common+=(--balance-alpha "${ALPHA:-0.5}" --batch "${BATCH:-256}" --lr-scale "${LR_SCALE:-sqrt}" --amp "${AMP:-bf16}"
         --w-bone "${W_BONE:-300}" --time-draw "${TIME_DRAW:-steps}" --init-weights "$init")
[[ "${COMPILE:-0}" == 1 ]] && common+=(--compile)
left=$(( budget - ($(date +%s) - t_begin) - 30 ))
(( left > 30 )) || { echo "lease-train.sh: only ${left} s left after the unpack; nothing trained" >&2; exit 1; }
minutes=$("$py" -c "print(round($left / 60, 2))")
# the cosine horizon from a measured pace: 25 steps of probe, then the rest of the time at that pace
probe="${PROBE_STEPS:-25}"
launch "$run" --steps 100000 --stop-at "$probe" --log-every 5
wait_all
sps=$(tail -1 "$runs/$run/log.csv" | awk -F, '{print $4}')
rest=$(( budget - ($(date +%s) - t_begin) - 30 ))
steps=$("$py" -c "print(min(max($probe + 1, int($probe + 0.9 * $rest / max($sps, 1e-6))), ${MAX_STEPS:-10**9}))")
limit=$("$py" -c "print(round(max($rest, 1) / 60, 2))")
echo "lease-train: $model from $(basename "$init"): probe ${sps} s/step -> --steps $steps, --time-limit-min $limit (of $minutes)"
launch "$run" --steps "$steps" --time-limit-min "$limit" --weights-out "$out/$model.pt" --weights-dtype float32 \
  --weights-minutes "${WEIGHTS_MINUTES:-2}"
wait_all
keep_logs
echo "lease-train: $(tail -1 "$runs/$run/log.csv")"
echo "lease-train: done in $(( $(date +%s) - t_begin )) s; $out: $(ls "$out" | tr '\n' ' ')"
