"""Exact values where a closed form exists (issue 20 §3): the closed form at the states, the fit on it, the
grid's error against it, and the Property of Sec. 4.5 on it -- each against an independent truth (the
head-on closed form sqrt(d^2 + R^2) - R - r, Monte Carlo, the grid's own trilinear interpolation)."""

import warnings

import numpy as np
import pandas as pd
import pytest

from mutual.supervision.control import binomial_consistent, false_positive_rates
from mutual.supervision.dubins import avoid_value_closed_form
from mutual.supervision.exact import (ExactValueFunction, exact_library, exact_value_function, grid_error,
                                      interpolated_closed_form)
from mutual.supervision.fit import (GridValueWarning, data_efficiency_scan, expected_coverage, fit_supervisor,
                                    member_values)
from mutual.supervision.reachability import value_library
from mutual.supervision.supervisor import NoisySupervisor
from mutual.supervision.value_function import GridSpec

GRID = GridSpec(8.0, (41, 41, 24))


def head_on(values, rng):
    """Head-on states (heading at the obstacle centre from a random bearing) with the true robot's exact value
    ``values``: V = sqrt(d^2 + 9) - 4 (R = 3, r = 1)."""
    d, b = np.sqrt((np.asarray(values) + 4) ** 2 - 9), rng.uniform(-np.pi, np.pi, len(values))
    return np.stack([d * np.cos(b), d * np.sin(b), b + np.pi], axis=1)


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


def test_the_fit_reads_exact_values_and_warns_on_the_grid():
    rng = np.random.default_rng(2)
    v = 0.5 + 0.1 * rng.standard_normal(40)
    states = head_on(v, rng)
    lib = value_library([1.0], 1.0, GRID, method="closed-form")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        exact_fit = fit_supervisor(lib, states)
        assert not any(issubclass(w.category, GridValueWarning) for w in caught)
        grid_fit = fit_supervisor(lib, states, values="grid")
    assert exact_fit.values == "exact" and exact_fit.mu == pytest.approx(v.mean(), abs=1e-9)
    assert grid_fit.mu - v.mean() > 0.1 and grid_fit.value_error > 0.1
    assert any(issubclass(w.category, GridValueWarning) for w in caught)
    np.testing.assert_allclose(member_values(lib, states)[0], v, atol=1e-12)


def test_a_library_with_a_disturbance_has_no_closed_form():
    from mutual.supervision.value_function import ValueFunction, ValueLibrary

    member = exact_value_function(1.0, 1.0, GRID)
    disturbed = ValueLibrary((ValueFunction(1.0, 1.0, GRID, member.values, d_max=0.2),))
    with pytest.raises(ValueError, match="no closed form"):
        fit_supervisor(disturbed, head_on([0.5, 0.6, 0.7], np.random.default_rng(0)), values="exact")


def test_the_property_holds_on_exact_values():
    """Sec. 4.5: robots avoiding at alpha = mu on the exact value never alarm a noiseless supervisor of that set."""
    sup_fn = exact_value_function(0.75, 1.0, GRID)
    ideal = NoisySupervisor(sup_fn, 0.5, 0.0)
    rates, closest, lowest = false_positive_rates(ideal, sup_fn, [0.5], 100, np.random.default_rng(3), 7.5,
                                                  lowest_values=True)
    assert rates[0] == 0 and lowest.min() >= 0.5 - 1e-6
    std_rates, std_closest = false_positive_rates(ideal, exact_value_function(1.0, 1.0, GRID), [0.0], 100,
                                                  np.random.default_rng(3), 7.5)
    assert std_rates[0] > 0.9 and std_closest >= 0  # the Standard set alarms it, and keeps robots out of K


def test_the_teaming_batch_evaluates_exact_functions_exactly():
    from mutual.study.value_stack import _Stack

    fns = [exact_value_function(w, r, GRID) for w, r in ((1.0, 1.0), (0.5, 2.0))]
    stack = _Stack(fns, np.array([0, 1, 1]), "team")
    rng = np.random.default_rng(4)
    states = np.concatenate([rng.uniform(-6, 6, (3, 5, 2, 2)), rng.uniform(-np.pi, np.pi, (3, 5, 2, 1))], axis=-1)
    got = stack.interp(states)
    for b, f in enumerate([fns[0], fns[1], fns[1]]):
        np.testing.assert_allclose(got[b].ravel(), f.interp(states[b].reshape(-1, 3), fill_value=np.inf), atol=1e-12)
    with pytest.raises(ValueError, match="all exact"):
        _Stack([fns[0], value_library([1.0], 1.0, GRID, method="closed-form")[0]], np.array([0, 1]), "team")


def test_expected_coverage_against_monte_carlo():
    rng = np.random.default_rng(5)
    x = rng.standard_normal((100_000, 40))
    u = (x - x.mean(axis=1, keepdims=True)) / x.std(axis=1, keepdims=True)
    assert expected_coverage(2.0, 40) == pytest.approx(np.mean(u <= 2), abs=3e-4)
    assert expected_coverage(2.0, 10 ** 6) == pytest.approx(0.97725, abs=1e-4)
    with pytest.raises(ValueError, match="p must be"):
        expected_coverage(2.0, 2)


def test_binomial_consistency():
    assert binomial_consistent(0.5, 400, 0.5)[0] and not binomial_consistent(0.6, 400, 0.5)[0]
    np.testing.assert_array_equal(binomial_consistent([0.0, 0.16], 100, [0.0, 0.1587]), [True, True])
    with pytest.raises(ValueError, match="fractions"):
        binomial_consistent(1.5, 10, 0.5)


def test_data_efficiency_scan_counts_sessions():
    rows = [{"w_max": w, "sigma": s, "seed": k, "n": 40, "recovered": k < (10 if s == 0.05 else 5)}
            for w in (0.5, 0.75) for s in (0.05, 0.2) for k in range(10)]
    cells, scan = data_efficiency_scan(pd.DataFrame(rows), 40, (0.75, 0.05), table_name="t")
    assert scan["seeds"] == [10, 10] and scan["settings"] == [2, 4] and "sigma 0.2: 5/10" in scan["flips"]
    assert len(cells) == 4
