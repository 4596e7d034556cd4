"""The scans of what the thesis leaves open: Figure 7.2's scan solves both hazards for every alpha, Figure 6.1's
scan rows, and Figure 7.2's second scan over start states around the hazard and horizons."""

import numpy as np
import pytest

from mutual.motion.evident import safety as es
from mutual.motion.evident import scans
from mutual.motion.evident.evidence import distance_to_point


def test_figure_72_scan_solves_both_hazards_for_every_alpha():
    from mutual.motion.evident import scans
    table, paths = scans.figure_72_scan([0.5, 1.0], [[-2.0, 2.0], [2.0, -2.0]], steps=20)
    assert len(table) == 4 and set(table["hazard"]) == {"[-2.0, 2.0]", "[2.0, -2.0]"}
    assert {"obvious", "anticipates", "H1 only slightly", "feature legible"} <= set(table.columns)
    assert set(paths[(2.0, -2.0)]) == {"H0", "H1", 0.5, 1.0}
    same = es.solve(es.figure_scenario("7.2", steps=20)[0], es.figure_scenario("7.2", steps=20)[2])
    np.testing.assert_allclose(paths[(-2.0, 2.0)]["H1"].xs, same.xs)       # the chosen cell is the notebook's solve


def test_figure_61_scan_rows():
    from mutual.motion.evident import scans
    table = scans.figure_61_scan((10.0,), (5.0, 20.0), (0.5,), steps=20)
    assert len(table) == 2 and table["H0 collides"].all()                   # the person stands on H0's course
    assert (table["H1 closest"] > 0).all() and table["error"].eq("").all()


def test_ring_starts_head_for_the_goal_and_skip_starts_at_it():
    hazard, goal = np.array([-2.0, 2.0]), np.array([2.0, -1.0])
    starts = scans.ring_starts(hazard, goal)
    assert starts.shape == (45, 3)                                   # 2 radii x 8 bearings, one dropped, 3 headings
    assert np.all(np.linalg.norm(starts[:, :2] - goal, axis=1) >= 2.5)
    np.testing.assert_allclose(np.sort(np.unique(np.round(np.linalg.norm(starts[:, :2] - hazard, axis=1), 9))), [2.0, 4.5])
    towards = starts[::3]                                            # the first heading of each position: towards g
    direction = np.c_[np.cos(towards[:, 2]), np.sin(towards[:, 2])]
    to_goal = (goal - towards[:, :2]) / np.linalg.norm(goal - towards[:, :2], axis=1, keepdims=True)
    np.testing.assert_allclose(direction, to_goal, atol=1e-12)


def test_start_scan_reproduces_the_drawn_cell():
    """Our own start through the scan gives the same H1 gain as solving H0 and H1 directly."""
    base, w0, w1 = es.figure_scenario("7.2", steps=20)
    start = base.x0
    kappa = base.horizon / (np.linalg.norm(base.goal - start[:2]) / base.speed)
    row = scans.figure_72_start_scan(start[None], (kappa,), steps=20, turn_rates=(0.0,)).iloc[0]
    h0, h1 = es.solve(base, w0), es.solve(base, w1)
    i0, i1 = (distance_to_point(r.xs, base.hazard, base.dt)["integral"] for r in (h0, h1))
    assert row["T (s)"] == pytest.approx(base.horizon)
    assert row["H1 integral gain"] == pytest.approx(i1 / i0 - 1, rel=1e-6)
    assert row["H1 only slightly"] == (0 < i1 / i0 - 1 < scans.H1_ONLY_SLIGHTLY)
