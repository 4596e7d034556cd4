"""What would be committed of each notebook carries no outputs (whatever the lab did to the working copy), has
a parameters cell and the ``mutual`` kernel, and leaves the work to the library."""

import ast

import nbformat
import pytest

from mutual.compendium.hygiene import committed_text, dirty_cells, filter_installed, staged_text
from mutual.compendium.notebooks import declared_parameters
from mutual.compendium.paths import NOTEBOOKS


NOTEBOOK_PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))
IDS = [p.stem for p in NOTEBOOK_PATHS]


def _code_cells(path):
    return [c for c in nbformat.read(path, as_version=4).cells if c.cell_type == "code"]


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_what_would_be_committed_has_no_outputs(path):
    """What `git add` would stage (the working copy through the clean filter) and what is staged now
    carry no outputs or execution counts; a notebook run and autosaved in the lab passes."""
    dirty = dirty_cells(committed_text(path))
    hint = "" if filter_installed() else " (the output-stripping git filter is not installed: run `make env`)"
    assert not dirty, f"{path.name}: code cells {dirty} would be committed with outputs{hint}"
    staged = staged_text(path)
    if staged is not None:
        assert not dirty_cells(staged), f"{path.name}: the staged copy carries outputs in code cells {dirty_cells(staged)}"


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_parameters_cell_and_kernel(path):
    declared = declared_parameters(path)
    assert declared["quick"] == "False", f"{path.name}: 'quick' must default to False"
    assert nbformat.read(path, as_version=4).metadata.kernelspec.name == "mutual"


@pytest.mark.parametrize("path", NOTEBOOK_PATHS, ids=IDS)
def test_library_does_the_work(path):
    """Notebooks call `mutual`; they define no functions or classes of their own."""
    for cell in _code_cells(path):
        tree = ast.parse("\n".join("pass" if line.lstrip().startswith(("%", "!")) else line
                                   for line in cell.source.splitlines()))
        defs = [n.name for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.ClassDef))]
        assert not defs, f"{path.name}: move {defs} into lib/mutual"
