"""Every notebook runs in a fresh kernel with its quick parameters, and what would be committed of it
carries no outputs (whatever the lab did to the working copy)."""

import ast
import re

import nbformat
import pytest

from mutual.compendium.claims import VERDICTS
from mutual.compendium.hygiene import committed_text, dirty_cells, filter_installed, staged_text
from mutual.compendium.notebooks import declared_parameters
from mutual.compendium.paths import NOTEBOOKS

NOTEBOOK_PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))
IDS = [p.stem for p in NOTEBOOK_PATHS]
PROGRESS_BAR = re.compile(r"\d+%\|.*\||it/s\]|s/it\]")


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


@pytest.mark.parametrize("stem", IDS)
def test_notebook_runs_quick(stem, executed_notebook):
    results = executed_notebook(stem)
    if not stem.startswith("00_"):
        extensions = executed_notebook.folder / "results" / "extensions" / f"{stem}.json"
        assert results or extensions.exists(), f"{stem} wrote no results for the reproduction report"


@pytest.mark.parametrize("stem", IDS)
def test_no_progress_bars_in_executed_notebooks(stem, executed_notebook):
    """Batch runs set TQDM_DISABLE=1 for their kernels: no progress-bar noise in the outputs."""
    executed_notebook(stem)
    nb = executed_notebook.nodes[stem]
    noisy = [i for i, c in enumerate((c for c in nb.cells if c.cell_type == "code"), 1)
             for o in c.get("outputs", []) if o.get("output_type") == "stream" and PROGRESS_BAR.search(o.get("text", ""))]
    assert not noisy, f"{stem}: progress bars printed into code cells {sorted(set(noisy))}"


def test_overview_renders_every_verdict_category(executed_notebook):
    """The overview runs after the chapter notebooks and shows the report's summary with every category."""
    executed_notebook("00_overview")
    text = "\n".join(str(o.get("data", {}).get("text/markdown", "")) + str(o.get("data", {}).get("text/plain", ""))
                     for c in executed_notebook.nodes["00_overview"].cells if c.cell_type == "code"
                     for o in c.get("outputs", []))
    summary = next((ln for ln in text.splitlines() if "Summary: " in ln), "")
    missing = [v for v in VERDICTS if f" {v}" not in summary]
    assert summary and not missing, f"00_overview: summary line {summary!r} lacks {missing}"
