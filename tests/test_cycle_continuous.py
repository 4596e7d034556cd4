"""The continuous loop against independent truth: the Laplace observer against the exact Gaussian of a
linear-quadratic problem (and chapter 6's closed-form observer), the JAX avoid value against the numpy
closed form, iLQR paths against the safe set, and the exact false-positive probability against sampling."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from mutual.cycle.evidence import (PROBLEM, SafeSetTask, avoid_value, first_confidence, first_crossing, solve_path,
                                   ILQR_OPTIONS)
from mutual.cycle.laplace import posterior_over_time, prefix_log_likelihoods
from mutual.cycle.supervision import closed_form_library, closed_form_value_function, false_positive_study
from mutual.motion.legible import reaching_cost, single_integrator
from mutual.motion.observer import log_boltzmann
from mutual.supervision.dubins import avoid_value_closed_form
from mutual.supervision.reachability import QUICK_GRID
from mutual.supervision.supervisor import NoisySupervisor

N, DT = 10, 0.1
P = {"dt": np.float64(DT), "a": np.float64(4.0), "b": np.float64(2.5), "c": np.float64(0.3),
     "h": np.array([0.0, 0.0]), "g": np.array([2.0, -2.0])}
X0 = np.array([-2.0, 1.0])


def lq_dynamics(x, u, p):
    return x + p["dt"] * u


def lq_running(x, u, p):
    return p["dt"] * (p["b"] * jnp.sum(u ** 2) - p["c"] * jnp.sum((x - p["h"]) ** 2))


def lq_terminal(x, p):
    return p["a"] * jnp.sum((x - p["g"]) ** 2)


def lq_gaussian(p):
    """Mean and covariance of P(u) ~ exp(-J(u)) for the quadratic J, from its exact Hessian."""
    def J(v):
        u, x, total = v.reshape(N, 2), jnp.asarray(X0), 0.0
        for k in range(N):
            total += lq_running(x, u[k], p)
            x = lq_dynamics(x, u[k], p)
        return total + lq_terminal(x, p)
    with jax.enable_x64(True):
        H = np.asarray(jax.hessian(J)(jnp.zeros(2 * N)))
        h = np.asarray(jax.grad(J)(jnp.zeros(2 * N)))
    return -np.linalg.solve(H, h), np.linalg.inv(H)


@pytest.mark.parametrize("c", [0.0, 0.3])
def test_laplace_prefix_likelihoods_are_exact_for_linear_quadratic_problems(c):
    p = dict(P, c=np.float64(c))
    us = np.random.default_rng(1).normal(size=(N, 2))
    got = prefix_log_likelihoods(lq_dynamics, lq_running, lq_terminal, X0, us, p)
    mean, cov = lq_gaussian(p)
    exact = [0.0] + [stats.multivariate_normal(mean[:2 * t], cov[:2 * t, :2 * t]).logpdf(us[:t].ravel())
                     for t in range(1, N + 1)]
    np.testing.assert_allclose(got, exact, atol=1e-8)


def test_laplace_full_likelihood_matches_chapter_6s_closed_form_observer():
    """c = 0 is chapter 6's reaching cost; its full-trajectory likelihood in mutual.motion.observer."""
    p = dict(P, c=np.float64(0.0))
    us = np.random.default_rng(2).normal(size=(N, 2))
    got = prefix_log_likelihoods(lq_dynamics, lq_running, lq_terminal, X0, us, p)[-1]
    cost = reaching_cost(P["g"], dt=DT, terminal_weight=4.0, effort_weight=2.5)
    assert got == pytest.approx(log_boltzmann(single_integrator(2, DT), cost, X0, us), abs=1e-8)


def test_posterior_over_time():
    post = posterior_over_time([0.0, 1.0, 3.0], [0.0, 0.0, 0.0], prior=0.5)
    np.testing.assert_allclose(post, 1 / (1 + np.exp(-np.array([0.0, 1.0, 3.0]))))
    assert first_confidence(post, 0.5, 0.95) == 1.0 and first_confidence(post[:2], 0.5) == np.inf


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


def test_closed_form_library_samples_the_closed_form():
    lib = closed_form_library([0.5, 1.0], 1.0, QUICK_GRID)
    xs, ys, ts = QUICK_GRID.coordinate_vectors
    nodes = np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)
    np.testing.assert_allclose(lib[1].values.ravel(), avoid_value_closed_form(nodes, 1.0, 1.0), atol=1e-5)
    assert lib.w_maxes.tolist() == [0.5, 1.0]


def test_exact_false_positive_probability_agrees_with_sampled_judgements():
    sup_vf = closed_form_value_function(0.75, 1.0, QUICK_GRID)
    supervisor = NoisySupervisor(sup_vf, 0.5, 0.3)
    controller = closed_form_value_function(1.0, 1.0, QUICK_GRID)
    n = 300
    out = false_positive_study(supervisor, {"standard": (controller, 0.3)}, n, np.random.default_rng(0), 7.5, dt=0.05)
    row = out.iloc[0]
    assert 0.0 < row["p_false_positive"] < 1.0
    assert abs(row["sampled"] - row["p_false_positive"]) < 5 * np.sqrt(0.25 / n)
    assert row["low"] <= row["p_false_positive"] <= row["high"]
    # a noiseless supervisor and robots that stay well clear of its level: no false positives at all
    calm = NoisySupervisor(sup_vf, 0.2, 0.0)
    out = false_positive_study(calm, {"wide": (controller, 1.5)}, 40, np.random.default_rng(1), 7.5, dt=0.05)
    assert out["p_false_positive"].iloc[0] == 0.0 and out["closest_edge"].iloc[0] > 0.2
