"""iLQR motion that evidences the learned safe set: the JAX avoid value against the numpy closed form,
ignorant paths drive through and avoiding paths keep out, iLQR paths stationary by autodiff; bad inputs
(a table)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mutual.cycle.evidence import ILQR_OPTIONS, PROBLEM, SafeSetTask, avoid_value, first_crossing, solve_path
from mutual.supervision.dubins import avoid_value_closed_form


def test_jax_avoid_value_is_the_closed_form_and_smoothing_stays_close():
    states = np.random.default_rng(0).uniform([-6, -4, -np.pi], [6, 4, np.pi], size=(400, 3))
    exact = avoid_value_closed_form(states, 0.75, 1.0)
    with jax.enable_x64(True):
        sharp = np.array([float(avoid_value(jnp.asarray(s), 0.75, 1.0)) for s in states])
        smooth = np.array([float(avoid_value(jnp.asarray(s), 0.75, 1.0, smoothing=0.02)) for s in states])
    np.testing.assert_allclose(sharp, exact, atol=1e-9)
    assert np.max(np.abs(smooth - exact)) < 0.05


@pytest.fixture(scope="module")
def safe_task():
    task = SafeSetTask(x0=(-7.5, -0.5, 0.0), goal=(7.5, -0.5), horizon=5.0, steps=20, a_goal=10.0,
                       a_effort=2.0, a_safe=1000.0)
    return task, task.hypotheses(0.75, 0.6, 0.5)


def test_ignorant_path_drives_through_and_avoiding_paths_keep_out(safe_task):
    task, hyp = safe_task
    paths = {name: solve_path(task, params) for name, params in hyp.items()}
    assert np.allclose(paths["H0"].xs[:, 1], -0.5, atol=1e-6)            # straight at the obstacle
    for name in ("H1", "legible"):
        v = avoid_value_closed_form(paths[name].xs, 0.75, 1.0)
        assert v.min() > 0.6 - 0.05, name                                 # outside {V < level} up to the hinge
    assert first_crossing(paths["H0"].xs, task.dt, lambda x: avoid_value_closed_form(x, 0.75, 1.0), 0.6) < 2.0
    # the legible weights are (1 + alpha) w1 - w0 (eq. 6.15)
    np.testing.assert_allclose(hyp["legible"]["weights"], 1.5 * hyp["H1"]["weights"] - hyp["H0"]["weights"])


def test_ilqr_paths_are_stationary_by_autodiff(safe_task):
    from mutual.motion.trajopt import trajectory_cost_grad
    task, hyp = safe_task
    for name in ("H1", "legible"):
        r = solve_path(task, hyp[name])
        value, grad = trajectory_cost_grad(*PROBLEM, np.asarray(task.x0), r.us, hyp[name])
        assert np.abs(grad).max() <= 10 * ILQR_OPTIONS["grad_tol"] * (1 + abs(value))


TASK = dict(x0=(-7.5, -0.5, 0.0), goal=(7.5, -0.5), horizon=5.0, steps=10, a_goal=10.0, a_effort=2.0, a_safe=100.0)


CASES = [
    (SafeSetTask, (), dict(TASK, x0=(0.0, 0.0)), ValueError, "x0/goal"),
    (SafeSetTask, (), dict(TASK, horizon=-1.0), ValueError, "horizon"),
    (SafeSetTask, (), dict(TASK, steps=0), ValueError, "steps"),
    (SafeSetTask, (), dict(TASK, a_safe=-1.0), ValueError, "a_safe"),
    (SafeSetTask(**TASK).params, (), {"w_max": 0.0}, ValueError, "w_max/level"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
