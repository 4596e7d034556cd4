"""Refinement (the cells model): infer on a coarse grid, then split the cells near each inferred boundary
and infer again.

A uniform grid fine enough to place a boundary precisely is costly in every dimension; the
boundary only needs fine cells where it lies. :func:`refine_near` splits, along the coordinates a
chosen region constrains, the cells within ``window`` cells of its boundary (a bound's value, a
disk's or box's extent in its plane) into ``factor`` equal parts; the rest of the grid stays as it
was. :func:`refinement` repeats infer-then-refine and records how the boundary moves.
"""

import time

import pandas as pd

from .cells import infer_cells
from .inference import boundary_errors
from .regions import Bound, Box, Disk


def _cell_width(grid, dim, value):
    edges = grid.edges[dim]
    j = min(max(int((edges <= value).sum()) - 1, 0), edges.size - 2)
    return edges[j + 1] - edges[j]


def refine_near(grid, region, window=2, factor=2):
    """``grid`` with the cells near ``region``'s boundary split (module docstring)."""
    if isinstance(region, Bound):
        w = window * _cell_width(grid, region.dim, region.value)
        return grid.refine(region.dim, region.value - w, region.value + w, factor)
    if isinstance(region, (Disk, Box)):
        for n, dim in enumerate(region.dims):
            if isinstance(region, Disk):
                lo, hi = region.center[n] - region.radius, region.center[n] + region.radius
            else:
                lo, hi = region.low[n], region.high[n]
            w = window * max(_cell_width(grid, dim, lo), _cell_width(grid, dim, hi))
            grid = grid.refine(dim, lo - w, hi + w, factor)
        return grid
    raise ValueError(f"region: cannot refine near {region!r} (a cell candidate has no boundary to refine)")


def refinement(problem, recording, levels=2, truth=(), window=2, factor=2, **infer_options):
    """Infer on ``problem``'s grid (:func:`.cells.infer_cells`), then ``levels`` times refine near every
    chosen region (cells excepted) and infer again. Returns a table -- per level: cells, the chosen
    constraints, the boundary error against each region of ``truth`` -- and the
    :class:`~.cells.CellInference` of every level. ``infer_options`` go to :func:`.cells.infer_cells`."""
    rows, runs, current = [], [], problem
    for level in range(levels + 1):
        start = time.perf_counter()
        run = infer_cells(current, recording, **infer_options)
        runs.append(run)
        errors = boundary_errors(run, truth)
        rows.append({"level": level, "cells": current.grid.n_cells,
                     "chosen": "; ".join(run.labels()) or "none",
                     **{f"error {region.describe(current.grid)}": e for region, e in zip(truth, errors)},
                     "seconds": time.perf_counter() - start})
        chosen = [r for r in run.chosen_regions() if r is not None]
        if level == levels or not chosen:
            break
        grid = current.grid
        for region in chosen:
            grid = refine_near(grid, region, window, factor)
        current = current.replace(grid=grid)
    return pd.DataFrame(rows), runs
