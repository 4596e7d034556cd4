"""Every path of the compendium, anchored at the repository root.

Outputs go to ``figures/`` unless ``MUTUAL_OUTPUT_DIR`` points elsewhere (the
notebook tests use a temporary folder so that quick runs never overwrite the
committed figures). The library's caches (:mod:`mutual.cache`) go to ``CACHE`` (``.cache/``)
when the Makefile or the tests run them.
"""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
DATA = ROOT / "data"
NOTEBOOKS = ROOT / "notebooks"
BUILD = ROOT / "build"
CLAIMS = DATA / "paper_claims.csv"
CACHE = ROOT / ".cache"


def figures_dir() -> Path:
    """Folder for figures and tables (``MUTUAL_OUTPUT_DIR`` or ``figures/``)."""
    return Path(os.environ.get("MUTUAL_OUTPUT_DIR", ROOT / "figures"))


def generated_data_dir() -> Path:
    """Folder for datasets a notebook generates (simulated demonstrations, the simulated study):
    ``data/`` when the outputs go to ``figures/``, else ``<output folder>/data``."""
    if "MUTUAL_OUTPUT_DIR" in os.environ:
        return figures_dir() / "data"
    return DATA


def results_dir() -> Path:
    """Folder for the per-notebook result files read by the reproduction report."""
    return figures_dir() / "results"
