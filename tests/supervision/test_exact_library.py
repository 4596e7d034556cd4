"""The exact avoid value across the library of Fig. 4.2, against brute-force rollouts of the game: at the
slowest and the fastest turner (the closed form is the independent route that checks the HJ library), and
on the boundary of the keep-out disk (line 862: where the zero level set meets the boundary of H)."""

import numpy as np
import pytest

from mutual.supervision.dubins import avoid_value_closed_form, dubins_step, keep_out_margin
from mutual.supervision.exact import exact_value_function
from mutual.supervision.value_function import QUICK_GRID, boundary_values

R_OBS = 1.0


def best_rollout(states, w_max, dt, horizon, every):
    """max over controls 'turn hard left or right for tau, then straight' (tau every ``every`` steps) of
    min_t l(x(t)): the value the best of these controls secures, a lower bound on V reached by the optimum."""
    steps = int(round(horizon / dt))
    taus = np.arange(0, steps + 1, every)
    controls = np.array([np.where(np.arange(steps) < t, sign * w_max, 0.0) for sign in (1, -1) for t in taus])
    s = np.repeat(states, len(controls), axis=0)
    u = np.tile(controls, (len(states), 1))
    worst = keep_out_margin(s, R_OBS)
    for step in range(steps):
        s = dubins_step(s, u[:, step], dt)
        worst = np.minimum(worst, keep_out_margin(s, R_OBS))
    return worst.reshape(len(states), len(controls)).max(axis=1)


@pytest.mark.parametrize("w_max, every", [(0.25, 8), (3.0, 1)])
def test_closed_form_equals_the_best_rollout_at_the_ends_of_the_library(w_max, every):
    rng = np.random.default_rng(2)
    p = rng.uniform(-7, 7, size=(80, 2))
    s = np.column_stack([p, rng.uniform(-np.pi, np.pi, 80)])
    s = s[keep_out_margin(s, R_OBS) > 0.2][:24]
    best = best_rollout(s, w_max, dt=0.01, horizon=2 * np.pi / w_max, every=every)
    assert np.allclose(best, avoid_value_closed_form(s, w_max, R_OBS), atol=0.03)


@pytest.mark.parametrize("w_max", [0.25, 1.0, 3.0])
def test_on_the_boundary_of_the_disk_only_headings_into_it_are_unsafe(w_max):
    """On |p| = r: V = 0 where the car does not head into the disk (driving straight keeps l >= 0, and V <= l = 0)
    and V < 0 where it does; the exact value matches the best rollout at every one of these states."""
    vf = exact_value_function(w_max, R_OBS, QUICK_GRID)
    values, approaching = boundary_values(vf, n_points=3, n_headings=12)
    assert approaching.sum() == values.size // 2
    assert np.all(values[~approaching] == pytest.approx(0.0, abs=1e-12)) and np.all(values[approaching] < 0)
    around = np.repeat(2 * np.pi * np.arange(3) / 3, 12)
    heading = around + np.tile(2 * np.pi * (np.arange(12) + 0.5) / 12, 3)
    states = np.column_stack([R_OBS * np.cos(around), R_OBS * np.sin(around), heading])
    best = best_rollout(states, w_max, dt=0.01, horizon=np.pi / w_max + 1.0, every=max(1, round(1 / w_max)))
    assert np.allclose(best, values.ravel(), atol=0.03)


@pytest.mark.parametrize("kwargs, message", [({"n_points": 1}, "n_points must be an integer >= 2"),
                                             ({"n_headings": 2.5}, "n_headings must be an integer >= 2"),
                                             ({"n_points": True}, "n_points must be an integer >= 2")])
def test_bad_boundary_sampling_is_refused(kwargs, message):
    with pytest.raises(ValueError, match=message):
        boundary_values(exact_value_function(1.0, R_OBS, QUICK_GRID), **kwargs)
    with pytest.raises(ValueError, match="value_fn must be a ValueFunction, got ndarray"):
        boundary_values(np.zeros((2, 3)))
