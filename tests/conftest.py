"""Shared test set-up: quiet, single-threaded numerics and a private output folder,
so no test ever writes into the committed ``figures/`` (or the scratch folder)."""

import gc
import inspect
import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import pytest

# The unit tests keep about 1.5 million long-lived objects (JAX's traces and programs, pandas, matplotlib); with
# Python's default thresholds a full collection scans them all whenever they grow by a quarter (about 20 s of a cold
# run of the unit tests): collections run far less often here; cyclic garbage is still freed, later
gc.set_threshold(10_000, 50, 1_000)
os.environ.setdefault("MPLBACKEND", "Agg")
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # this process and the notebook lane (below): two single-threaded lanes on two cores
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
os.environ["MUTUAL_OUTPUT_DIR"] = tempfile.mkdtemp(prefix="mutual-test-figures-")
os.environ.setdefault("MUTUAL_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".cache"))

from mutual.compendium.paths import NOTEBOOKS

import nbformat  # after mutual.compendium, which keeps jsonschema's 1.4 s IRI grammar from loading


LANE_OUTPUT = Path(os.environ["MUTUAL_OUTPUT_DIR"]) / "notebooks"  # the lane's own: a runner holds its folder
_CALLS = re.compile(r"executed_notebook\(\s*[\"'](\d\d_\w+)[\"']")


class NotebookLane:
    """Quick runs of the notebooks the collected tests need, one after another in a background
    process (the runner, ``python -m mutual.compendium.notebooks --quick``), while the unit tests
    run in this one: two lanes on two cores, and every notebook runs once per session. The
    overview runs last (it renders the other notebooks' results)."""

    def __init__(self, stems):
        self.stems = [s for s in sorted(stems) if not s.startswith("00_")] + sorted(s for s in stems if s.startswith("00_"))
        self.done = {stem: threading.Event() for stem in self.stems}
        self.outcome, self.process, self.stopped = {}, None, False
        self.seconds, self.waited = {}, 0.0
        self.thread = threading.Thread(target=self._run, daemon=True, name="notebook lane")

    def _run(self):
        try:
            for stem in self.stems:
                if self.stopped:
                    break
                command = [sys.executable, "-m", "mutual.compendium.notebooks", "--quick", "--output", str(LANE_OUTPUT),
                           str(NOTEBOOKS / f"{stem}.ipynb")]
                start = time.monotonic()
                self.process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                out, err = self.process.communicate()
                self.seconds[stem] = time.monotonic() - start
                self.outcome[stem] = (self.process.returncode, (err.strip() or out.strip()).splitlines()[-1:])
                self.done[stem].set()
        finally:  # whatever happened, nobody waits forever
            for event in self.done.values():
                event.set()

    def wait(self, stem):
        start = time.monotonic()
        self.done[stem].wait()
        self.waited += time.monotonic() - start
        return self.outcome.get(stem, (1, ["the session stopped before this notebook ran"]))

    def stop(self):
        self.stopped = True
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
        for event in self.done.values():
            event.set()


def _needed_notebooks(items):
    """Stems of the notebooks the collected tests use (a ``stem`` parameter, or a literal call)."""
    stems = set()
    for item in items:
        if "executed_notebook" not in getattr(item, "fixturenames", ()):
            continue
        stem = getattr(item, "callspec", None) and item.callspec.params.get("stem")
        stems |= {stem} if stem else set(_CALLS.findall(inspect.getsource(item.function)))
    if any(s.startswith("00_") for s in stems):
        stems |= {p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")}
    return stems


def pytest_addoption(parser):
    parser.addoption("--jax-compiles", action="store_true",
                     help="count JAX's compilations per test file and print where the compile time went")


def pytest_configure(config):
    if config.getoption("--jax-compiles"):
        from helpers.compiles import CompileCounter
        counter = CompileCounter()
        counter.start()
        config.pluginmanager.register(counter, "jax-compiles")


@pytest.hookimpl(trylast=True)  # after -k and -m have deselected what will not run
def pytest_collection_modifyitems(session, config, items):
    """Tests that read a notebook's run go last, in the order the lane runs the notebooks, and the
    lane starts now: the unit tests run while the notebooks do."""
    lane = NotebookLane(_needed_notebooks(items))
    order = {stem: i for i, stem in enumerate(lane.stems)}

    def key(item):
        if "executed_notebook" not in getattr(item, "fixturenames", ()):
            return -1
        stem = getattr(item, "callspec", None) and item.callspec.params.get("stem")
        stems = [stem] if stem else _CALLS.findall(inspect.getsource(item.function))
        return max((order.get(s, len(order)) for s in stems), default=len(order))
    items.sort(key=key)
    config._notebook_lane = lane
    if lane.stems and not config.option.collectonly:
        lane.thread.start()


def pytest_terminal_summary(terminalreporter, config):
    """Where the notebook lane's time went: each quick run's wall time, and how long the tests waited for it."""
    lane = getattr(config, "_notebook_lane", None)
    if lane is not None and lane.seconds:
        runs = ", ".join(f"{stem[:2]} {sec:.0f} s" for stem, sec in lane.seconds.items())
        terminalreporter.write_line(f"notebook lane (quick runs, wall): {runs}; total {sum(lane.seconds.values()):.0f} s; "
                                    f"the tests waited {lane.waited:.0f} s for it")


def pytest_sessionfinish(session):
    lane = getattr(session.config, "_notebook_lane", None)
    if lane is not None:
        lane.stop()


@pytest.fixture(scope="session")
def executed_notebook(pytestconfig):
    """``executed_notebook(stem)`` waits for the quick run of ``notebooks/<stem>.ipynb`` (the
    notebook lane ran it in a fresh kernel with ``quick=True``) and returns its results
    ``{claim_id: entry}``; the executed notebooks are in ``executed_notebook.nodes``, their
    outputs (figures, tables, results) in ``executed_notebook.folder``."""
    lane = pytestconfig._notebook_lane
    nodes = {}

    def run(stem):
        if stem not in lane.done:
            pytest.fail(f"{stem}: no test collected for this session names the notebook (see tests/conftest.py)")
        status, why = lane.wait(stem)
        if status != 0:
            pytest.fail(f"{stem}: {' '.join(why) or f'the runner exited with status {status}'}")
        if stem not in nodes:
            nodes[stem] = nbformat.read(str(LANE_OUTPUT / "executed" / f"{stem}.ipynb"), as_version=4)
        path = LANE_OUTPUT / "results" / f"{stem}.json"
        return json.loads(path.read_text())["claims"] if path.exists() else {}

    run.nodes, run.folder = nodes, LANE_OUTPUT
    return run
