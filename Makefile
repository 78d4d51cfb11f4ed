# The README's two commands: `make demo` and `make test`. Both set up .venv on first use.
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
OUT ?= out/demo

.PHONY: demo test test-fast lint docs clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[dev]'
	touch $@

demo: $(VENV)/.installed
	$(BIN)/hitchpark reproduce --out $(OUT)
	$(BIN)/hitchpark ik-study --out $(OUT)/ik_study
	@echo "demo results in $(OUT)/"

test: $(VENV)/.installed   # over every core (pytest-xdist); -n 0 for one process
	$(BIN)/python -m pytest -q -n auto

test-fast: $(VENV)/.installed   # the inner loop: all but the tests marked slow
	$(BIN)/python -m pytest -q -n auto -m "not slow"

lint: $(VENV)/.installed
	$(BIN)/ruff check src tests
	$(BIN)/mypy
	$(BIN)/lint-imports

docs: $(VENV)/.installed
	$(BIN)/sphinx-build -E -W -q -b html docs out/docs
	@echo "documentation in out/docs/index.html"

clean:
	rm -rf $(VENV) out .pytest_cache .mypy_cache .ruff_cache .hypothesis .import_linter_cache
