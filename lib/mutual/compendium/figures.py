"""One style and one saver for every figure and table of the compendium.

Figures are named by their thesis number (``fig_3_1``; our own figures of a chapter ``fig_3_lemma``, and
of an extension beyond the thesis ``fig_ext_cycle_learn``, so that no name claims a thesis figure it is not)
and saved as PDF and PNG (a quick run, the tests' notebook lane: PNG only), tables (``table_5_1``,
``table_ext_power_simulated``) as CSV and Markdown, all written atomically and with no metadata that changes
between runs, so a rerun gives identical bytes.
"""

import os
import re

from ..atomic import atomic_path, write_text
from ..style import CYCLE, PALETTE, use_style  # noqa: F401 (the notebooks' one import)
from .paths import figures_dir, saved
from .runs import current_mode

_NAME = re.compile(r"^(fig|table|anim)_([0-9]+|ext)_[a-z0-9_]+$")
MAX_ANIMATION_BYTES = 2 * 1024 * 1024


def _check_name(name, kind):
    if not _NAME.match(name) or not name.startswith(kind):
        raise ValueError(f"name {name!r} must look like '{kind}_<chapter>_<number>' (e.g. '{kind}_3_1'; "
                         f"figures beyond the thesis's own: '{kind}_2_complexity'; extensions beyond the thesis: "
                         f"'{kind}_ext_<topic>_<name>')")


def savefig(fig, name):
    """Save ``fig`` as ``<name>.pdf`` and ``<name>.png`` in the figures folder; return the paths. A quick run (the
    runner's ``--quick`` alone, as in the tests' notebook lane) writes the PNG alone; every other run writes both."""
    _check_name(name, "fig")
    os.environ.setdefault("SOURCE_DATE_EPOCH", "0")
    out = figures_dir()
    metadata = {
        "pdf": {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": None},
        "png": {"Software": None},
    }
    paths = []
    for ext in ("png",) if current_mode() == "quick" else ("pdf", "png"):
        target = out / f"{name}.{ext}"
        with atomic_path(target) as tmp:
            fig.savefig(tmp, format=ext, metadata=metadata[ext])
        paths.append(target)
    return [saved(p) for p in paths]


def save_animation(animation, name, fps=10, dpi=80):
    """Save a matplotlib ``animation`` as ``<name>.gif`` (e.g. ``anim_6_2``) in the figures folder.

    Frames are rendered by Agg and encoded by Pillow, so a rerun gives identical bytes; a GIF over
    ``MAX_ANIMATION_BYTES`` (2 MiB) is refused: use fewer frames or a lower ``dpi``.
    """
    from matplotlib.animation import PillowWriter

    _check_name(name, "anim")
    target = figures_dir() / f"{name}.gif"
    with atomic_path(target) as tmp:
        animation.save(tmp, writer=PillowWriter(fps=fps), dpi=dpi)
        size = tmp.stat().st_size
        if size > MAX_ANIMATION_BYTES:
            raise ValueError(f"{name}.gif would be {size / 2**20:.1f} MiB, over the 2 MiB limit: "
                             "use fewer frames or a lower dpi")
    return saved(target)


def _at_roundoff(df, floor, floatfmt):
    """``df`` with every float cell below ``floor`` in magnitude written as ``"< floor"`` (:func:`~.results.roundoff`)."""
    from .results import roundoff

    def cell(v):
        return roundoff(v, floor, floatfmt) if isinstance(v, float) and abs(v) < floor else v
    return df.map(cell)


def markdown_table(df, floatfmt=".3g"):
    """A pandas DataFrame as a GitHub-flavoured Markdown table."""
    def cell(v):
        return format(v, floatfmt) if isinstance(v, float) else str(v).replace("|", "\\|")
    lines = ["| " + " | ".join(map(str, df.columns)) + " |", "|" + "---|" * len(df.columns)]
    lines += ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join(lines) + "\n"


def save_table(df, name, floatfmt=".3g", roundoff=None):
    """Save a pandas DataFrame as ``<name>.csv`` and ``<name>.md``; return the paths.

    ``roundoff`` (a floor such as ``1e-12``): float cells smaller in magnitude are written as
    ``"< 1e-12"``, not as rounding digits that change from machine to machine."""
    _check_name(name, "table")
    if roundoff is not None:
        df = _at_roundoff(df, roundoff, floatfmt)
    out = figures_dir()
    csv = write_text(out / f"{name}.csv", df.to_csv(index=False, float_format=lambda v: format(v, floatfmt)))
    md = write_text(out / f"{name}.md", markdown_table(df, floatfmt))
    return saved(csv, md)
