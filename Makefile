# robocourse: the two commands a student needs.
#   make lab   - set up .venv (first time only) and open JupyterLab on the course folder:
#                chapters/ and exercises/ side by side, the robocourse kernel as default
#   make test  - same set-up, then the whole suite (unit tests + every notebook)
# Both are idempotent: the venv is rebuilt only when requirements.txt or pyproject.toml change.

PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.robocourse-installed
KERNEL := robocourse
LAB_FLAGS ?=
# the lab's settings live in the venv, never in your home (robocourse/cli/lab.py says what each does)
PYTEST_FLAGS ?=
# parallel workers for make test (pytest-xdist, one module per worker, serial tests alone: tests/conftest.py);
# TEST_JOBS=0 runs everything in this process
TEST_JOBS ?= 3

.PHONY: lab lab-user test setup kernel exercises lint clean

setup: $(STAMP)

$(STAMP): requirements.txt pyproject.toml
	@$(PYTHON) -c 'import sys; v = sys.version_info; sys.exit(0 if v >= (3, 10) else "robocourse needs Python 3.10 or newer; found %d.%d. Install a newer python3 or run: make PYTHON=python3.11 test" % v[:2])'
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e .
	$(PY) -m ipykernel install --sys-prefix --name $(KERNEL) --display-name "Python (robocourse)" > /dev/null
	@touch $(STAMP)
	@echo "robocourse environment ready in $(VENV)"

kernel: $(STAMP)

# the lab's settings are rewritten at every start (about a second): they depend on where Jupyter's
# runtime folder is now (kernel sockets live there), and a student's saved layout is kept
lab: lab-user $(STAMP)
	$(VENV)/bin/robocourse lab-settings --root . --prefix $(VENV) > /dev/null
	$(VENV)/bin/jupyter lab $(LAB_FLAGS)

# Jupyter refuses to start as root without --allow-root: say why and what to do before any set-up runs
lab-user:
	@if [ "$$(id -u)" = 0 ] && ! printf '%s' "$(LAB_FLAGS)" | grep -Eq -- '--allow-root|allow_root'; then \
	  echo "make lab: you are root (uid 0), and Jupyter refuses to run as root: every notebook would run with root's" >&2; \
	  echo "  powers. Run make lab as your own user; in a container where root is the only user, say so:" >&2; \
	  echo "  make lab LAB_FLAGS=--allow-root" >&2; \
	  exit 2; \
	fi

test: $(STAMP)
	$(PY) -X faulthandler -m pytest -n $(TEST_JOBS) --dist loadgroup $(PYTEST_FLAGS)

exercises: $(STAMP)
	$(VENV)/bin/robocourse exercises build

lint: $(STAMP)
	$(VENV)/bin/ruff check .

clean:
	rm -rf $(VENV) .pytest_cache
