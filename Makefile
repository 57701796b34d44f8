# The two commands of the README: `make run` (install + start the service) and `make test`.
SHELL := /bin/bash
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin

.PHONY: run test lint install install-test web fbx-writer

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip

# Re-install only when the dependency lists change.
$(VENV)/.installed: pyproject.toml $(BIN)/python
	$(BIN)/pip install -q -e .
	touch $@

node_modules/.installed: package.json package-lock.json
	npm ci --no-audit --no-fund --loglevel=error
	touch $@

web: node_modules/.installed $(VENV)/.installed
	npm run --silent build

install: $(VENV)/.installed node_modules/.installed web

run: install
	$(BIN)/rigforge serve

$(VENV)/.installed-test: pyproject.toml $(VENV)/.installed
	$(BIN)/pip install -q -e '.[test]'
	touch $@

install-test: install $(VENV)/.installed-test
	@command -v chromium >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null)
	@command -v assimp >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq assimp-utils >/dev/null)
	@command -v docker-compose >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq docker-compose >/dev/null)

# Optional FBX writer: Blender's bpy in its own venv (it needs numpy<2; ~1 GB). simcore/io/fbx_export.py finds it.
fbx-writer:
	test -x .venv-fbx/bin/python || $(PYTHON) -m venv .venv-fbx
	.venv-fbx/bin/pip install -q 'bpy==5.0.1' 'numpy<2'

# ruff and mypy (configured in pyproject.toml; mypy keeps its cache in .mypy_cache) before the suite.
lint: $(VENV)/.installed-test
	$(BIN)/ruff check .
	$(BIN)/mypy

test: install-test lint
	$(BIN)/pytest
