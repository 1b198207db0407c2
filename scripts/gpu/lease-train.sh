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
# Settings (environment): as train-balanced.sh (BATCH 256, LR_SCALE sqrt, AMP bf16, W_BONE 300, COMPILE 0) but
# ALPHA 0.25 (it won slice 3: rare actions drawn more often) and TIME_DRAW pairs (it won slice 4: every (step count,
# step) pair equally often, so 10 steps' middle steps get more samples; train-balanced.sh's is steps),
# WEIGHTS_MINUTES (2), LEASE_SECONDS (480), PROBE_STEPS (25: the steps timed to set the cosine horizon), MAX_STEPS
# (no cap), MARGIN_SECONDS (30, plus 15 per run), VARIANTS (below), PYTHON (python3) and EMDM_TRAIN_EXTRA. The CPU
# rehearsal in CI runs this same script with EMDM_TRAIN_EXTRA="--device cpu --d-width 32 ...", AMP=off, BATCH=2,
# PROBE_STEPS=2, MAX_STEPS=4.
#
# VARIANTS="name:flags;name:flags" trains several recipes side by side on the one device, from the same start, in
# the same time (1.7x the steps of one run in all with three on an H200, 1.5x with two; a comparison judged
# afterwards on the CPU, so the lease is not spent waiting): each variant's
# flags are appended to the recipe's (the last of a repeated flag wins), each continues from
# .lease/init-<run>-<name>.pt if present (a second call of the same lease: `lease.sh init <run>-<name> FILE`),
# else from the common start above, and each leaves its weights and log.csv in $OUT/<name>/ (train.out: all of them
# in $OUT/train.out). Names: [a-z0-9]+, flags may be empty.
set -euo pipefail
t_begin=$(date +%s)
here="$(cd "$(dirname "$0")/../.." && pwd)"
run="${1:?usage: lease-train.sh t2m|a2m|ddim}"
out="${OUT:?OUT: the folder that comes back from the device}"
budget="${LEASE_SECONDS:-480}"
# shellcheck source=scripts/gpu/runs.sh
source "$here/scripts/gpu/runs.sh"
declare -A run_flags=(
  [t2m]="--task text --lr-g 1e-4"
  [a2m]="--task action --lr-g 1.5e-4"
  [ddim]="--task text --lr-g 1e-4 --objective diffusion --supported-steps 1,2,4,5,8,10,20,50,100"
)
model="${run_model[$run]:-}"
[[ -n "$model" ]] || { echo "lease-train.sh: unknown run '$run' ($run_names)" >&2; exit 2; }
pack="$here/.lease/dataset.emdmpack"
[[ -f "$pack" ]] || { echo "lease-train.sh: $pack missing: run scripts/gpu/lease.sh prepare here and carry .lease" >&2; exit 2; }
init="$here/.lease/init-$run.pt"
[[ -f "$init" ]] || init="$here/public/models/$model.weights.f16.pt"
# the runs of this call: one, or one per variant (run name -> its own flags, start and folder in $OUT)
names=()
declare -A flags=() inits=() outs=()
if [[ -z "${VARIANTS:-}" ]]; then
  names=("$run"); flags[$run]="${run_flags[$run]}"; inits[$run]="$init"; outs[$run]="$out"
else
  IFS=';' read -r -a specs <<<"$VARIANTS"
  for spec in "${specs[@]}"; do
    [[ -z "${spec// /}" ]] && continue
    v="${spec%%:*}"; vflags=""; [[ "$spec" == *:* ]] && vflags="${spec#*:}"
    [[ "$v" =~ ^[a-z0-9]+$ ]] || { echo "lease-train.sh: VARIANTS: bad name '$v' in '$spec' (want [a-z0-9]+:flags)" >&2; exit 2; }
    [[ -n "${flags[$run-$v]+x}" ]] && { echo "lease-train.sh: VARIANTS: '$v' named twice" >&2; exit 2; }
    n="$run-$v"; names+=("$n")
    flags[$n]="${run_flags[$run]} $vflags"; outs[$n]="$out/$v"
    inits[$n]="$here/.lease/init-$n.pt"; [[ -f "${inits[$n]}" ]] || inits[$n]="$init"
  done
  (( ${#names[@]} )) || { echo "lease-train.sh: VARIANTS names no variant ('$VARIANTS')" >&2; exit 2; }
fi
for n in "${names[@]}"; do
  [[ -f "${inits[$n]}" ]] || { echo "lease-train.sh: no weights to continue from for $n (${inits[$n]})" >&2; exit 2; }
  flags[$n]+=" --init-weights ${inits[$n]}"
  mkdir -p "${outs[$n]}"
done
mkdir -p "$out"
keep_logs() {  # whatever happens, the logs come back with the weights; a device call returns at most 8 files, so
              # the variants' train.out tails share one $OUT/train.out (env.txt + 3 variants x 2 + it = 8)
  local n
  if [[ -z "${VARIANTS:-}" ]]; then
    [[ -f "${runs:-}/$run/log.csv" ]] && cp "$runs/$run/log.csv" "$out/log.csv"
    [[ -f "${runs:-}/$run/train.out" ]] && tail -c 200000 "$runs/$run/train.out" >"$out/train.out"
    return 0
  fi
  : >"$out/train.out"
  for n in "${names[@]}"; do
    [[ -f "${runs:-}/$n/log.csv" ]] && cp "$runs/$n/log.csv" "${outs[$n]}/log.csv"
    [[ -f "${runs:-}/$n/train.out" ]] && { echo "== $n"; tail -c 60000 "$runs/$n/train.out"; } >>"$out/train.out"
  done
  return 0
}
trap keep_logs EXIT
work="${LEASE_WORK:-$(mktemp -d)}"
data_in="$pack" runs="$work/runs" cache="$here/.lease/cache"
# shellcheck source=scripts/gpu/common.sh
source "$here/scripts/gpu/common.sh"
{ date -u; nvidia-smi --query-gpu=name,memory.total --format=csv,noheader 2>/dev/null || echo "no nvidia-smi";
  "$py" -c 'import torch; print("torch", torch.__version__, "cuda", torch.cuda.is_available())'; } >"$out/env.txt" 2>&1
seed_cache
common+=(--balance-alpha "${ALPHA:-0.25}" --batch "${BATCH:-256}" --lr-scale "${LR_SCALE:-sqrt}" --amp "${AMP:-bf16}"
         --w-bone "${W_BONE:-300}" --time-draw "${TIME_DRAW:-pairs}")
[[ "${COMPILE:-0}" == 1 ]] && common+=(--compile)
left=$(( budget - ($(date +%s) - t_begin) - 30 ))
(( left > 30 )) || { echo "lease-train.sh: only ${left} s left after the unpack; nothing trained" >&2; exit 1; }
minutes=$("$py" -c "print(round($left / 60, 2))")
# the cosine horizon from a measured pace: 25 steps of probe (every run at once, so the pace is the shared one),
# then the rest of the time at that pace
probe="${PROBE_STEPS:-25}"
for n in "${names[@]}"; do launch "$n" --steps 100000 --stop-at "$probe" --log-every 5; done
wait_all
# the margin covers each run's start (loading, the dataset onto the device: ~20 s, more with several runs at once)
# and the last write; 30 s alone let a 540 s call of three variants end at 561 s
rest=$(( budget - ($(date +%s) - t_begin) - ${MARGIN_SECONDS:-30} - 15 * ${#names[@]} ))
limit=$("$py" -c "print(round(max($rest, 1) / 60, 2))")
for n in "${names[@]}"; do
  sps=$(tail -1 "$runs/$n/log.csv" | awk -F, '{print $4}')
  steps=$("$py" -c "print(min(max($probe + 1, int($probe + 0.9 * $rest / max($sps, 1e-6))), ${MAX_STEPS:-10**9}))")
  echo "lease-train: [$n] $model from $(basename "${inits[$n]}"): probe ${sps} s/step -> --steps $steps, --time-limit-min $limit (of $minutes)"
  launch "$n" --steps "$steps" --time-limit-min "$limit" --weights-out "${outs[$n]}/$model.pt" --weights-dtype float32 \
    --weights-minutes "${WEIGHTS_MINUTES:-2}"
done
wait_all
keep_logs
for n in "${names[@]}"; do echo "lease-train: $n: $(tail -1 "$runs/$n/log.csv")"; done
echo "lease-train: done in $(( $(date +%s) - t_begin )) s; $out: $(cd "$out" && find . -type f | sort | tr '\n' ' ')"
