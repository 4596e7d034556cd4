"""The Dubins car of eq. (5.1) and the closed-form avoid value, against brute-force simulation and rotation
invariance; huge inputs do not overflow; bad inputs (tables)."""

import re

import numpy as np
import pytest

from mutual.dubins import DubinsCar
from mutual.supervision.dubins import (avoid_value_closed_form, check_states, dubins_step, keep_out_margin,
                                       rotate_to_heading, unsafe_reach)
from mutual.supervision.reachability import QUICK_GRID, value_library

from helpers.supervision import STATES, case_id


W, R_OBS, V = 1.0, 1.0, 3.0


def _rollout_min_margin(states, control_sequences, dt):
    """min_t l(x(t)) for each state under each control sequence (k, T): (n, k)."""
    n, k = len(states), len(control_sequences)
    s = np.repeat(states, k, axis=0)
    u = np.tile(control_sequences, (n, 1))
    best = keep_out_margin(s, R_OBS)
    for step in range(u.shape[1]):
        s = dubins_step(s, u[:, step], dt)
        best = np.minimum(best, keep_out_margin(s, R_OBS))
    return best.reshape(n, k)


def _hard_turn_then_straight(dt, horizon):
    """Controls: turn hard left/right for tau seconds, then straight, for tau on a fine grid."""
    steps = int(horizon / dt)
    taus = np.arange(0, steps + 1, 2)
    seqs = [np.where(np.arange(steps) < t, sign * W, 0.0) for sign in (1, -1) for t in taus]
    return np.array(seqs)


def test_exact_step_matches_fine_euler_integration():
    rng = np.random.default_rng(0)
    s = np.column_stack([rng.normal(size=(20, 2)), rng.uniform(-np.pi, np.pi, 20)])
    u = rng.uniform(-2, 2, 20)
    u[:3] = 0.0
    fine = s.copy()
    for _ in range(10000):
        fine = fine + 1e-5 * np.column_stack([V * np.cos(fine[:, 2]), V * np.sin(fine[:, 2]), u])
    exact = dubins_step(s, u, 0.1)
    assert np.allclose(exact[:, :2], fine[:, :2], atol=1e-4)
    assert np.allclose(np.angle(np.exp(1j * (exact[:, 2] - fine[:, 2]))), 0, atol=1e-6)


def test_closed_form_equals_best_of_brute_force_controls():
    """The oracle is achieved by a hard turn then straight, and no sampled control does better."""
    rng = np.random.default_rng(1)
    p = rng.uniform(-6, 6, size=(60, 2))
    s = np.column_stack([p, rng.uniform(-np.pi, np.pi, 60)])
    s = s[keep_out_margin(s, R_OBS) > 0.2]
    dt, horizon = 0.01, 2 * np.pi / W
    oracle = avoid_value_closed_form(s, W, R_OBS)
    best_turn = _rollout_min_margin(s, _hard_turn_then_straight(dt, horizon), dt).max(axis=1)
    assert np.allclose(best_turn, oracle, atol=0.03)
    random_controls = np.repeat(rng.uniform(-W, W, size=(40, 20)), int(horizon / dt) // 20 + 1, axis=1)
    best_random = _rollout_min_margin(s, random_controls, dt).max(axis=1)
    assert np.all(best_random <= oracle + 0.02)


def test_closed_form_basic_geometry():
    # moving away: the distance to the disk
    assert avoid_value_closed_form([4.0, 0.0, 0.0], W, R_OBS)[0] == pytest.approx(3.0)
    # head-on at the unsafe reach: exactly on the zero level set
    reach = unsafe_reach(W, R_OBS)
    assert reach == pytest.approx(np.sqrt(2 * 3 * 1 + 1))
    assert avoid_value_closed_form([-reach, 0.0, 0.0], W, R_OBS)[0] == pytest.approx(0.0, abs=1e-12)
    # passing wide: a car that would miss the disk by 1 keeps at least that margin
    assert avoid_value_closed_form([-5.0, 2.0, 0.0], W, R_OBS)[0] >= 1.0 - 1e-12


def test_value_is_invariant_under_rotation_about_the_obstacle():
    rng = np.random.default_rng(4)
    s = np.column_stack([rng.uniform(-5, 5, (50, 2)), rng.uniform(-np.pi, np.pi, 50)])
    turned = rotate_to_heading(s, 0.7)
    assert np.allclose(turned[:, 2], 0.7)
    assert np.allclose(np.hypot(turned[:, 0], turned[:, 1]), np.hypot(s[:, 0], s[:, 1]))
    assert np.allclose(avoid_value_closed_form(turned, W, R_OBS), avoid_value_closed_form(s, W, R_OBS))


def test_dynamics_match_eq_5_1():
    car = DubinsCar(w_max=0.5)
    x = np.array([1.0, 2.0, 0.3])
    f = np.asarray(car(x, np.array([0.4]), np.zeros(2), 0.0))
    assert np.allclose(f, [3 * np.cos(0.3), 3 * np.sin(0.3), 0.4])
    grad = np.array([0.0, 0.0, -2.0])
    u, d = car.optimal_control_and_disturbance(x, 0.0, grad)
    assert float(u[0]) == pytest.approx(-0.5)  # the control maximises dV/dt


@pytest.mark.parametrize("bad, match", [
    (np.zeros((4, 2)), "shape"),
    (np.array([[0.0, np.nan, 0.0]]), "NaN"),
])
def test_bad_states_raise(bad, match):
    with pytest.raises(ValueError, match=match):
        check_states(bad)


@pytest.mark.parametrize("kwargs, match", [
    ({"w_max": 0.0}, "w_max"), ({"w_max": -1.0}, "w_max"), ({"radius": 0.0}, "radius"),
    ({"speed": np.inf}, "speed"),
])
def test_bad_parameters_raise(kwargs, match):
    args = {"w_max": 1.0, "radius": 1.0, "speed": 3.0} | kwargs
    with pytest.raises(ValueError, match=match):
        avoid_value_closed_form([0.0, 2.0, 0.0], **args)


@pytest.mark.parametrize("radius, speed, w_max", [(1e308, 3.0, 1.0), (1.0, 1e308, 1e-10), (1e200, 1e200, 1e-200)])
def test_huge_inputs_of_the_reach_do_not_overflow(radius, speed, w_max):
    reach = unsafe_reach(w_max, radius, speed)
    assert reach >= radius
    with pytest.raises(ValueError, match="half_width=8.0 is too small.*obstacle radius"):
        value_library([w_max, 2 * w_max], radius, QUICK_GRID, speed=speed, progress=False)


CASES = [
    # the Dubins car and its closed form (mutual.supervision.dubins)
    (avoid_value_closed_form, ([0.0, 2.0, 0.0], 0.0, 1.0), {}, ValueError, "w_max must be a positive finite"),
    (avoid_value_closed_form, ([0.0, 2.0, 0.0], 1.0, "one"), {}, ValueError, "radius must be a positive finite"),
    (check_states, ([[1.0, 2.0]],), {}, ValueError, "must have shape (n, 3)"),
    (check_states, ([["a", "b", "c"]],), {}, ValueError, "states must be numbers of shape (n, 3)"),
    (dubins_step, (STATES, 0.0, -0.1), {}, ValueError, "dt must be a positive finite"),
    (dubins_step, (STATES, [0.0, 1.0], 0.1), {}, ValueError, "controls must be one turn rate or one per state"),
    (keep_out_margin, ([[np.nan, 0.0, 0.0]], 1.0), {}, ValueError, "states contains NaN"),
    (rotate_to_heading, (STATES,), {"heading": np.inf}, ValueError, "heading must be a finite angle"),
    (unsafe_reach, (1.0, -1.0), {}, ValueError, "radius must be a positive finite"),
]


@pytest.mark.parametrize("func, args, kwargs, error, phrase", CASES, ids=[case_id(c) for c in CASES])
def test_bad_input_raises_a_clear_error(func, args, kwargs, error, phrase):
    with pytest.raises(error, match=re.escape(phrase)):
        func(*args, **kwargs)
