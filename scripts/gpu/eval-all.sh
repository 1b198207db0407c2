#!/usr/bin/env bash
# Issue 7's whole evaluation on a GPU machine: every row of docs/RESULTS.md's tables at the full protocol
# (all test clips, REPEATS repeats), evaluate runs in parallel (generators on the GPU, evaluators on CPU
# threads), then the Python timing rows on the GPU. Writes docs/results/json/*.json; render them with
# `python -m emdm.eval.report` (anywhere).
#
#   scripts/gpu/eval-all.sh DATASET WEIGHTS [REPEATS] [PARALLEL]
#
# DATASET  the prepared dataset folder (test split; Mean/Std)
# WEIGHTS  folder with the --weights-out files of scripts/gpu/train-all.sh: t2m.pt a2m.pt t2m-ddim.pt
#          t2m-naive.pt t2m-nodcond.pt (a missing one is skipped with a notice) and eval/{matcher,classifier}.pt
# The evaluators are read from WEIGHTS/eval/; caption embeddings from $EMDM_EVAL_CACHE when set.
# EMDM_EVAL_EXTRA (e.g. "--max-items 40 --mm-texts 4 --mm-repeats 2 --plaus-n 10") is appended to every
# evaluation: for a quick smoke run. EMDM_EVAL_TIMING=0 skips the timing rows (e.g. while the GPU is shared).
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
data="${1:?usage: eval-all.sh DATASET WEIGHTS [REPEATS] [PARALLEL]}"
w="${2:?WEIGHTS folder}"
repeats="${3:-20}"
par="${4:-6}"
py="${PYTHON:-python3}"
export PYTHONPATH="$here/scripts${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
device=cuda
"$py" -c 'import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)' || device=cpu
echo "eval-all: generators on $device, $par evaluations at a time, $repeats repeats"

read -r -a extra <<<"${EMDM_EVAL_EXTRA:-}"
ev=(--dataset "$data" --matcher "$w/eval/matcher.pt" --classifier "$w/eval/classifier.pt" "${extra[@]}")
gen=(--repeats "$repeats" --device "$device" --batch 256 --threads 2)
cmds=()
cmds+=("text --source real --repeats $repeats")
cmds+=("action --source real --repeats $repeats")
have() { [[ -f "$w/$1.pt" ]] || { echo "eval-all: $w/$1.pt missing, its rows are skipped" >&2; return 1; }; }
if have t2m; then for T in 10 1 2 4; do cmds+=("text --ckpt $w/t2m.pt --steps $T ${gen[*]}"); done; fi
if have t2m-ddim; then for T in 100 50 10; do cmds+=("text --ckpt $w/t2m-ddim.pt --steps $T ${gen[*]}"); done; fi
if have t2m-naive; then cmds+=("text --ckpt $w/t2m-naive.pt --steps 10 ${gen[*]}"); fi
if have t2m-nodcond; then cmds+=("text --ckpt $w/t2m-nodcond.pt --steps 10 ${gen[*]}"); fi
if have a2m; then cmds+=("action --ckpt $w/a2m.pt --steps 10 ${gen[*]}"); fi

logdir="$(mktemp -d)"
fails=0
one() {  # n, evaluate args...
  local n="$1"; shift
  # shellcheck disable=SC2086
  if "$py" -m emdm.eval.evaluate "$@" "${ev[@]}" >"$logdir/$n.log" 2>&1; then
    echo "ok   #$n $* ($(tail -1 "$logdir/$n.log"))"
  else
    echo "FAIL #$n $*"; tail -5 "$logdir/$n.log"; return 1
  fi
}
running=0
n=0
for c in "${cmds[@]}"; do
  n=$((n + 1))
  # shellcheck disable=SC2086
  one "$n" $c &
  running=$((running + 1))
  if (( running >= par )); then wait -n || fails=$((fails + 1)); running=$((running - 1)); fi
done
while (( running > 0 )); do wait -n || fails=$((fails + 1)); running=$((running - 1)); done

timing=()
[[ -f "$w/t2m.pt" ]] && timing+=(--model "$w/t2m.pt=1,2,4,5,8,10")
[[ -f "$w/t2m-ddim.pt" ]] && timing+=(--model "$w/t2m-ddim.pt=10,50,100")
if (( ${#timing[@]} )) && [[ "${EMDM_EVAL_TIMING:-1}" != 0 ]]; then
  "$py" -m emdm.eval.evaluate timing "${timing[@]}" --runs 10 --device "$device" --threads 2 \
    --runtime "python-$device"
fi
ls -la "$here/docs/results/json"
(( fails == 0 )) || { echo "eval-all: $fails evaluation(s) failed" >&2; exit 1; }
