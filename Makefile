# wheelnav: `make demo` runs the demo mission, `make test` the test suite.
# Both create .venv (Python >= 3.11) and install the project into it when needed.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test test-long test-all warm lint format docs bench scenarios campaign clean

$(STAMP): pyproject.toml
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/wheelnav mission scenarios/demo.yaml --report demo-report.json

# make test leaves out the tests marked long (pyproject.toml): they take as long as the rest
# together; make test-long runs only them, make test-all everything. Two workers
# (pytest-xdist), a test file to each: a whole-fleet mission in lockstep waits on round
# trips more than it computes, so two side by side share the two cores well
TEST_WORKERS ?= 2
test: $(STAMP)
	$(PY) -m pytest -q -m "not long" -n $(TEST_WORKERS) --dist loadfile

test-long: $(STAMP)
	$(PY) -m pytest -q -m long

test-all: $(STAMP)
	$(PY) -m pytest -q

# compile every numba kernel into its cache (__pycache__ beside the sources): a first start
# on a fresh clone otherwise compiles them inside the services' start-up (~25 s)
warm: $(STAMP)
	$(PY) -m wheelnav.warm

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(PY) -m wheelnav.import_rules

format: $(STAMP)
	$(VENV)/bin/ruff check --fix .
	$(VENV)/bin/ruff format .

scenarios: $(STAMP)
	$(VENV)/bin/wheelnav scenarios scenarios/*.yaml --reports scenario-reports

# a randomized building campaign (docs/campaign.md); CAMPAIGN_ARGS to change its size
CAMPAIGN_ARGS ?= --buildings 12 --seed 0 --missions 9
campaign: $(STAMP)
	$(VENV)/bin/wheelnav campaign $(CAMPAIGN_ARGS) --out campaign

bench: $(STAMP)
	$(PY) -m pip install --quiet -e '.[bench]'
	$(VENV)/bin/wheelnav bench planner

docs: $(STAMP)
	$(PY) -m wheelnav.docs

clean:
	rm -rf $(VENV) demo-report.json scenario-reports campaign
