"""Every notebook runs in a fresh kernel with its quick parameters, and is committed clean."""

import ast

import nbformat
import pytest

from mutual.compendium.notebooks import declared_parameters
from mutual.compendium.paths import NOTEBOOKS, results_dir

NOTEBOOK_PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))
IDS = [p.stem for p in NOTEBOOK_PATHS]


def _code_cells(path):
    return [c for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code"]


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_committed_without_outputs(path):
    dirty = [i for i, c in enumerate(_code_cells(path)) if c.outputs or c.execution_count]
    assert not dirty, f"{path.name}: code cells {dirty} carry outputs or execution counts"


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_parameters_cell_and_kernel(path):
    declared = declared_parameters(path)
    assert declared["quick"] == "False", f"{path.name}: 'quick' must default to False"
    assert nbformat.read(path, as_version=4).metadata.kernelspec.name == "mutual"


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_library_does_the_work(path):
    """Notebooks call `mutual`; they define no functions or classes of their own."""
    for cell in _code_cells(path):
        tree = ast.parse(cell.source)
        defs = [n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
        assert not defs, f"{path.name}: move {defs} into lib/mutual"


@pytest.mark.parametrize("stem", IDS)
def test_notebook_runs_quick(stem, executed_notebook):
    results = executed_notebook(stem)
    if not stem.startswith("00_"):
        extensions = results_dir() / "extensions" / f"{stem}.json"   # chapter 8: extensions, not thesis claims
        assert results or extensions.exists(), f"{stem} wrote no results for the reproduction report"
