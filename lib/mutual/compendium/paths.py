"""Every path of the compendium, anchored at the repository root.

Outputs (figures, tables, results, the report, generated datasets) go to the folder named by
``MUTUAL_OUTPUT_DIR``; without it they go to a scratch folder, ``build/scratch/``. Only
``make figures`` points ``MUTUAL_OUTPUT_DIR`` at the committed ``figures/`` (through
``python -m mutual.compendium.notebooks --output figures``), so a notebook opened in the lab, a quick
run or a run with other parameters never rewrites what is committed. The library's caches
(:mod:`mutual.cache`) go to ``CACHE`` (``.cache/``) when the Makefile or the tests run them.
"""

import os
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
DATA = ROOT / "data"
NOTEBOOKS = ROOT / "notebooks"
BUILD = ROOT / "build"
FIGURES = ROOT / "figures"          # the committed outputs, written by `make figures` only
SCRATCH = BUILD / "scratch"         # every other run's outputs (git-ignored)
CLAIMS = DATA / "paper_claims.csv"
SETTINGS = DATA / "paper_settings.csv"
CACHE = ROOT / ".cache"
OUTPUT_ENV = "MUTUAL_OUTPUT_DIR"


class SavedPath(type(Path())):
    """A file the compendium wrote. A notebook shows it as ``saved figures/fig_3_1.png`` (relative to
    the repository when inside it) rather than a machine's absolute path."""

    def __repr__(self):
        shown = self.relative_to(ROOT) if self.is_relative_to(ROOT) else self
        return f"saved {shown}"


def saved(*paths):
    """``paths`` as :class:`SavedPath` (one path) or a list of them."""
    out = [SavedPath(p) for p in paths]
    return out[0] if len(out) == 1 else out


def figures_dir() -> Path:
    """Folder for figures and tables: ``$MUTUAL_OUTPUT_DIR``, else the scratch folder ``build/scratch``."""
    return Path(os.environ.get(OUTPUT_ENV) or SCRATCH)


def is_committed(folder=None) -> bool:
    """Whether ``folder`` (default: the current output folder) is the committed ``figures/``."""
    folder = Path(folder) if folder is not None else figures_dir()
    return folder.resolve() == FIGURES.resolve()


def generated_data_dir() -> Path:
    """Folder for datasets a notebook generates (simulated demonstrations, the simulated study):
    the committed ``data/`` when the outputs go to the committed ``figures/``, else
    ``<output folder>/data``."""
    return DATA if is_committed() else figures_dir() / "data"


def results_dir() -> Path:
    """Folder for the per-notebook result files read by the reproduction report."""
    return figures_dir() / "results"


def executed_dir() -> Path:
    """Folder for executed copies of the notebooks: ``build/executed`` for ``make figures``,
    else ``<output folder>/executed``."""
    return BUILD / "executed" if is_committed() else figures_dir() / "executed"
