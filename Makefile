# `make demo` and `make test` bootstrap everything they need on a fresh machine.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
# System packages the tests and the demo need (Debian names): udev for udevadm
# (the real-udev rules test), libusb-1.0-0 for pyusb (Huion vendor init).
SYSPKGS := umockdev gir1.2-umockdev-1.0 python3-gi chromium nodejs udev libusb-1.0-0
PYTEST_ARGS ?=

.PHONY: test demo sysdeps venv lint typecheck pytest bench node-deps clean fuzz

test: sysdeps venv node-deps lint typecheck pytest

demo: sysdeps venv
	$(BIN)/stiction demo

sysdeps:
	@bash scripts/ensure-sysdeps.sh $(SYSPKGS)

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test,bench,experiment]'
	touch $@

node-deps:
	@if [ -f clients/examples/node/package.json ]; then \
	  cd clients/examples/node && { [ -d node_modules ] || npm ci --no-audit --no-fund --loglevel=error; }; \
	fi

lint: venv
	$(BIN)/ruff check src tests fuzz
	$(BIN)/ruff format --check src tests fuzz

typecheck: venv
	$(BIN)/mypy

pytest: venv
	$(BIN)/python -m pytest $(PYTEST_ARGS)

# Benchmarks are not part of `make test`: they measure, tests assert. Results go
# to ~/.cache/stiction/bench/; `make bench BENCH_ARGS=--save` updates the
# committed figures in bench/results/ that the docs quote.
BENCH_ARGS ?=
bench: venv
	$(BIN)/stiction bench all $(BENCH_ARGS)

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache .hypothesis

# Coverage-guided fuzzing (atheris/libFuzzer) of every parser of user input,
# FUZZ_SECONDS each; not part of `make test`. Crashes land in tests/regressions/.
FUZZ_SECONDS ?= 60
FUZZ_TARGETS := hid_descriptor hid_recording evemu libinput_record scene trace control_request
fuzz: venv
	$(BIN)/python -m pip install -q -e '.[fuzz]'
	@for t in $(FUZZ_TARGETS); do \
	  echo "fuzzing $$t for $(FUZZ_SECONDS) s"; \
	  $(BIN)/python fuzz/run.py $$t -max_total_time=$(FUZZ_SECONDS) -print_final_stats=1 || exit 1; \
	done
