# Two commands do all set-up on a fresh machine:
#   make demo   -> virtual environment, install, run the main job on embedded example data
#   make test   -> same environment plus the test extra, run the test suite
#   make docs   -> same environment plus the docs extra, build docs/_build/html (warnings are errors)
PYTHON ?= python3
VENV   ?= .venv
BIN    := $(VENV)/bin

.PHONY: demo test docs reports bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# the package alone for the demo; the test extra only for the tests
$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

$(VENV)/.installed-docs: $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $@

demo: $(VENV)/.installed
	$(BIN)/python examples/demo.py --out reports/demo

# -n 2 --dist loadfile: two pytest-xdist workers (the CI machine has 2 cores); a
# whole test file goes to one worker, so a module-scoped fixture (the batch
# run, the UVW calibration) is computed once, not once per worker.
test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -q --durations=20 -n 2 --dist loadfile

# the documentation site: user guide, command reference (from the argparse
# parsers), API reference, science, gallery, validation; nothing is fetched
docs: $(VENV)/.installed-docs
	$(BIN)/python -m sphinx -W --keep-going -q -b html docs docs/_build/html

reports: $(VENV)/.installed-test
	$(BIN)/python examples/make_reports.py

bench: $(VENV)/.installed-test
	$(BIN)/python benchmarks/bench_speed.py

clean:
	rm -rf $(VENV) build *.egg-info docs/_build docs/generated
