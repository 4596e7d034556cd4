"""Refinement of the grid near an inferred boundary: only the cells near the boundary split, and every level
is reported."""

import numpy as np

from mutual.constraints.continuous import Bound, Disk, Grid, Problem, QuadraticReward
from mutual.constraints.continuous.refine import refine_near, refinement

from helpers.continuous import DI, recording_of


def test_refinement_splits_only_the_cells_near_the_boundary():
    grid = Grid.uniform([-1, -1], [1, 1], [10, 10], [False, False], DI.state_names, DI.state_units)
    fine = refine_near(grid, Bound(1, "upper", 0.4), window=1)
    assert fine.shape == (10, 13) and np.all(np.isin(grid.edges[1], fine.edges[1]))
    assert np.allclose(np.diff(fine.edges[1])[(fine.edges[1][:-1] > 0.15) & (fine.edges[1][:-1] < 0.55)], 0.1)
    disk = refine_near(grid, Disk((0, 1), (0.0, 0.0), 0.3), window=1)
    assert disk.shape[0] > 10 and disk.shape[1] > 10


def test_refinement_reports_every_level():
    grid = Grid.uniform([-1.5, -1.5], [1.5, 1.5], [9, 9], [False, False], DI.state_names, DI.state_units)
    problem = Problem(DI, grid, [-1.0, 0.0, 1.0], 0.2, 12, QuadraticReward([1, 0], [1, 0.1], [0.05], [5, 1], 0.5))
    rec = recording_of(problem, [(-1.0, 0.0)] * 3, [(1, 1, 0, 0, 0, 0, 0, 0, 0, 0, -1, -1)] * 3)
    table, runs = refinement(problem, rec, levels=1, truth=[Bound(1, "upper", 0.4)], scheduler="inline")
    assert list(table["level"]) == [0, 1][:len(runs)] and len(runs) >= 1
    assert runs[-1].problem.grid.n_cells >= runs[0].problem.grid.n_cells
