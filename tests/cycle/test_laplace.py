"""The supervisor's posterior over time by the Laplace approximation, against the exact Gaussian of a
linear-quadratic problem and chapter 6's closed-form observer; bad inputs (a table)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from scipy import stats

from mutual.cycle.evidence import first_confidence
from mutual.cycle.laplace import posterior_over_time, prefix_log_likelihoods
from mutual.motion.legible import reaching_cost, single_integrator
from mutual.motion.observer import log_boltzmann


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


CASES = [
    (posterior_over_time, ([0.0], [0.0]), {"prior": 1.0}, ValueError, "prior"),
    (prefix_log_likelihoods, (None, None, None, np.zeros(2), np.zeros(3), {}), {}, ValueError, "us: must have shape"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{c[0].__name__ if hasattr(c[0], '__name__') else 'call'}-{i}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase):
        fn(*args, **kwargs)
