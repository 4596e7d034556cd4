"""A computed claim's scan (CLAIMS.md rule 2) from the notebook's scan table: in how many cells the
statement holds, and where it flips (:func:`mutual.compendium.claims.check_scan` validates the result)."""

import numpy as np


def _cell(row, by):
    return ", ".join(f"{c} {row[c]:g}" if isinstance(row[c], (int, float, np.integer, np.floating))
                     and not isinstance(row[c], (bool, np.bool_)) else f"{c} {row[c]}" for c in by)


def scan_entry(table, holds, by, name, seeds=None, limit=6):
    """``{"table", "seeds", "settings", "flips"}`` for a results entry.

    ``table``: one row per cell of the scan (a DataFrame); ``holds``: the name of its boolean column (the
    statement holds in that cell, for at least 9 of 10 seeds where seeded); ``by``: the columns that name a
    cell; ``name``: the saved table or figure that shows the scan; ``seeds``: ``[holding, total]`` at the
    chosen set-up, or None for an experiment with no random draw. ``flips`` lists up to ``limit`` cells
    where the statement fails (and how many more), or is empty."""
    ok = table[holds].astype(bool)
    failing = table[~ok]
    shown = "; ".join(_cell(row, by) for _, row in failing.head(limit).iterrows())
    more = f" (and {len(failing) - limit} more)" if len(failing) > limit else ""
    flips = f"fails in {len(failing)} of {len(table)} cells: {shown}{more}" if len(failing) else ""
    return {"table": name, "seeds": None if seeds is None else [int(seeds[0]), int(seeds[1])],
            "settings": [int(ok.sum()), int(len(table))], "flips": flips}
