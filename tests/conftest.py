"""Shared test set-up: quiet, single-threaded numerics and a private output folder,
so no test ever writes into the committed ``figures/`` (or the scratch folder)."""

import json
import os
import tempfile
import textwrap
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
os.environ["MUTUAL_OUTPUT_DIR"] = tempfile.mkdtemp(prefix="mutual-test-figures-")
os.environ.setdefault("MUTUAL_CACHE_DIR", str(Path(__file__).resolve().parents[1] / ".cache"))

from mutual.compendium.notebooks import NotebookError, execute  # noqa: E402
from mutual.compendium.paths import NOTEBOOKS, results_dir  # noqa: E402

# SHORT-LIVED (issue 10; the coordinator empties it when the chapter branches land): chapter
# notebooks whose write_results calls do not yet name `computed_by` and a `note` for every entry.
# For these notebooks only, the tests run the kernel with a start-up file that fills in the missing
# provenance (write_results itself refuses entries without it), and tests/test_claims_strict.py
# skips their strictness checks. test_claims_strict fails once a listed notebook is updated, so the
# set only shrinks.
AWAITING_PROVENANCE = set()

_PROVENANCE_SHIM = textwrap.dedent('''
    # tests/conftest.py AWAITING_PROVENANCE: fills in what write_results now requires
    import mutual.compendium.results as _results
    _write_results = _results.write_results
    _results._check_provenance = lambda notebook, cid, entry: None
    _results.write_results = lambda notebook, claims, simulated=False: _write_results(notebook, {
        cid: {"note": "(no note yet)", "computed_by": "(not named yet)",
              **(entry if isinstance(entry, dict) else {"value": entry})} for cid, entry in claims.items()}, simulated)
''')


@pytest.fixture(scope="session")
def executed_notebook(tmp_path_factory):
    """``executed_notebook(stem)`` runs ``notebooks/<stem>.ipynb`` once per session with
    ``quick=True`` in a fresh kernel and returns its results ``{claim_id: entry}``; the executed
    notebook nodes are in ``executed_notebook.nodes``. The overview runs after every chapter
    notebook, so that it renders their results."""
    outcome, nodes = {}, {}
    shim = tmp_path_factory.mktemp("ipython")
    (shim / "profile_default" / "startup").mkdir(parents=True)
    (shim / "profile_default" / "startup" / "00-awaiting-provenance.py").write_text(_PROVENANCE_SHIM)

    def run(stem):
        if stem.startswith("00_"):
            for other in sorted(p.stem for p in NOTEBOOKS.glob("[0-9][0-9]_*.ipynb")):
                if not other.startswith("00_"):
                    try:
                        run(other)
                    except pytest.fail.Exception:
                        pass
        if stem not in outcome:
            env = {"IPYTHONDIR": str(shim)} if stem in AWAITING_PROVENANCE else None
            try:
                nodes[stem] = execute(NOTEBOOKS / f"{stem}.ipynb", {"quick": True}, timeout=900, env=env)
                path = results_dir() / f"{stem}.json"
                outcome[stem] = json.loads(path.read_text())["claims"] if path.exists() else {}
            except (NotebookError, ValueError) as err:
                outcome[stem] = err
        if isinstance(outcome[stem], Exception):
            pytest.fail(str(outcome[stem]))
        return outcome[stem]

    run.nodes = nodes
    return run
