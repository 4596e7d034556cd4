"""One style and one saver for every figure and table of the compendium.

Figures are named by their thesis number (``fig_3_1``) and saved as PDF and PNG,
tables (``table_5_1``) as CSV and Markdown, all written atomically and with no
metadata that changes between runs, so a rerun gives identical bytes.
"""

import os
import re

import matplotlib
import matplotlib.pyplot as plt

from .atomic import atomic_path, write_text
from .paths import figures_dir

# Okabe & Ito (2008), the colour-blind-safe qualitative palette.
PALETTE = {
    "black": "#000000", "orange": "#E69F00", "sky": "#56B4E9", "green": "#009E73",
    "yellow": "#F0E442", "blue": "#0072B2", "vermillion": "#D55E00", "purple": "#CC79A7",
}
CYCLE = [PALETTE[k] for k in ("blue", "orange", "green", "vermillion", "purple", "sky", "yellow", "black")]

STYLE = {
    "figure.figsize": (5.0, 3.6),
    "figure.dpi": 100,
    "savefig.dpi": 150,
    "savefig.bbox": "tight",
    "font.size": 10,
    "axes.titlesize": 10,
    "axes.labelsize": 10,
    "legend.fontsize": 8,
    "legend.frameon": False,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.prop_cycle": matplotlib.cycler(color=CYCLE),
    "image.cmap": "viridis",
    "lines.linewidth": 1.6,
    "svg.hashsalt": "mutual",
    "pdf.fonttype": 42,
}

_NAME = re.compile(r"^(fig|table)_[0-9]+_[a-z0-9_]+$")


def use_style():
    """Apply the compendium's matplotlib style (and a fixed ``SOURCE_DATE_EPOCH``)."""
    os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
    plt.rcParams.update(STYLE)


def _check_name(name, kind):
    if not _NAME.match(name) or not name.startswith(kind):
        raise ValueError(f"name {name!r} must look like '{kind}_<chapter>_<number>' (e.g. '{kind}_3_1'; "
                         f"figures beyond the thesis's own: '{kind}_2_complexity')")


def savefig(fig, name):
    """Save ``fig`` as ``<name>.pdf`` and ``<name>.png`` in the figures folder; return the paths."""
    _check_name(name, "fig")
    os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
    out = figures_dir()
    metadata = {
        "pdf": {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": None},
        "png": {"Software": None},
    }
    paths = []
    for ext in ("pdf", "png"):
        target = out / f"{name}.{ext}"
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=ext, metadata=metadata[ext])
        paths.append(target)
    return paths


def markdown_table(df, floatfmt=".3g"):
    """A pandas DataFrame as a GitHub-flavoured Markdown table."""
    def cell(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v).replace("|", "\\|")
    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines) + "\n"


def save_table(df, name, floatfmt=".3g"):
    """Save a pandas DataFrame as ``<name>.csv`` and ``<name>.md``; return the paths."""
    _check_name(name, "table")
    out = figures_dir()
    csv = write_text(out / f"{name}.csv", df.to_csv(index=False, float_format=lambda v: format(v, floatfmt)))
    md = write_text(out / f"{name}.md", markdown_table(df, floatfmt))
    return [csv, md]
