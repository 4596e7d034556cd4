"""Fig. 7.2's second scan: start states around the hazard and horizons relative to the straight-line time."""

import numpy as np
import pytest

from mutual.motion.evident import safety as es
from mutual.motion.evident import scans
from mutual.motion.evident.evidence import distance_to_point


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
