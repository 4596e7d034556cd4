"""Shared test set-up: quiet, single-threaded numerics and a private output folder per process,
so no test ever writes into the committed ``figures/`` (or the scratch folder), and the notebook
lane (``helpers.lane``): the notebooks' quick runs, once per session, beside the unit tests."""

import atexit
import gc
import json
import os
import shutil
import tempfile
from pathlib import Path

import pytest

# The unit tests keep about 1.5 million long-lived objects (JAX's traces and programs, pandas, matplotlib); with
# Python's default thresholds a full collection scans them all whenever they grow by a quarter (about 20 s of a cold
# run of the unit tests): collections run far less often here; cyclic garbage is still freed, later
gc.set_threshold(10_000, 50, 1_000)
os.environ.setdefault("MPLBACKEND", "Agg")
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # every test process and the notebook lane (below): single-threaded
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
os.environ["MUTUAL_OUTPUT_DIR"] = tempfile.mkdtemp(prefix="mutual-test-figures-")  # each process its own
OUTPUT, KEEP_OUTPUT = os.environ["MUTUAL_OUTPUT_DIR"], []   # kept (and named) when a test of this process failed


@atexit.register
def _remove_output():
    if not KEEP_OUTPUT:
        shutil.rmtree(OUTPUT, ignore_errors=True)

os.environ.setdefault("MUTUAL_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".cache"))

from helpers.lane import LaneOutcomes, NotebookLane, needed_notebooks, sort_for_the_lane

import nbformat  # after mutual (helpers.lane), which keeps jsonschema's 1.4 s IRI grammar from loading

LANE_OUTPUT = Path(os.environ["MUTUAL_OUTPUT_DIR"]) / "notebooks"  # the lane's own folder: a runner holds its folder


def lane_folder(config):
    """Where the session's notebook lane writes: this process's, or a pytest-xdist worker's controller's."""
    return Path(config.workerinput["lane"]) if hasattr(config, "workerinput") else LANE_OUTPUT


def pytest_addoption(parser):
    parser.addoption("--jax-compiles", action="store_true",
                     help="count JAX's compilations per test file and print where the compile time went")


def pytest_configure(config):
    if config.getoption("--jax-compiles"):
        if getattr(config.option, "numprocesses", None) or hasattr(config, "workerinput"):
            raise pytest.UsageError("--jax-compiles counts the compilations of one process: run it without -n")
        from helpers.compiles import CompileCounter
        counter = CompileCounter()
        counter.start()
        config.pluginmanager.register(counter, "jax-compiles")


@pytest.hookimpl(trylast=True)  # after -k and -m have deselected what will not run
def pytest_collection_modifyitems(session, config, items):
    """Tests that read a notebook's run go last, in the order the lane runs the notebooks, and the
    lane starts now (alone) or when a worker has collected (pytest-xdist's controller, below)."""
    stems = needed_notebooks(items)
    sort_for_the_lane(items, stems)
    if hasattr(config, "workerinput"):
        folder = lane_folder(config)
        config._notebook_lane = LaneOutcomes(stems, folder)
        folder.mkdir(parents=True, exist_ok=True)
        (folder / f"needed-{config.workerinput['workerid']}.json").write_text(json.dumps(stems))
        return
    config._notebook_lane = NotebookLane(stems, LANE_OUTPUT)
    if stems and not config.option.collectonly:
        config._notebook_lane.start()


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node):
    """pytest-xdist's controller: each worker reads the controller's lane folder."""
    node.workerinput["lane"] = str(LANE_OUTPUT)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids):
    """pytest-xdist's controller: the first worker to finish collecting says which notebooks to run."""
    if getattr(node.config, "_notebook_lane", None) is None:
        stems = json.loads((LANE_OUTPUT / f"needed-{node.gateway.id}.json").read_text())
        node.config._notebook_lane = NotebookLane(stems, LANE_OUTPUT)
        if stems:
            node.config._notebook_lane.start()


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error):
    """pytest-xdist's controller: add up how long each worker waited for the lane."""
    waited = getattr(node, "workeroutput", {}).get("lane_waited", 0.0)
    node.config._lane_waited = getattr(node.config, "_lane_waited", 0.0) + waited


def pytest_terminal_summary(terminalreporter, config):
    """Where the notebook lane's time went: each quick run's wall time, and how long the tests waited for it;
    after a failure, where the executed notebooks and outputs were kept."""
    if terminalreporter.stats.get("failed") or terminalreporter.stats.get("error"):
        terminalreporter.write_line(f"outputs kept (the lane's executed notebooks in {LANE_OUTPUT / 'executed'}): "
                                    f"{OUTPUT} (the workers' beside it, mutual-test-figures-*)")
    lane = getattr(config, "_notebook_lane", None)
    if isinstance(lane, NotebookLane) and lane.seconds:
        runs = ", ".join(f"{stem[:2]} {sec:.0f} s" for stem, sec in lane.seconds.items())
        waited = getattr(config, "_lane_waited", lane.waited)
        terminalreporter.write_line(f"notebook lane (quick runs, wall): {runs}; total {sum(lane.seconds.values()):.0f} s; "
                                    f"the tests waited {waited:.0f} s for it")


def pytest_sessionfinish(session):
    if session.testsfailed:
        KEEP_OUTPUT.append(True)
    lane = getattr(session.config, "_notebook_lane", None)
    if isinstance(lane, NotebookLane):
        lane.stop()
    elif lane is not None and hasattr(session.config, "workeroutput"):
        session.config.workeroutput["lane_waited"] = lane.waited


@pytest.fixture(scope="session")
def executed_notebook(pytestconfig):
    """``executed_notebook(stem)`` waits for the quick run of ``notebooks/<stem>.ipynb`` (the
    notebook lane ran it in a fresh kernel with ``quick=True``) and returns its results
    ``{claim_id: entry}``; the executed notebooks are in ``executed_notebook.nodes``, their
    outputs (figures, tables, results) in ``executed_notebook.folder``."""
    lane, folder = pytestconfig._notebook_lane, lane_folder(pytestconfig)
    nodes = {}

    def run(stem):
        if stem not in lane.done:
            pytest.fail(f"{stem}: no test collected for this session names the notebook (see tests/conftest.py)")
        status, why = lane.wait(stem)
        if status != 0:
            pytest.fail(f"{stem}: {' '.join(why) or f'the runner exited with status {status}'}")
        if stem not in nodes:
            nodes[stem] = nbformat.read(str(folder / "executed" / f"{stem}.ipynb"), as_version=4)
        path = folder / "results" / f"{stem}.json"
        return json.loads(path.read_text())["claims"] if path.exists() else {}

    run.nodes, run.folder = nodes, folder
    return run
