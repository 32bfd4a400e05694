# Sheer: two commands set everything up on a fresh machine.
#   make run   - create .venv on first use, install Sheer editable, start the studio on the sample head
#   make test  - the whole suite (under xvfb-run when there is no display)
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.sheer-installed
PYTEST_ARGS ?=

.PHONY: run test lint bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

run: $(STAMP)
	$(VENV)/bin/sheer $(ARGS)

# pytest exits 5 when it collected no test: the suite has tests, so that fails too (e.g. a PYTEST_ARGS
# that selects nothing).
test: $(STAMP)
	@if [ -z "$$DISPLAY" ]; then \
		echo "No DISPLAY: running the suite under xvfb-run"; \
		xvfb-run -a -s "-screen 0 1920x1080x24" $(PY) -m pytest $(PYTEST_ARGS); rc=$$?; \
	else \
		$(PY) -m pytest $(PYTEST_ARGS); rc=$$?; \
	fi; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests: failing"; fi; \
	exit $$rc

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/lint-imports
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV) build *.egg-info
