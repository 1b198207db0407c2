# Sourced by train-all.sh and train-bone.sh: what their runs share. Expects $data_in, $runs and $cache set
# (and $here, the repository root); sets $py, $data (a dataset folder: an archive from
# `python -m emdm.data.pack` is unpacked beside RUNS), the flags every run shares ($common), the smoke-test
# flags ($extra, from EMDM_TRAIN_EXTRA), and seed_cache / launch / wait_all over the associative array
# $flags (run name -> its own flags) and the list $names.
py="${PYTHON:-python3}"
export PYTHONPATH="$here/scripts${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
mkdir -p "$runs"
if [[ -f "$data_in" ]]; then
  data="$(dirname "$runs")/dataset"
  [[ -f "$data/train.txt" ]] || "$py" -m emdm.data.pack --unpack "$data_in" "$data" --workers "$(nproc)"
else
  data="$data_in"
fi
common=(--data "$data" --preset web --batch 64 --min-frames 16 --random-crop 0.3 --warmup 200 --ema 0.999
        --d-width 1024 --lr-d 1.25e-4 --lr-min 1e-5 --no-progress --log-every 25 --ckpt-minutes 1000)
read -r -a extra <<<"${EMDM_TRAIN_EXTRA:-}"
pids=()

seed_cache() {  # make every run's folder; text runs get the caption embeddings of $cache, if given
  local n
  for n in "${names[@]}"; do
    mkdir -p "$runs/$n"
    if [[ -n "$cache" && "${flags[$n]}" == *"--task text"* ]]; then cp -n "$cache"/text-*.npy "$runs/$n/" 2>/dev/null || true; fi
  done
}

launch() {  # name, extra args...: one emdm.train run in the background, its output in RUNS/<name>/train.out
  local n="$1"; shift
  # shellcheck disable=SC2086
  "$py" -m emdm.train "${common[@]}" ${flags[$n]} --out "$runs/$n" "$@" "${extra[@]}" >>"$runs/$n/train.out" 2>&1 &
  pids+=($!)
}

wait_all() {  # wait for every launched run; on a failure show each run's last lines and stop
  local rc=0 p n
  for p in "${pids[@]}"; do wait "$p" || rc=1; done
  pids=()
  if (( rc )); then
    for n in "${names[@]}"; do echo "== $n"; tail -5 "$runs/$n/train.out"; done
    echo "$(basename "$0"): a run failed" >&2; exit 1
  fi
}
