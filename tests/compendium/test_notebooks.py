"""The notebook runner: it names the failing cell, requires declared parameters, exits non-zero naming the
notebook, and prints no progress bars in batch runs (its kernels' socket waits: test_kernel.py)."""

import subprocess
import sys

import pytest

from mutual.compendium.notebooks import NotebookError, declared_parameters, execute

from helpers.claims import notebook_file


def test_runner_names_the_failing_cell(tmp_path):
    path = notebook_file(tmp_path, "quick = False", "x = 1", "raise RuntimeError('boom')")
    with pytest.raises(NotebookError, match=r"99_demo.ipynb failed in code cell 3 \(\"raise RuntimeError\(.boom.\)\"\): RuntimeError: boom"):
        execute(path, {"quick": True})


def test_runner_requires_declared_parameters(tmp_path):
    with pytest.raises(ValueError, match="exactly one cell tagged 'parameters'"):
        declared_parameters(notebook_file(tmp_path, "quick = False", tagged=False))
    with pytest.raises(ValueError, match="must declare 'quick'"):
        declared_parameters(notebook_file(tmp_path, "seed = 0"))
    with pytest.raises(ValueError, match="no parameter named 'n_demos'"):
        execute(notebook_file(tmp_path, "quick = False"), {"n_demos": 3})


def test_make_figures_runner_exits_non_zero_naming_the_notebook(tmp_path):
    path = notebook_file(tmp_path, "quick = False", "1 / 0")
    out = subprocess.run([sys.executable, "-m", "mutual.compendium.notebooks", "--quick", str(path)],
                         capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode != 0
    assert "99_demo.ipynb failed in code cell 2 ('1 / 0')" in out.stderr and "ZeroDivisionError" in out.stderr
    assert "Traceback" not in out.stderr and len(out.stderr.strip().splitlines()) == 1


def test_batch_runs_print_no_progress_bars(tmp_path):
    """TQDM_DISABLE=1 plus the runner's kernel start-up line: even a bar asked for explicitly stays silent."""
    path = notebook_file(tmp_path, "quick = False", "import os\nfrom tqdm import tqdm\nfrom tqdm.auto import tqdm as auto\n"
                     "total = sum(tqdm(range(5), disable=False, desc='loud')) + sum(auto(range(5)))\n"
                     "print(total, os.environ['TQDM_DISABLE'])")
    nb = execute(path, {"quick": True})
    outputs = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs]
    assert [o.get("text") for o in outputs] == ["20 1\n"], outputs


STARTS = """import sys
import mutual.compendium.notebooks, nbformat
nbformat.validate(nbformat.v4.new_notebook())
try:
    nbformat.validate({"cells": "not a list"}, version=4)
    print("accepted a broken notebook")
except nbformat.ValidationError:
    pass
print(sys.modules.get("rfc3987_syntax") is None)
"""


def test_the_runner_starts_without_building_jsonschemas_iri_grammar():
    """A runner, kernel or filter process never loads rfc3987_syntax (1.4 s of grammar building at every
    start), and nbformat still validates: a new notebook passes, a broken one does not."""
    out = subprocess.run([sys.executable, "-c", STARTS], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["True"], out.stdout + out.stderr
