#!/usr/bin/env bash
# Run every test suite, even when one fails; print one summary line per suite; exit non-zero if
# any failed. pytest's exit 5 (no tests collected) is a failure like any other non-zero exit.
set -uo pipefail
cd "$(dirname "$0")/../.."
export CI="${CI:-true}"
LOGDIR=".ci-logs"
mkdir -p "$LOGDIR"
declare -a SUMMARY=()
FAILED=0

run_suite() {
  local name="$1"; shift
  local log="$LOGDIR/$name.log"
  local t0=$SECONDS
  echo "=== $name: $* (log: $log)"
  "$@" 2>&1 | tee "$log"
  local rc=${PIPESTATUS[0]}
  local dt=$((SECONDS - t0))
  if [[ $rc == 0 ]]; then
    SUMMARY+=("PASS  $name (${dt}s)")
  else
    SUMMARY+=("FAIL  $name (exit $rc, ${dt}s; see $log)")
    FAILED=1
  fi
}

run_suite typecheck npx tsc --noEmit
run_suite vitest npx vitest run
run_suite pytest .venv/bin/python -m pytest tests/python -q
run_suite playwright npx playwright test

echo
echo "=== summary"
for line in "${SUMMARY[@]}"; do echo "$line"; done
exit $FAILED
