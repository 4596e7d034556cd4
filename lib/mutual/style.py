"""One colour-blind-safe style for every plot the library and the notebooks draw."""

import os

import matplotlib
import matplotlib.pyplot as plt

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


def use_style():
    """Apply the compendium's matplotlib style (and a fixed ``SOURCE_DATE_EPOCH``)."""
    os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
    plt.rcParams.update(STYLE)
