# wheelnav: `make demo` runs the demo mission, `make test` the test suite.
# Both create .venv (Python >= 3.11) and install the project into it when needed.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test lint format docs bench scenarios clean

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/wheelnav mission scenarios/demo.yaml --report demo-report.json

test: $(STAMP)
	$(PY) -m pytest -q

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m wheelnav.import_rules

format: $(STAMP)
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .

scenarios: $(STAMP)
	$(VENV)/bin/wheelnav scenarios scenarios/*.yaml --reports scenario-reports

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	$(VENV)/bin/wheelnav bench planner

docs: $(STAMP)
	$(PY) -m wheelnav.docs

clean:
	rm -rf $(VENV) demo-report.json scenario-reports
