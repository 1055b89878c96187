# redservo: two commands that work on a fresh machine with Python >= 3.11 and make.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-all
TSTAMP := $(VENV)/.installed-test
DSTAMP := $(VENV)/.installed-docs
OUT    ?= out
CHROMIUM ?= /usr/bin/chromium

.PHONY: demo test lint typecheck warm warm-examples pytest bench clean chromium egl docs

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# demo: only what the commands need (redservo[all]); test: the test tools as well.
# --no-compile: pip would byte-compile every module of every package it installs (11,500
# files, about 25 CPU-s, the largest CPU item of the install); Python compiles the modules a
# command imports, on their first import, instead.
$(STAMP): $(BIN)/python pyproject.toml
	@echo "== installing redservo[all] into $(VENV) (a minute or two on a fresh machine)"
	$(BIN)/python -m tests.heartbeat $(BIN)/python -m pip install --quiet --no-compile -e '.[all]'
	touch $(STAMP)

$(TSTAMP): $(BIN)/python pyproject.toml
	@echo "== installing redservo[test] into $(VENV) (a minute or two on a fresh machine)"
	$(BIN)/python -m tests.heartbeat $(BIN)/python -m pip install --quiet --no-compile -e '.[test]'
	touch $(STAMP) $(TSTAMP)

# System packages, installed with apt-get when missing and running as root (a fresh machine, CI),
# each announced by one line that says what and how to skip it; without them the tests that
# need them are skipped with a message. Skip: make test CHROMIUM_INSTALL=0 EGL_INSTALL=0 (or
# the same names in the environment). APT_GET: the installer (a stand-in in the Makefile's test).
CHROMIUM_INSTALL ?= 1
EGL_INSTALL ?= 1
APT_GET ?= apt-get

# The viewer's test takes a screenshot with Debian's Chromium (the chromium package).
chromium:
	@if [ -x $(CHROMIUM) ]; then :; \
	elif [ "$(CHROMIUM_INSTALL)" = 0 ]; then \
		echo "chromium: not installed (CHROMIUM_INSTALL=0): the viewer's browser test will be skipped"; \
	elif [ "$$(id -u)" != 0 ] || ! command -v $(APT_GET) >/dev/null; then \
		echo "chromium: not installed (needs root and apt-get): the viewer's browser test will be skipped"; \
	else \
		echo "== installing Debian's chromium with apt-get as root, for the viewer's browser test (skip: make test CHROMIUM_INSTALL=0)"; \
		$(APT_GET) update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive $(APT_GET) install -y -qq chromium >/dev/null 2>&1 || \
		echo "chromium not installed: the viewer's browser test will be skipped"; \
	fi

# MuJoCo renders offscreen through EGL (MUJOCO_GL=egl, docs/physics.md): Debian's libegl1 (the
# loader), libegl-mesa0 (Mesa's EGL) and libgl1-mesa-dri (its software rasterizer).
egl:
	@if ldconfig -p 2>/dev/null | grep -q 'libEGL_mesa.so.0'; then :; \
	elif [ "$(EGL_INSTALL)" = 0 ]; then \
		echo "egl: not installed (EGL_INSTALL=0): the MuJoCo rendering tests will be skipped"; \
	elif [ "$$(id -u)" != 0 ] || ! command -v $(APT_GET) >/dev/null; then \
		echo "egl: not installed (needs root and apt-get): the MuJoCo rendering tests will be skipped"; \
	else \
		echo "== installing Debian's libegl1 libegl-mesa0 libgl1-mesa-dri with apt-get as root, for MuJoCo's offscreen rendering (skip: make test EGL_INSTALL=0)"; \
		$(APT_GET) update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive $(APT_GET) install -y -qq libegl1 libegl-mesa0 \
			libgl1-mesa-dri >/dev/null 2>&1 || \
		echo "EGL not installed: the MuJoCo rendering tests will be skipped"; \
	fi

## make demo: create the environment, install, reproduce the papers, run a small campaign and
## one animated run, and write figures to $(OUT)/ (kernels uncompiled until `redservo warmup`)
demo: $(STAMP) egl
	$(BIN)/python examples/demo.py --out $(OUT)

## make test: create the environment, install, lint (ruff), compile the numba kernels on both
## cores (mypy beside them), and run the tests on two pytest-xdist workers
## (as root it also apt-get installs chromium and EGL when missing; CHROMIUM_INSTALL=0 EGL_INSTALL=0 skip)
test: lint
	@$(MAKE) --no-print-directory -j2 typecheck warm
	@$(MAKE) --no-print-directory pytest WARMED=1

lint: $(TSTAMP)
	@echo "== lint: ruff check and ruff format --check (a few seconds)"
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

typecheck: $(TSTAMP)
	@echo "== type-check: mypy on src/redservo (about a minute the first time, cached after)"
	$(BIN)/python -m tests.heartbeat $(BIN)/mypy

# The kernels the tests run compiled (tests/conftest.py), once, before the workers start: each
# worker would otherwise compile the same kernels at the same time. A warm cache takes seconds.
# WARM_JOBS processes share the compilations (redservo warmup --jobs).
WARM_JOBS ?= 2
warm: $(TSTAMP)
	@echo "== warm-up: redservo warmup --jobs $(WARM_JOBS) compiles the numba kernels once into their on-disk cache (a few minutes on a fresh clone, seconds after)"
	$(BIN)/redservo warmup --jobs $(WARM_JOBS)

# The worked extension examples (a law, a robot kind) compile a step chain of their own, once,
# into examples/__pycache__/numba-examples (tests/examples_cache.py), after the warm-up, whose
# cache they copy and share for every kernel their extensions leave unchanged. `make test`
# leaves that to their two tests (one xdist group, scheduled among the first), which compile
# it on one worker while the other runs tests; `make warm-examples` compiles it ahead.
warm-examples: $(TSTAMP) warm
	$(BIN)/python -m tests.examples_cache

# Two workers (-n 2); tests sharing a port range, a browser or a module-scoped fixture keep to
# one worker (xdist groups, tests/conftest.py). PYTEST_WORKERS=0: all in the pytest process.
# (Three workers on the two cores were measured and not kept: docs/decisions.md, make test.)
# `make test` has just warmed the cache (WARMED=1); `make pytest` alone warms it first.
# The summary lists the 30 slowest tests, the kernels the tests still compiled (the
# warm-up's gaps, tests/compile_report.py) and the test files that took the most CPU
# (tests/cpu_report.py: the figure that adds up to the run's CPU time, wall time being the load's).
PYTEST_WORKERS ?= 2
pytest: $(TSTAMP) chromium egl $(if $(WARMED),,warm)
	@echo "== tests: pytest on $(PYTEST_WORKERS) workers collects the tests, then prints a dot per test (and a line every 10 s for a test that runs long)"
	$(BIN)/python -m pytest -q -p tests.heartbeat -p tests.compile_report -p tests.cpu_report --durations=30 \
		-n $(PYTEST_WORKERS) --dist loadgroup

## make docs: the documentation site (MkDocs Material, API reference from the docstrings)
## into site/, strictly: a broken link or reference fails the build
$(DSTAMP): $(BIN)/python pyproject.toml
	@echo "== installing redservo[docs] (MkDocs Material, mkdocstrings) into $(VENV)"
	$(BIN)/python -m tests.heartbeat $(BIN)/python -m pip install --quiet --no-compile -e '.[docs]'
	touch $(DSTAMP)

docs: $(DSTAMP)
	@echo "== docs: mkdocs build --strict into site/"
	NO_MKDOCS_2_WARNING=1 $(BIN)/python -m mkdocs build --strict --site-dir site

bench: $(STAMP)
	$(BIN)/redservo bench

clean:
	rm -rf $(VENV) $(OUT) site .pytest_cache .mypy_cache .ruff_cache
