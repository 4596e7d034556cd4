"""Shared test set-up: quiet, single-threaded numerics and a private output folder,
so no test ever writes into the committed ``figures/`` (or the scratch folder)."""

import json
import os
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
os.environ["MUTUAL_OUTPUT_DIR"] = tempfile.mkdtemp(prefix="mutual-test-figures-")
os.environ.setdefault("MUTUAL_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".cache"))

from mutual.compendium.notebooks import NotebookError, execute
from mutual.compendium.paths import NOTEBOOKS, results_dir


@pytest.fixture(scope="session")
def executed_notebook():
    """``executed_notebook(stem)`` runs ``notebooks/<stem>.ipynb`` once per session with
    ``quick=True`` in a fresh kernel and returns its results ``{claim_id: entry}``; the executed
    notebook nodes are in ``executed_notebook.nodes``. The overview runs after every chapter
    notebook, so that it renders their results."""
    outcome, nodes = {}, {}

    def run(stem):
        if stem.startswith("00_"):
            for other in sorted(p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")):
                if not other.startswith("00_"):
                    try:
                        run(other)
                    except pytest.fail.Exception:
                        pass
        if stem not in outcome:
            try:
                nodes[stem] = execute(NOTEBOOKS / f"{stem}.ipynb", {"quick": True}, timeout=900)
                path = results_dir() / f"{stem}.json"
                outcome[stem] = json.loads(path.read_text())["claims"] if path.exists() else {}
            except (NotebookError, ValueError) as err:
                outcome[stem] = err
        if isinstance(outcome[stem], Exception):
            pytest.fail(str(outcome[stem]))
        return outcome[stem]

    run.nodes = nodes
    return run
