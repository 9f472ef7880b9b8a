# facesynth developer commands. `make demo` and `make test` work on a fresh clone: they create
# .venv and install facesynth with every extra first.
VENV ?= .venv
PYTHON ?= python3
BIN := $(VENV)/bin

.PHONY: demo test lint bench install clean test-deploy test-containers test-netns test-board

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[all,test]'
	touch $@

install: $(BIN)/.installed

## The bundled performer video through S -> P -> F -> T -> C; servo commands in facesynth-commands.jsonl.
demo: $(BIN)/.installed
	$(BIN)/facesynth run

## Lint, type-check, schema freshness, and the whole test suite.
test: $(BIN)/.installed lint
	$(BIN)/python -m pytest -q

## The deployment groups (root; .ci/run installs what they need): docker-compose on Podman,
## services on separate hosts in network namespaces, the servo-board install.
test-deploy: test-board test-netns test-containers

test-containers: $(BIN)/.installed
	$(BIN)/python -m pytest -q -s -m containers tests/containers

test-netns: $(BIN)/.installed
	$(BIN)/python -m pytest -q -s -m netns tests/netns

test-board: $(BIN)/.installed
	$(BIN)/python -m pytest -q -s -m board tests/board

lint: $(BIN)/.installed
	$(BIN)/ruff check .
	$(BIN)/mypy
	$(BIN)/lint-imports --no-cache
	$(BIN)/python -m schemas.export --check

bench: $(BIN)/.installed
	$(BIN)/facesynth bench chain
	$(BIN)/facesynth bench tracker

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache facesynth-commands.jsonl
