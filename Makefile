# The README's two commands: `make demo` and `make test`. Each builds .venv from nothing.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
# small dense matrices: one BLAS thread is fastest (see solutions/__init__.py)
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

.PHONY: demo test test-fast lint bench clean sandbox-tools browser-tools
# A target's prerequisites are made side by side (the venv and bubblewrap, each waiting on the network).
MAKEFLAGS += --jobs=2

# The venv is filled by uv (PyPI's uv wheel, installed first with pip): the same versions pip resolves, 58 s
# against pip's 83 s on an empty cache (2 cores), on the critical path of `make test` (nothing runs before it).
# Bytecode is compiled at install as pip does: the grader's sandbox and its kernel import from a read-only
# site-packages, where a module without its .pyc would be compiled again by every process. pip does it all
# when uv cannot.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip uv
	$(BIN)/python -m uv pip install --quiet --compile-bytecode --python $(BIN)/python -e ".[dev]" || \
	  $(BIN)/python -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP) sandbox-tools
	MPLBACKEND=Agg $(BIN)/python -m course.demo

# The grader's sandbox is bubblewrap (Debian package bubblewrap): installed here when missing and we are
# root with apt-get (CI); otherwise one line says that the isolation tests will be skipped.
sandbox-tools:
	@command -v bwrap >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq bubblewrap >/dev/null 2>&1 || { \
	      apt-get update -qq >/dev/null 2>&1; DEBIAN_FRONTEND=noninteractive apt-get install -y -qq bubblewrap; } || \
	      echo "apt-get could not install bubblewrap: the isolation tests will be skipped"; \
	  else \
	    echo "bubblewrap (bwrap) not found and not root with apt-get: the isolation tests will be skipped (apt-get install bubblewrap)"; \
	  fi; }

# The browser tests (tests/solutions/test_viewer_browser.py) drive Debian's chromium with Playwright: installed here
# when missing and we are root with apt-get (CI), after bubblewrap (one apt-get at a time); otherwise one line says
# that the browser tests will be skipped.
browser-tools: sandbox-tools
	@command -v chromium >/dev/null 2>&1 || { \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null 2>&1 || { \
	      apt-get update -qq >/dev/null 2>&1; \
	      DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; } || \
	      echo "apt-get could not install chromium: the browser tests will be skipped"; \
	  else \
	    echo "chromium not found and not root with apt-get: the browser tests will be skipped (apt-get install chromium)"; \
	  fi; }

# Tests run on every core (pytest-xdist). Each work unit is a test file (--dist loadfile; the nbgrader cycle is
# one file per homework), so that a unit's module-scoped fixtures (a nbgrader course, a graded class, a Dask
# cluster) are built once. (Not --dist loadgroup: with pytest 9 its xdist_group marks are ignored, every test is a
# unit of its own and module fixtures were built on both workers.) Units are handed out in collection order
# (--no-loadscope-reorder: the slow tier first, longest first, tests/conftest.py SLOW), not by test count.
# One compiled cache for the run (build/test-cache/compiled), warnings are errors (pyproject), 20 slowest listed.
# `make test-fast` leaves the slow tier out (a quick loop; CI runs `make test`, everything).
TEST_WORKERS ?= auto
PYTEST := MPLBACKEND=Agg $(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile --no-loadscope-reorder
test: $(STAMP) sandbox-tools browser-tools
	$(BIN)/ruff check solutions course autograder mbdkit tests benchmarks
	$(BIN)/ruff format --check solutions course autograder mbdkit tests benchmarks
	$(PYTEST) --durations=20 --junitxml=build/junit.xml  # per-file times: python benchmarks/durations.py build/junit.xml

test-fast: $(STAMP)
	$(BIN)/ruff check solutions course autograder mbdkit tests benchmarks
	$(BIN)/ruff format --check solutions course autograder mbdkit tests benchmarks
	$(PYTEST) --durations=10 -m "not slow"

# modules/ is generated from solutions/ (every homework stubbed), committed, never edited by hand.
.PHONY: modules
modules: $(STAMP)
	$(BIN)/python -m course.release modules

# The course notes as HTML pages: build/notes/index.html (every chapter executed; mbd notes --help)
.PHONY: notes
notes: $(STAMP)
	MPLBACKEND=Agg $(BIN)/mbd notes --out build/notes

# Golden summaries of the example models (tests/solutions/golden_summaries.json): regenerate after a change meant
# to change results, then review the diff (tests/solutions/golden.py).
.PHONY: golden
golden: $(STAMP)
	$(BIN)/python tests/solutions/golden.py

# The numba engine compiled once for this machine (`mbd compile`, a progress bar; nothing to do when it is on disk):
# no later run waits for a compilation, and every run that repays loading it takes it by default (engine auto).
# Not a step of `make demo` (issue 27 wants the demo in about a minute; this takes one to two on 2 cores): a run
# that repays a first compilation makes what it needs, saying so on stderr.
.PHONY: compile
compile: $(STAMP)
	$(BIN)/mbd compile

bench: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python benchmarks/kinematics.py

clean:
	rm -rf $(VENV) build *.egg-info out
