# redservo: two commands that work on a fresh machine with Python >= 3.11 and make.
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-all
TSTAMP := $(VENV)/.installed-test
OUT    ?= out
CHROMIUM ?= /usr/bin/chromium

.PHONY: demo test lint typecheck pytest bench clean chromium

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# demo: only what the commands need (redservo[all]); test: the test tools as well.
$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e '.[all]'
	touch $(STAMP)

$(TSTAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP) $(TSTAMP)

# The viewer's test takes a screenshot with Debian's Chromium: installed when missing and
# running as root (CI); otherwise that test is skipped with a message.
chromium:
	@if [ ! -x $(CHROMIUM) ] && [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
		echo "installing chromium (apt-get) for the viewer's browser test"; \
		apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null 2>&1 || \
		echo "chromium not installed: the viewer's browser test will be skipped"; \
	fi

## make demo: create the environment, install, compile the kernels (redservo warmup, with
## progress), reproduce the papers and write figures to $(OUT)/
demo: $(STAMP)
	$(BIN)/python examples/demo.py --out $(OUT)

## make test: create the environment, install, lint (ruff), type-check (mypy) and run the tests
test: lint typecheck pytest

lint: $(TSTAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

typecheck: $(TSTAMP)
	$(BIN)/mypy

pytest: $(TSTAMP) chromium
	$(BIN)/python -m pytest -q

bench: $(STAMP)
	$(BIN)/redservo bench

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .mypy_cache .ruff_cache
