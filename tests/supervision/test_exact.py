"""Exact values where a closed form exists: the closed form at the states, the exact safe control, a library of
exact members, and the grid's error against it -- each against an independent truth (the head-on closed
form sqrt(d^2 + R^2) - R - r, the grid's own trilinear interpolation)."""

import numpy as np
import pytest

from mutual.supervision.dubins import avoid_value_closed_form
from mutual.supervision.exact import (ExactValueFunction, exact_library, exact_value_function, grid_error,
                                      interpolated_closed_form)
from mutual.supervision.fit import fit_supervisor
from mutual.supervision.reachability import value_library
from mutual.supervision.value_function import GridSpec

from helpers.supervision import head_on


GRID = GridSpec(8.0, (41, 41, 24))


def test_exact_values_are_the_closed_form_at_the_states():
    rng = np.random.default_rng(0)
    v = rng.uniform(0.0, 3.0, 200)
    exact = exact_value_function(1.0, 1.0, GRID)
    states = head_on(v, rng)
    assert isinstance(exact, ExactValueFunction) and exact.exact
    np.testing.assert_allclose(exact.interp(states), v, atol=1e-12)
    other = np.column_stack([rng.uniform(-7, 7, (300, 2)), rng.uniform(-np.pi, np.pi, 300)])
    np.testing.assert_allclose(exact.interp(other), avoid_value_closed_form(other, 1.0, 1.0), atol=1e-12)
    assert np.isnan(exact.interp([[9.0, 0.0, 0.0]]))[0]  # off the grid's domain, as for a grid value function


def test_the_exact_safe_control_turns_away():
    exact = exact_value_function(1.0, 1.0, GRID)
    # a car left of the centre line heading right turns left (up, away), one right of it turns right
    assert exact.safe_control([[-4.0, 0.3, 0.0]])[0] > 0
    assert exact.safe_control([[-4.0, -0.3, 0.0]])[0] < 0


def test_a_library_of_exact_members_is_evaluated_exactly():
    lib = exact_library([0.5, 1.0], 1.0, GRID)
    states = np.array([[-3.0, 0.2, 0.1], [2.0, -1.0, 2.0]])
    np.testing.assert_allclose(lib.interp_all(states)[1], avoid_value_closed_form(states, 1.0, 1.0), atol=1e-12)


def test_the_grid_overestimates_head_on_values_through_theta():
    """The head-on bias is trilinear interpolation in theta across the kink of V: with the closed form at the nodes
    it is large at random headings and nearly gone at node headings."""
    rng = np.random.default_rng(1)
    states = head_on(rng.uniform(0.2, 1.0, 300), rng)
    on_nodes = states.copy()
    on_nodes[:, 2] = np.round(on_nodes[:, 2] / GRID.spacings[2]) * GRID.spacings[2]
    closed = value_library([1.0], 1.0, GRID, method="closed-form")[0]
    assert grid_error(closed, states)["bias"] > 0.1
    assert abs(grid_error(closed, on_nodes)["bias"]) < 0.03
    np.testing.assert_allclose(interpolated_closed_form(GRID, states, 3.0, 1.0), closed.interp(states), atol=1e-5)


def test_a_library_with_a_disturbance_has_no_closed_form():
    from mutual.supervision.value_function import ValueFunction, ValueLibrary

    member = exact_value_function(1.0, 1.0, GRID)
    disturbed = ValueLibrary((ValueFunction(1.0, 1.0, GRID, member.values, d_max=0.2),))
    with pytest.raises(ValueError, match="no closed form"):
        fit_supervisor(disturbed, head_on([0.5, 0.6, 0.7], np.random.default_rng(0)), values="exact")
