# The two entry points of a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-slow lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

# The main job on built-in defaults: the predictors on real recorded motion, then a
# reduced run of the paper's experiment (3 trials x 40 frames) and its report.
demo: $(STAMP)
	$(BIN)/handvar predict examples/data/htrack-fingerfist.txt --layout htrack --reset-at 4000
	$(BIN)/handvar experiment --quick --out demo/experiment.zarr
	$(BIN)/handvar report demo/experiment.zarr --out demo/report

test: $(STAMP)
	$(BIN)/ruff check src tests benchmarks studies
	$(BIN)/python -m pytest

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks studies examples
	$(BIN)/ruff format --check src tests benchmarks studies examples

test-slow: $(STAMP)
	$(BIN)/python -m pytest -m slow

# Every timing benchmark of benchmarks/ (the accuracy studies are in studies/, each run
# on its own: studies/README.md).
bench: $(STAMP)
	for b in benchmarks/*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) build src/*.egg-info demo
