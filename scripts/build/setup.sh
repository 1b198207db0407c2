#!/usr/bin/env bash
# Idempotent set-up steps used by the Makefile: `setup.sh node|python|chromium`.
# Each step keeps a stamp (hash of its inputs) and returns at once when nothing changed.
set -euo pipefail
cd "$(dirname "$0")/../.."

hash_of() { cat "$@" | sha256sum | cut -d' ' -f1; }

setup_node() {
  command -v npm >/dev/null || { echo "setup: npm not found; install Node.js >= 20 (https://nodejs.org)" >&2; exit 1; }
  local want; want="$(hash_of package.json package-lock.json)"
  if [[ -f node_modules/.emdm-stamp && "$(cat node_modules/.emdm-stamp)" == "$want" ]]; then
    echo "setup node: up to date"
  else
    echo "setup node: npm ci (ONNXRUNTIME_NODE_INSTALL_CUDA=skip)"
    ONNXRUNTIME_NODE_INSTALL_CUDA=skip npm ci --no-audit --no-fund
    echo "$want" > node_modules/.emdm-stamp
  fi
}

setup_python() {
  local py="${PYTHON:-python3}"
  if [[ ! -x .venv/bin/python ]]; then
    "$py" -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else 1)' \
      || { echo "setup: $py is $("$py" --version 2>&1); Python >= 3.11 is required (set PYTHON=...)" >&2; exit 1; }
    echo "setup python: creating .venv with $("$py" --version 2>&1)"
    "$py" -m venv .venv
  fi
  local want; want="$(hash_of requirements.txt pyproject.toml)"
  if [[ -f .venv/.emdm-stamp && "$(cat .venv/.emdm-stamp)" == "$want" ]]; then
    echo "setup python: up to date"
    return
  fi
  echo "setup python: pip install -r requirements.txt && pip install -e ."
  .venv/bin/python -m pip install --disable-pip-version-check -q --upgrade pip
  .venv/bin/python -m pip install --disable-pip-version-check -q -r requirements.txt
  .venv/bin/python -m pip install --disable-pip-version-check -q --no-deps -e .
  echo "$want" > .venv/.emdm-stamp
}

setup_chromium() {
  local chrome="${CHROMIUM_PATH:-/usr/bin/chromium}"
  if [[ -x "$chrome" ]]; then
    echo "setup chromium: $chrome present"
    return
  fi
  echo "setup chromium: apt-get install -y chromium"
  local sudo=""
  [[ "$(id -u)" == 0 ]] || sudo="sudo"
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get update
  $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y chromium
}

case "${1:-}" in
  node) setup_node ;;
  python) setup_python ;;
  chromium) setup_chromium ;;
  *) echo "usage: $0 node|python|chromium" >&2; exit 2 ;;
esac
