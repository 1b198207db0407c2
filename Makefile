# The two commands of the README:
#   make demo   install what the demo needs, build, serve on http://127.0.0.1:5173 (shipped models)
#   make test   install everything (npm deps, Python venv, Debian chromium) and run every suite
SHELL := /bin/bash
PORT ?= 5173

.PHONY: demo test setup setup-node setup-python setup-chromium build typecheck unit pytest e2e bench-text export-minilm fixtures-text

demo: setup-node build
	@echo "EMDM demo: http://127.0.0.1:$(PORT)/  library example: http://127.0.0.1:$(PORT)/examples/minimal.html  (Ctrl-C to stop)"
	npx vite preview --host 127.0.0.1 --port $(PORT) --strictPort

test: setup
	bash scripts/build/test-all.sh

setup: setup-node setup-python setup-chromium

setup-node:
	bash scripts/build/setup.sh node

setup-python:
	bash scripts/build/setup.sh python

setup-chromium:
	bash scripts/build/setup.sh chromium

build: setup-node
	npx vite build

# single suites (after `make setup`)
typecheck:
	npx tsc --noEmit
unit:
	npx vitest run
pytest:
	.venv/bin/python -m pytest tests/python -q
e2e:
	npx playwright test

# text encoder tools
bench-text:
	node scripts/build/bench-text.mjs
export-minilm:
	.venv/bin/python -m emdm.text.export_minilm
fixtures-text:
	.venv/bin/python -m emdm.text.fixtures
