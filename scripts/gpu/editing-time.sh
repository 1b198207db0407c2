#!/usr/bin/env bash
# Issue 14's time bar on a GPU machine, in one call (about 2 minutes): a 3 × 5 s timeline against one 5 s motion
# with the shipped model's PyTorch weights on the GPU (every window's early steps in one call per step, as the
# page's fp16 file on WebGPU), then the page's int8 ONNX file on that machine's CPU cores (1, 2, 4, 8 threads).
# Needs nothing but the repository and a python3 with torch, numpy, onnxruntime and tokenizers (the GPU image's).
#
#   scripts/gpu/editing-time.sh OUTDIR [MODEL]
#
# Writes OUTDIR/editing-time-<MODEL>-pytorch-cuda.json and OUTDIR/editing-time-<MODEL>-onnxruntime-cpu-int8.json;
# copy them to docs/results/json/ and run `python -m emdm.eval.report` (anywhere) for RESULTS.md's rows.
# EMDM_TIME_TIMELINES (default 12) timelines and single motions are timed per runtime and thread count;
# EMDM_TIME_EXTRA (e.g. "--steps 2 --seconds 2") is appended to both runs: for a smoke test on a CPU.
set -euo pipefail
here="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:?usage: editing-time.sh OUTDIR [MODEL]}"
model="${2:-emdm-t2m-web}"
py="${PYTHON:-python3}"
n="${EMDM_TIME_TIMELINES:-12}"
read -r -a extra <<<"${EMDM_TIME_EXTRA:-}"
export PYTHONPATH="$here/scripts${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
mkdir -p "$out"
weights="$("$py" -c 'import json, sys; print(json.load(open(sys.argv[1]))["models"][sys.argv[2]]["trainingWeights"])' \
  "$here/public/models/manifest.json" "$model")"
device=cuda
"$py" -c 'import torch, sys; sys.exit(0 if torch.cuda.is_available() else 1)' || device=cpu
echo "editing-time: $model, weights $weights on $device"
"$py" -m emdm.eval.editing --time-only --model "$model" --ckpt "$here/public/models/$weights" --device "$device" \
  --time-threads 1 --time-timelines "$n" --out "$out/editing-time-$model-pytorch-$device.json" "${extra[@]}"
"$py" -m emdm.eval.editing --time-only --model "$model" --variant int8 --time-threads 1,2,4,8 --time-timelines "$n" \
  --out "$out/editing-time-$model-onnxruntime-cpu-int8.json" "${extra[@]}"
echo "editing-time: done"
