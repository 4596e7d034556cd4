# The compendium's commands. `make test` and `make figures` set everything up.
PYTHON ?= python3.11
VENV   := .venv
BIN    := $(VENV)/bin
READY  := $(VENV)/.ready
PEERS       := .venv-peers
PEERS_READY := $(PEERS)/.ready
# What installs environment.lock: uv (pinned in installer.lock), or pip (`make env INSTALLER=pip`: pip reads the
# machine's pip settings, a mirror or a wheel folder, which uv does not: it has its own, UV_INDEX_URL, ...)
INSTALLER ?= uv
ifeq ($(INSTALLER),uv)
INSTALL := $(BIN)/uv pip install --python $(BIN)/python --compile-bytecode
else ifeq ($(INSTALLER),pip)
INSTALL := $(BIN)/python -m pip install --disable-pip-version-check
else
$(error INSTALLER must be uv or pip, not $(INSTALLER))
endif

NOTEBOOKS := $(wildcard notebooks/[0-9][0-9]_*.ipynb)

export SOURCE_DATE_EPOCH := 0
export PYTHONHASHSEED := 0
export MUTUAL_CACHE_DIR ?= $(CURDIR)/.cache
export PYDEVD_DISABLE_FILE_VALIDATION := 1
export OMP_NUM_THREADS ?= 2
export OPENBLAS_NUM_THREADS ?= 2

# The git clean filter that strips outputs from notebooks on `git add` (.gitattributes): nbstripout,
# with the compendium's settings (lib/mutual/compendium/hygiene.py; also the lab's pre-save hook)
NBSTRIP := $(BIN)/python -m mutual.compendium.hygiene
# JupyterLab refuses to start as root without --allow-root
LABFLAGS   ?=
ALLOW_ROOT := $(if $(filter 0,$(shell id -u)),--allow-root)

.PHONY: figures test bench bench-quick bench-peers lab book test-browser lock lock-peers clean distclean env git-filter

## figures: run every notebook (full parameters), rebuild figures/, data/ and figures/REPRODUCTION.md;
##          the only command that writes them (and the README's verdict counts)
figures: $(READY) git-filter
	@echo "==> executing $(words $(NOTEBOOKS)) notebooks (outputs to figures/, executed copies in build/executed/)"
	$(BIN)/python -m mutual.compendium.notebooks --output figures $(NOTEBOOKS)
	@echo "==> building the reproduction report"
	$(BIN)/python -m mutual.compendium.report --output figures --readme README.md

## test: unit tests plus a quick run of every notebook (outputs to a temporary folder): the unit tests on
##       WORKERS pytest-xdist workers, a file each at a time, beside the notebook lane (`make test WORKERS=8`
##       on a larger machine; WORKERS=0: one process, as a plain `pytest` runs)
WORKERS ?= 2
test: $(READY) git-filter
	@echo "==> running the tests (unit tests and every notebook with quick parameters)"
	$(BIN)/python -m pytest -n $(WORKERS) --dist loadfile --no-loadscope-reorder

## bench: timings side by side, printed and written to figures/benchmarks.md;
##        `make bench QUICK=1` (or `make bench-quick`): small sizes, written to build/bench/ only
bench: $(READY)
	$(BIN)/python bench/run.py $(if $(QUICK),--quick)

bench-quick:
	$(MAKE) bench QUICK=1

## bench-peers: our solvers and statistics against crocoddyl (FDDP), CasADi + IPOPT and pingouin, in a
##              separate pinned environment $(PEERS) (bench/peers/requirements.lock, about 2.5 GB; never
##              part of environment.lock); writes its own section of figures/benchmarks.md, which
##              `make bench` keeps (and this keeps `make bench`'s); QUICK=1: small sizes, to build/bench/;
##              JAX compiles into an empty cache (build/bench/peers-jax), so compile times are cold; the
##              peers run on one OpenMP/BLAS thread (their fastest for these small problems here)
bench-peers: $(PEERS_READY)
	rm -rf build/bench/peers-jax
	JAX_COMPILATION_CACHE_DIR=$(CURDIR)/build/bench/peers-jax OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 \
		$(PEERS)/bin/python bench/run.py --peers $(if $(QUICK),--quick)

## lab: JupyterLab on notebooks/00_overview.ipynb with the kernel "mutual"; what you run there
##      writes to build/scratch/, never to figures/, and notebooks/ are saved without outputs
##      (extra flags: make lab LABFLAGS="--no-browser --port=8899")
lab: $(READY) git-filter
	@echo "==> JupyterLab: outputs of notebooks run here go to build/scratch/ (only make figures writes figures/)"
	env -u MUTUAL_OUTPUT_DIR $(BIN)/jupyter lab --ServerApp.root_dir="$(CURDIR)" $(ALLOW_ROOT) \
		--ContentsManager.pre_save_hook=mutual.compendium.hygiene.strip_before_save $(LABFLAGS) \
		notebooks/00_overview.ipynb

## book: the rendered book (Jupyter Book 2 / MyST) of the notebooks as `make figures` executed them
##       (build/executed/), with the README, the report and the benchmarks, as a static site in build/book/;
##       serve it with `.venv/bin/python book/serve.py`. Needs node >= 18 and npm; the first run
##       builds the site theme from book/theme with pinned npm packages (the npm registry, a few minutes)
book: $(READY)
	$(BIN)/python book/build.py

## test-browser: headless Chromium (Debian's, apt-get installs it when missing) through Playwright:
##               JupyterLab runs the overview and chapter 6 and moves a widget, the book's pages render;
##               screenshots in build/screenshots/. Not part of `make test`; needs `make figures` and `make book`
test-browser: $(READY) git-filter
	$(BIN)/python -m pytest tests/browser -v -p no:cacheprovider

## env: create or refresh the pinned environment and the git filter
env: $(READY) git-filter

# Installs (or updates) the nbstripout filter in this clone's git config; commands run from the
# top of the work tree, so the relative path finds this checkout's .venv. Outside git: nothing.
git-filter: $(READY)
	@if git rev-parse --is-inside-work-tree >/dev/null 2>&1 && \
	    [ "$$(git config --get filter.nbstripout.clean)" != '$(NBSTRIP)' ]; then \
		git config filter.nbstripout.clean '$(NBSTRIP)' && \
		git config filter.nbstripout.smudge cat && \
		git config diff.ipynb.textconv '$(NBSTRIP) --textconv' && \
		echo "==> installed the git filter that strips notebook outputs on commit (.gitattributes)"; \
	fi

# The environment is rebuilt whenever a lock or the package metadata changes. pip installs the pinned uv
# (installer.lock), and uv the pinned environment: the same hash-checked wheels, in about a third of pip's time here
# (parallel downloads; the bytecode compiled on every core)
$(READY): environment.lock installer.lock pyproject.toml
	@echo "==> installing the pinned environment into $(VENV) with $(INSTALLER) (hash-checked, from environment.lock)"
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(if $(filter uv,$(INSTALLER)),$(BIN)/python -m pip install --disable-pip-version-check --quiet \
		--require-hashes --no-deps -r installer.lock)
	$(INSTALL) --require-hashes --no-deps -r environment.lock
	$(INSTALL) --no-deps --no-build-isolation -e .
	$(BIN)/python -m ipykernel install --sys-prefix --name mutual --display-name "Python (mutual)"
	@touch $@

# The peers' environment (bench-peers): its own lock, and `mutual` editable without its dependencies
$(PEERS_READY): bench/peers/requirements.lock pyproject.toml
	@echo "==> installing the peers bench environment into $(PEERS) (hash-checked, from bench/peers/requirements.lock)"
	@test -x $(PEERS)/bin/python || $(PYTHON) -m venv $(PEERS)
	$(PEERS)/bin/python -m pip install --disable-pip-version-check --progress-bar off \
		--require-hashes --no-deps -r bench/peers/requirements.lock
	$(PEERS)/bin/python -m pip install --disable-pip-version-check --no-deps --no-build-isolation -e .
	@touch $@

LOCK := build/lock-tools/bin/pip-compile --generate-hashes --allow-unsafe --strip-extras --no-emit-index-url \
	--no-emit-find-links $(LOCKFLAGS)

## lock: recompile environment.lock from requirements.in, and installer.lock (uv) from installer.in (pins and
##       hashes, Python 3.11); keeps current pins where they still fit; `make lock LOCKFLAGS=--upgrade` upgrades
##       all but uv, which installer.in pins (edit it there)
lock:
	@test -x build/lock-tools/bin/pip-compile || \
		($(PYTHON) -m venv build/lock-tools && build/lock-tools/bin/pip install -q pip-tools)
	$(LOCK) -o environment.lock requirements.in
	$(LOCK) -o installer.lock installer.in

## lock-peers: recompile bench/peers/requirements.lock from bench/peers/requirements.in (constrained
##             to environment.lock's pins, so shared packages match the runtime's versions)
lock-peers:
	@test -x build/lock-tools/bin/pip-compile || \
		($(PYTHON) -m venv build/lock-tools && build/lock-tools/bin/pip install -q pip-tools)
	$(LOCK) -o bench/peers/requirements.lock bench/peers/requirements.in

## clean: remove executed notebooks, caches and build products (keeps the environment)
clean:
	rm -rf build .cache .pytest_cache
	find . -name __pycache__ -not -path "./$(VENV)/*" -prune -exec rm -rf {} +

## distclean: clean, and remove the environments too
distclean: clean
	rm -rf $(VENV) $(PEERS)
