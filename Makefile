# Every target sets itself up on a fresh machine: it creates .venv and installs dloplan with
# everything its tests need (all extras), so `make demo` and `make test` are the only commands.
# After installing, the numba kernels are compiled into their on-disk cache by parallel
# processes (python -m dloplan.warmup, about a minute on 2 cores): the first run starts warm.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp
UV     := $(BIN)/uv
EXTRAS := .[dev,vision,robot,study,plants]

.PHONY: demo test bench lint browser clean

# uv installs dloplan and its extras into the venv (pip installs uv, an 18 MB wheel): it fetches
# the wheels in parallel and keeps them in its cache, where pip fetched them one at a time and,
# on this project's machines, cached none (50-210 s against 16-28 s; docs/performance.md).
# Like `pip install --no-compile`, uv does not byte-compile the 11 000 modules it installs (40 s
# of CPU); the warm-up writes the bytecode of the modules a run imports (also under
# PYTHONDONTWRITEBYTECODE, where Python would otherwise compile them from source in every process).
# uv reads no pip configuration (index, certificates): where it cannot install, pip does.
$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	{ $(BIN)/python -m pip install --quiet --no-compile 'uv>=0.5' \
	  && $(UV) pip install --quiet --python $(BIN)/python -e '$(EXTRAS)'; } \
	|| { echo "uv could not install: pip installs instead"; \
	     $(BIN)/python -m pip install --quiet --no-compile -e '$(EXTRAS)'; }
	$(BIN)/python -m dloplan.warmup || echo "warm-up incomplete: the rest compiles on first use"
	touch $(STAMP)

# exit code 1 means "planned, with warnings" (shown above it): the demo still succeeded
demo: $(STAMP)
	$(BIN)/dloplan demo -o out/demo || [ $$? -eq 1 ]

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples tools

# The HTML report is tested in headless Chromium: install it where we can (root with apt),
# otherwise that one test is skipped with its reason.
browser:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null \
	  && (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium \
	  >/dev/null) ; } || echo "chromium not installed: the browser test will be skipped"

# --durations=10: the ten slowest test phases (wall), to see where the suite's time goes;
# benchmarks/bench_test_suite.py gives CPU per test and module.
# lint and browser are made side by side (-j2): on a new machine apt-get fetches and installs
# Chromium (2 min at load 8) while uv installs and the warm-up compiles, instead of after them
test:
	$(MAKE) --no-print-directory -j2 lint browser
	$(BIN)/python -m pytest -q -n 2 --dist loadgroup --durations=10

# some benchmarks reuse the tests' scene builders (tests/ on the path)
bench: $(STAMP)
	for f in benchmarks/bench_*.py; do echo "== $$f"; PYTHONPATH=tests $(BIN)/python $$f || exit 1; done

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
