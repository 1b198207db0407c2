#!/usr/bin/env bash
# A GPU lease from this checkout. A device call copies the working tree (tracked files, untracked files git
# does not ignore, and the folders named in its `carry`), at most 64 MiB in all; the tracked tree alone is
# ~130 MB, almost all of it public/models. A training run needs none of the ONNX files or the text encoder: it
# reads the packed dataset, the caption-embedding cache and the weights it continues from.
#
#   scripts/gpu/lease.sh prepare [DATASET]  on the CPU: .lease/dataset.emdmpack (emdm.data.pack of DATASET,
#                                           default data/dataset, prepared first if missing) and .lease/cache/
#                                           (the text runs' caption embeddings, computed by emdm.train itself)
#   scripts/gpu/lease.sh shrink [RUN]       take what a run does not need out of what travels (out of git's
#                                           index, ignored in .git/info/exclude; nothing on disk is touched);
#                                           commits are refused until `restore`. With RUN (t2m, a2m, ddim) the
#                                           other models' weights stay behind too, and RUN's shipped weights as
#                                           well once .lease holds init-RUN*.pt (room for several variants' starts)
#   scripts/gpu/lease.sh size               what would travel now, in MiB; exit 1 over 64 MiB
#   scripts/gpu/lease.sh files              the paths that would travel, one a line (what `size` adds up)
#   scripts/gpu/lease.sh stage DIR          copy exactly those paths into DIR (the CPU rehearsal runs there)
#   scripts/gpu/lease.sh restore            undo `shrink` (index from HEAD, exclude and hook removed); idempotent
#   scripts/gpu/lease.sh init RUN FILE      .lease/init-RUN.pt from FILE (a call's returned weights), as float16:
#                                           the next call of the same lease continues from it (7.6 MB carried,
#                                           where the float32 file would take the tree over the limit); RUN may
#                                           name a variant of lease-train.sh's VARIANTS: init t2m-crop FILE
#   scripts/gpu/lease.sh next RUN OUTDIR    between two calls of one lease, in one step (the machine is released
#                                           after 30 s idle): init RUN from OUTDIR/<model>.pt, or RUN-NAME from each
#                                           OUTDIR/NAME/<model>.pt (VARIANTS), then restore, shrink RUN and size
#
# A slice, in order: prepare (once per machine), shrink t2m, size, then the device call
#   run(command="bash scripts/gpu/lease-train.sh t2m", carry=[".lease"], timeout_s=560)
# then restore, give_back. Time left for another call: init t2m /path/to/returned/emdm-t2m-web.pt, size, and the
# same device call with a smaller LEASE_SECONDS (with VARIANTS: init t2m-NAME per variant, restore, shrink t2m).
# tests/python/test_gpu_lease.py rehearses all of it on the CPU in CI.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
cd "$root"
py="${PYTHON:-$root/.venv/bin/python}"
[[ -x "$py" ]] || py=python3
export PYTHONPATH="$root/scripts${PYTHONPATH:+:$PYTHONPATH}"
lease=".lease"
limit=$((64 * 1024 * 1024))
marker="$(git rev-parse --git-path emdm-lease)"
exclude="$(git rev-parse --git-path info/exclude)"
hook="$(git rev-parse --git-path hooks)/pre-commit"
# What a training run needs from public/models: the manifest (the caption cache's key names the encoder's sha256
# there), the normalisation files and the weights a run continues from. Everything else stays behind.
keep_re() {  # the public/models paths that travel; $1: whose weights file travels too (a regex; empty: none)
  echo "^public/models/(manifest\\.json|[^/]+\\.meanstd\\.f32${1:+|$1\\.weights\\.f16\\.pt})\$"
}
# Nor does a run need the test fixtures or the results' figures (docs/results, 5 MB: room for a third variant's start)
drop_dirs=(public/models tests/fixtures docs/results)

die() { echo "lease.sh: $*" >&2; exit 2; }

# shellcheck source=scripts/gpu/runs.sh
source "$root/scripts/gpu/runs.sh"

dropped() {  # tracked paths that do not travel (RUN given: only its weights travel, and not even those once
             # .lease has starts of its own for it)
  local run="${1:-}" weights='[^/]+'
  if [[ -n "$run" ]]; then
    weights="${run_model[$run]}"
    compgen -G "$lease/init-$run*.pt" >/dev/null && weights=""
  fi
  git ls-files -- "${drop_dirs[@]}" | grep -Ev "$(keep_re "$weights")" || true
}

travelling() {  # tracked + untracked-not-ignored files, then the carried .lease folder
  git ls-files -z -c -o --exclude-standard | tr '\0' '\n' | while IFS= read -r f; do [[ -f "$f" ]] && echo "$f"; done
  [[ -d "$lease" ]] && find "$lease" -type f | sort
  return 0
}

cmd_prepare() {
  local ds="${1:-data/dataset}"
  if [[ ! -f "$ds/train.txt" ]]; then
    [[ "$ds" == data/dataset ]] || die "$ds: not a prepared dataset (no train.txt); run python -m emdm.data.prepare --out $ds"
    echo "lease.sh: preparing $ds from the shared data first"
    "$py" -m emdm.data.prepare --out "$ds"
  fi
  mkdir -p "$lease/cache"
  "$py" -m emdm.data.pack "$ds" "$lease/dataset.emdmpack"
  # the cache exactly as the run will look it up: the trainer's own data loading with the lease's data flags
  local tmp; tmp="$(mktemp -d)"
  "$py" -m emdm.train --data "$ds" --task text --min-frames 16 --preset tiny --d-width 32 --batch 1 --device cpu --threads 1 \
    --out "$tmp" --stop-at 0 --no-progress >/dev/null 2>"$tmp/err" || { cat "$tmp/err" >&2; rm -rf "$tmp"; die "caption cache failed"; }
  rm -f "$lease"/cache/text-*.npy
  cp "$tmp"/text-*.npy "$lease/cache/"
  rm -rf "$tmp"
  echo "lease.sh: $lease ready: $(du -sh "$lease" | cut -f1) ($(ls "$lease/cache" | wc -l) caption cache file)"
}

cmd_shrink() {
  local run="${1:-}"
  [[ -z "$run" || -n "${run_model[$run]+x}" ]] || die "shrink: unknown run '$run' ($run_names)"
  [[ -f "$marker" ]] && { echo "lease.sh: already shrunk ($(wc -l <"$marker") paths out); restore first to redo"; return; }
  git diff --cached --quiet || die "the index has staged changes; commit or unstage them first (shrink stages deletions)"
  local list; list="$(dropped "$run")"
  [[ -n "$list" ]] || die "nothing to take out"
  printf '%s\n' "$list" >"$marker"
  xargs -d '\n' git rm -r -q --cached -- <"$marker"
  { echo "# emdm-lease begin"; sed 's|^|/|' "$marker"; echo "# emdm-lease end"; } >>"$exclude"
  if [[ ! -e "$hook" ]]; then
    mkdir -p "$(dirname "$hook")"
    printf '#!/bin/sh\n# emdm-lease guard\necho "a GPU lease has public/models out of the index: run scripts/gpu/lease.sh restore first" >&2\nexit 1\n' >"$hook"
    chmod +x "$hook"
  fi
  echo "lease.sh: $(wc -l <"$marker") paths out of what travels until restore"
}

cmd_restore() {
  if [[ -f "$marker" ]]; then
    xargs -d '\n' git reset -q -- <"$marker" || true
    rm -f "$marker"
  fi
  if [[ -f "$exclude" ]]; then
    sed -i '/^# emdm-lease begin$/,/^# emdm-lease end$/d' "$exclude"
  fi
  if [[ -f "$hook" ]] && grep -q "emdm-lease guard" "$hook"; then rm -f "$hook"; fi
  echo "lease.sh: restored"
}

cmd_init() {
  local run="${1:?init RUN FILE}" src="${2:?init RUN FILE}"
  [[ "$run" =~ ^($run_re)(-[a-z0-9]+)?$ ]] || die "init: unknown run '$run' ($run_names, or RUN-VARIANT)"
  mkdir -p "$lease"
  "$py" -m emdm.checkpoints half "$src" "$lease/init-$run.pt" || exit 2
}

cmd_next() {
  local run="${1:?next RUN OUTDIR}" dir="${2:?next RUN OUTDIR}" model f n=0
  [[ -n "${run_model[$run]+x}" ]] || die "next: unknown run '$run' ($run_names)"
  [[ -d "$dir" ]] || die "next: $dir is not a folder (a device call's files_at)"
  model="${run_model[$run]}"
  if [[ -f "$dir/$model.pt" ]]; then
    cmd_init "$run" "$dir/$model.pt"; n=1
  else
    for f in "$dir"/*/"$model.pt"; do
      [[ -f "$f" ]] || continue
      local v; v="$(basename "$(dirname "$f")")"
      [[ "$v" =~ ^[a-z0-9]+$ ]] || die "next: $f: a variant's folder is named [a-z0-9]+, not '$v'"
      cmd_init "$run-$v" "$f"; n=$((n + 1))
    done
  fi
  (( n )) || die "next: no $model.pt in $dir or its variant folders"
  cmd_restore >/dev/null
  cmd_shrink "$run"
  cmd_size
}

cmd_size() {
  local bytes
  bytes=$(travelling | tr '\n' '\0' | xargs -0 -r stat -c %s | awk '{s += $1} END {print s + 0}')
  local lease_bytes=0
  [[ -d "$lease" ]] && lease_bytes=$(find "$lease" -type f -printf '%s\n' | awk '{s += $1} END {print s + 0}')
  awk -v b="$bytes" -v l="$lease_bytes" -v lim="$limit" 'BEGIN {
    printf "lease.sh: %.1f MiB would travel (%.1f MiB carried in .lease), limit %.0f MiB\n", b / 1048576, l / 1048576, lim / 1048576 }'
  if (( bytes > limit )); then
    echo "lease.sh: over the limit; run scripts/gpu/lease.sh shrink (or carry less)" >&2
    exit 1
  fi
}

cmd_stage() {
  local dst="${1:?stage DIR}"
  mkdir -p "$dst"
  travelling | tr '\n' '\0' | xargs -0 -r cp --parents -t "$dst"
}

case "${1:-}" in
  prepare) shift; cmd_prepare "$@" ;;
  shrink) shift; cmd_shrink "$@" ;;
  restore) cmd_restore ;;
  init) shift; cmd_init "$@" ;;
  next) shift; cmd_next "$@" ;;
  size) cmd_size ;;
  files) travelling ;;
  stage) shift; cmd_stage "$@" ;;
  *) echo "usage: $0 prepare [DATASET] | shrink [RUN] | size | files | stage DIR | init RUN FILE | next RUN OUTDIR | restore" >&2; exit 2 ;;
esac
