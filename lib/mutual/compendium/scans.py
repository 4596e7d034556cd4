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
    chosen set-up, or None for an experiment with no random draw. ``flips`` lists up to ``limit`` cells of the
    minority: where the statement fails, or, when it holds in fewer cells than it fails, where it holds; empty
    when it holds everywhere."""
    ok = table[holds].astype(bool)
    few, verb = (table[ok], "holds only") if 0 < ok.sum() < (~ok).sum() else (table[~ok], "fails")
    shown = "; ".join(_cell(row, by) for _, row in few.head(limit).iterrows())
    more = f" (and {len(few) - limit} more)" if len(few) > limit else ""
    flips = f"{verb} in {len(few)} of {len(table)} cells: {shown}{more}" if (~ok).any() else ""
    return {"table": name, "seeds": None if seeds is None else [int(seeds[0]), int(seeds[1])],
            "settings": [int(ok.sum()), int(len(table))], "flips": flips}
