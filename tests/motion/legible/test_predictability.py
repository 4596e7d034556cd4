"""Predictability against legibility: the correlation over the observer's own model is zero by construction,
straight lines reach their end points, and the correlation scan counts per seed and motion set."""

import numpy as np
import pytest

from mutual.motion.legible import double_integrator, predictability
from mutual.motion.observer import lifted_cost


DT, N = 0.01, 100
X0 = np.zeros(2)


def test_correlation_over_the_observers_own_model_is_zero_by_construction(reference):
    """With equal curvature, Cov(J1, J1 - J0) = a' H^-1 (H mean + h) = 0 exactly under P(u | H1)."""
    dyn, J1, J0 = reference
    H1, h1, _ = lifted_cost(dyn, J1, X0, N)
    H0, h0, _ = lifted_cost(dyn, J0, X0, N)
    np.testing.assert_allclose(H1, H0, atol=1e-12)
    a = h1 - h0                                   # J1 - J0 = a'u + const
    mean = -np.linalg.solve(H1, h1)
    assert abs(a @ np.linalg.solve(H1, H1 @ mean + h1)) < 1e-9
    table = predictability.predictability_correlations(dyn, J1, J0, X0, N, np.random.default_rng(0), n_samples=400)
    assert abs(table.set_index("motion set").loc[predictability.MOTION_SETS[-1], "r(J1, L)"]) < 0.2
    assert set(table["motion set"]) == set(predictability.MOTION_SETS)


def test_straight_lines_reach_their_end_points(reference):
    dyn = reference[0]
    ends = np.array([[1.0, 2.0], [-0.5, 0.3]])
    us = predictability.straight_lines(dyn, X0, N, ends)
    np.testing.assert_allclose(X0 + DT * us.sum(axis=1), ends, atol=1e-12)
    assert np.allclose(us, us[:, :1])                    # constant speed
    with pytest.raises(ValueError, match="cannot follow a straight line"):
        predictability.straight_lines(double_integrator(2, DT), np.zeros(4), N, np.ones((1, 4)))


def test_correlation_scan_counts_per_seed_and_set(reference):
    dyn, J1, J0 = reference
    by_seed, by_set = predictability.correlation_scan(dyn, J1, J0, X0, N, range(2), n_samples=200)
    assert list(by_seed["seed"]) == [0, 1] and by_seed["sets with r >= threshold"].between(0, 4).all()
    assert set(by_set["motion set"]) == set(predictability.MOTION_SETS)
    assert (by_set["r_min"] <= by_set["r_max"]).all() and by_set["seeds_reaching"].between(0, 2).all()
