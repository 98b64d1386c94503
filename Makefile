# evomesh: `make run` starts the service, `make test` runs every check. Both bootstrap .venv first.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Debian packages the test suite needs (installed when missing and run as root): chromium for
# the web viewer's end-to-end tests (headless, driven over its DevTools pipe).
APT_PACKAGES := chromium
# Debian libraries the gmsh wheel links against (for the side-by-side benchmarks).
BENCH_APT_PACKAGES := libglu1-mesa libxcursor1 libxft2 libxinerama1 libgomp1
PYTEST_ARGS ?=

.PHONY: run test bench lint typecheck system-deps clean

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dask,formats,test]'
	@touch $(STAMP)

$(VENV)/.bench-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e '.[bench]'
	@touch $@

run: $(STAMP)
	$(BIN)/evomesh serve

system-deps:
	@missing=""; for p in $(APT_PACKAGES); do dpkg -s $$p >/dev/null 2>&1 || missing="$$missing $$p"; done; \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends $$missing; \
	  else echo "missing Debian packages:$$missing (run 'make test' as root, or install them)" >&2; exit 1; fi; \
	fi

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/mypy engine service

test: $(STAMP) system-deps lint typecheck
	$(BIN)/python -m pytest -n auto $(PYTEST_ARGS)

bench: $(VENV)/.bench-installed
	@$(MAKE) --no-print-directory system-deps APT_PACKAGES="$(BENCH_APT_PACKAGES)"
	@set -e; for script in benchmarks/*_bench.py; do echo "== $$script"; $(BIN)/python $$script; done

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache .hypothesis
