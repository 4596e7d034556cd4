"""Every notebook runs in a fresh kernel with its quick parameters (the notebook lane of tests/conftest.py),
prints no progress bars, and the overview renders every verdict category."""

import re

import pytest

from mutual.compendium.claims import VERDICTS
from mutual.compendium.paths import NOTEBOOKS


NOTEBOOK_PATHS = sorted(NOTEBOOKS.glob("[0-9][0-9]_*.ipynb"))
IDS = [p.stem for p in NOTEBOOK_PATHS]
PROGRESS_BAR = re.compile(r"\d+%\|.*\||it/s\]|s/it\]")


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
