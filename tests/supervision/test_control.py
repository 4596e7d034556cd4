"""Control on a learned safe set (Sec. 4.5): at alpha = mu + 2 sigma over 97 % of interventions are avoided,
the filter keeps robots out of K and above the level (the closest obstacle with several), the Property holds
on exact values, and the false-positive counts are binomially consistent; bad inputs (a table)."""

import re

import numpy as np
import pytest

from mutual.supervision.control import (binomial_consistent, false_positive_rates, filter_control, safety_controller,
                                        simulate_filtered)
from mutual.supervision.dubins import keep_out_margin
from mutual.supervision.exact import exact_counterpart, exact_value_function
from mutual.supervision.fit import fit_supervisor
from mutual.supervision.supervisor import NoisySupervisor, approach_scenes
from mutual.supervision.value_function import GridSpec

from helpers.supervision import (RADIUS, STATES, case_id, simulated_interventions, small_supervisor,
                                 small_value_function)


def test_alpha_mu_plus_two_sigma_avoids_over_97_percent_of_interventions(library):
    states = simulated_interventions(library, 0.75, 0.5, 0.1, 600, seed=7)
    fit = fit_supervisor(library, states)
    assert fit.coverage(states, 2.0) > 0.97  # on the values the fit read (exact)
    below = exact_counterpart(fit.value_fn).interp(states) <= fit.level(2.0)
    assert below.mean() > 0.97


def test_filter_keeps_robots_out_of_k_and_above_the_level(library):
    vf = library[library.index_of(0.75)]
    rng = np.random.default_rng(4)
    scenes = approach_scenes(60, rng, RADIUS, 7.0)
    start = scenes[:, 0]
    controller = safety_controller(vf, alpha=0.5, u_max=1.0)  # a robot more agile than the model
    path = simulate_filtered(controller, start, 0.0, duration=6.0)
    assert keep_out_margin(path, RADIUS).min() > 0
    # robots only dip below alpha by the discretisation of the switching
    assert np.nanmin(vf.interp(path.reshape(-1, 3))) > 0.5 - 0.3
    # far from the level the nominal control passes unchanged
    far = np.array([[7.5, 7.5, 0.0], [-7.0, 0.0, np.pi]])
    assert np.all(filter_control(vf, far, 0.3, alpha=0.5) == 0.3)


def test_filter_with_obstacles_uses_the_closest_obstacle(library):
    vf = library[library.index_of(1.0)]
    obstacles = np.array([[0.0, 0.0], [30.0, 0.0]])
    robots = np.array([[27.5, 0.0, 0.0], [-2.5, 0.0, 0.0], [15.0, 0.0, 0.0]])
    u = filter_control(vf, robots, 0.0, alpha=0.2, obstacles=obstacles)
    rel = robots[:2] - np.array([[30.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    assert np.array_equal(u[:2], vf.safe_control(rel)) and np.all(u[:2] != 0)
    assert u[2] == 0.0


GRID = GridSpec(8.0, (41, 41, 24))


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


def test_binomial_consistency():
    assert binomial_consistent(0.5, 400, 0.5)[0] and not binomial_consistent(0.6, 400, 0.5)[0]
    np.testing.assert_array_equal(binomial_consistent([0.0, 0.16], 100, [0.0, 0.1587]), [True, True])
    with pytest.raises(ValueError, match="fractions"):
        binomial_consistent(1.5, 10, 0.5)


rng = np.random.default_rng


CASES = [
    # control on a learned safe set
    (lambda: filter_control(small_value_function(), STATES, np.nan, 0.0), (), {}, ValueError, "nominal_u contains NaN"),
    (lambda: filter_control(small_value_function(), STATES, 0.0, [0.0, 1.0]), (), {}, ValueError, "alpha must be one finite number"),
    (lambda: filter_control(small_value_function(), STATES, 0.0, 0.0, lookahead=-1.0), (), {}, ValueError,
     "lookahead must be a non-negative finite"),
    (lambda: filter_control(small_value_function(), STATES, 0.0, 0.0, obstacles=[[1.0, 2.0, 3.0]]), (), {}, ValueError,
     "obstacles must be a (k, 2) array"),
    (lambda: filter_control("V", STATES, 0.0, 0.0), (), {}, ValueError, "value_fn must be a mutual.supervision"),
    (lambda: safety_controller(small_value_function(), alpha=np.inf), (), {}, ValueError, "alpha must be finite"),
    (lambda: false_positive_rates(small_supervisor(), small_value_function(), [], 10, rng(0), 7.5), (), {}, ValueError,
     "alphas must be a non-empty sequence"),
    (lambda: false_positive_rates(small_supervisor(), small_value_function(), [0.5], 0, rng(0), 7.5), (), {}, ValueError,
     "n_robots must be an integer >= 1"),
    (lambda: simulate_filtered("controller", STATES, 0.0, 1.0), (), {}, ValueError, "controller must be callable"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
