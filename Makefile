# Sheer: two commands set everything up on a fresh machine.
#   make run   - create .venv on first use, install Sheer editable, start the studio on the sample head
#   make test  - the whole suite on 2 pytest-xdist workers (PYTEST_WORKERS=0: in one process, under
#                xvfb-run when there is no display; each worker starts its own Xvfb)
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.sheer-installed
PYTEST_ARGS ?=
PYTEST_WORKERS ?= 2

.PHONY: run test lint bench clean

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

# The studio and the kiosk need a display: without one, one line says what to do instead of Qt's abort.
# (Other commands, e.g. `make run ARGS="render ..."`, are headless and run anyway.)
NEEDS_DISPLAY := $(if $(filter-out studio kiosk --project --head,$(firstword $(ARGS))),,yes)
run: $(STAMP)
	@if [ -n "$(NEEDS_DISPLAY)" ] && [ -z "$$DISPLAY" ] && [ -z "$$WAYLAND_DISPLAY" ] && [ -z "$$QT_QPA_PLATFORM" ]; then \
		echo "make run: no display (DISPLAY is not set): set DISPLAY to your X server, run it under a virtual one with 'xvfb-run -a make run', or render without a window: '.venv/bin/sheer render --help'" >&2; \
		exit 2; \
	fi
	$(VENV)/bin/sheer $(ARGS)

# pytest exits 5 when it collected no test: the suite has tests, so that fails too (e.g. a PYTEST_ARGS
# that selects nothing). The workers (pytest-xdist, tests/xdist_support.py) get a module or an xdist_group at
# a time, each on its own X server; a worker that crashes fails the run (xdist cannot give its module to a
# new one). PYTEST_WORKERS=0 runs the suite in one process. Compiled modules are kept (__pycache__, ignored by
# git) even where the environment says PYTHONDONTWRITEBYTECODE: the workers and the few dozen `sheer`
# processes the tests start then compile Sheer once, and pytest keeps its assertion-rewritten test modules.
XDIST_ARGS := -n $(PYTEST_WORKERS) $(if $(filter-out 0,$(PYTEST_WORKERS)),--dist loadgroup --max-worker-restart 0)
test: $(STAMP)
	@unset PYTHONDONTWRITEBYTECODE; \
	if [ -z "$$DISPLAY" ]; then \
		echo "No DISPLAY: running the suite under xvfb-run"; \
		xvfb-run -a -s "-screen 0 1920x1080x24" $(PY) -m pytest $(XDIST_ARGS) $(PYTEST_ARGS); rc=$$?; \
	else \
		$(PY) -m pytest $(XDIST_ARGS) $(PYTEST_ARGS); rc=$$?; \
	fi; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests: failing"; fi; \
	exit $$rc

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/lint-imports
	$(VENV)/bin/mypy

clean:
	rm -rf $(VENV) build *.egg-info
