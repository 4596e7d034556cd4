"""Fixtures shared by the compendium's tests: the synthetic claims as the report's claims file, with an output
folder and a run of the notebook ``09_demo`` as the runner would tell its kernel."""

import pytest

import mutual.compendium.paths as paths
import mutual.compendium.runs as runs

from helpers.claims import SYNTHETIC_CLAIMS, SYNTHETIC_SETTINGS, notebook_file


@pytest.fixture
def claims_file(tmp_path, monkeypatch):
    """The claims above, an output folder in ``tmp_path`` and a run of the notebook ``09_demo`` (as the
    runner would tell its kernel), so that ``write_results("09_demo", ...)`` works in-process."""
    path = tmp_path / "claims.csv"
    SYNTHETIC_CLAIMS.to_csv(path, index=False)
    monkeypatch.setattr(paths, "CLAIMS", path)
    SYNTHETIC_SETTINGS.to_csv(tmp_path / "settings.csv", index=False)
    monkeypatch.setattr(paths, "SETTINGS", tmp_path / "settings.csv")
    monkeypatch.setenv("MUTUAL_OUTPUT_DIR", str(tmp_path / "figures"))
    notebook = notebook_file(tmp_path, "quick = False", "x = 1", name="09_demo")
    for key, value in runs.kernel_env(notebook, {}).items():
        monkeypatch.setenv(key, value)
    return path
