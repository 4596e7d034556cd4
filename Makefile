# The compendium's commands. `make test` and `make figures` set everything up.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
READY  := $(VENV)/.ready

NOTEBOOKS := $(wildcard notebooks/[0-9][0-9]_*.ipynb)

export SOURCE_DATE_EPOCH := 0
export PYTHONHASHSEED := 0
export MUTUAL_CACHE_DIR ?= $(CURDIR)/.cache
export PYDEVD_DISABLE_FILE_VALIDATION := 1
export OMP_NUM_THREADS ?= 2
export OPENBLAS_NUM_THREADS ?= 2

.PHONY: figures test bench lab lock clean distclean env

## figures: run every notebook (full parameters), rebuild figures/ and figures/REPRODUCTION.md
figures: $(READY)
	@echo "==> executing $(words $(NOTEBOOKS)) notebooks with papermill (executed copies in build/)"
	$(BIN)/python -m mutual.compendium.notebooks $(NOTEBOOKS)
	@echo "==> building the reproduction report"
	$(BIN)/python -m mutual.compendium.report

## test: unit tests plus a quick run of every notebook
test: $(READY)
	@echo "==> running the tests (unit tests and every notebook with quick parameters)"
	$(BIN)/python -m pytest

## bench: timings side by side, printed and written to figures/benchmarks.md
bench: $(READY)
	$(BIN)/python bench/run.py

## lab: JupyterLab on the notebooks with the project's kernel
lab: $(READY)
	$(BIN)/jupyter lab --notebook-dir=notebooks

## env: create or refresh the pinned environment only
env: $(READY)

# The environment is rebuilt whenever the lock or the package metadata changes.
$(READY): environment.lock pyproject.toml
	@echo "==> installing the pinned environment into $(VENV) (hash-checked, from environment.lock)"
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --disable-pip-version-check --progress-bar on \
		--require-hashes --no-deps -r environment.lock
	$(BIN)/python -m pip install --disable-pip-version-check --no-deps --no-build-isolation -e .
	$(BIN)/python -m ipykernel install --sys-prefix --name mutual --display-name "Python (mutual)"
	@touch $@

## lock: recompile environment.lock from requirements.in (pins and hashes, Python 3.11);
##       keeps current pins where they still fit; `make lock LOCKFLAGS=--upgrade` upgrades all
lock:
	@test -x build/lock-tools/bin/pip-compile || \
		($(PYTHON) -m venv build/lock-tools && build/lock-tools/bin/pip install -q pip-tools)
	build/lock-tools/bin/pip-compile --generate-hashes --allow-unsafe --strip-extras \
		--no-emit-index-url $(LOCKFLAGS) -o environment.lock requirements.in

## clean: remove executed notebooks, caches and build products (keeps the environment)
clean:
	rm -rf build .cache .pytest_cache
	find . -name __pycache__ -not -path "./$(VENV)/*" -prune -exec rm -rf {} +

## distclean: clean, and remove the environment too
distclean: clean
	rm -rf $(VENV)
