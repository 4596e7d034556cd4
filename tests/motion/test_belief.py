"""The observer's belief over time (mutual.motion.belief) against independent truths: the closed-form
likelihood ratio of chapter 6, the Gaussian marginal, and brute-force integration of eq. (6.8); bad
inputs (a table)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mutual.motion import belief, observer
from mutual.motion.evident import safety as es, task_belief
from mutual.motion.legible import random_lq_hypotheses, single_integrator


def test_full_motion_posterior_is_the_closed_form_likelihood_ratio():
    """At t = N the Gaussian posterior is the logistic of chapter 6's exact log Lambda (eq. 6.7)."""
    rng = np.random.default_rng(0)
    dyn, J0, J1, x0 = random_lq_hypotheses(rng, N=6)
    us = rng.normal(size=(6, 2))
    b = belief.posterior_over_time(us, belief.lq_gaussian(dyn, J0, x0, 6), belief.lq_gaussian(dyn, J1, x0, 6))
    log_lambda = observer.log_likelihood_ratio(dyn, J0, J1, x0, us)
    assert b[0] == pytest.approx(0.5)
    assert b[-1] == pytest.approx(1 / (1 + np.exp(log_lambda)), rel=1e-10)


def test_prefix_marginal_matches_brute_force_integration():
    """N = 2 scalar controls: the Gaussian marginal of u_0 against a quadrature of exp(-J) over u_1."""
    dyn = single_integrator(1, 0.5)
    from mutual.motion.legible import reaching_cost
    J = reaching_cost(np.array([1.0]), dt=0.5, terminal_weight=2.0, effort_weight=1.0)
    mean, P = belief.lq_gaussian(dyn, J, np.zeros(1), 2)
    # a Riemann sum of a smooth Gaussian converges faster than any power of the spacing: at 0.02 its error is
    # far below rounding (exp(-2 pi^2 sigma^2 / h^2)), and the tails beyond 12 are below exp(-70)
    grid = np.linspace(-12, 12, 1201)
    U0, U1 = np.meshgrid(grid, grid, indexing="ij")
    xN = 0.5 * (U0 + U1)
    cost = 2.0 * (xN - 1) ** 2 + 0.5 * (U0 ** 2 + U1 ** 2)
    dens = np.exp(-cost)
    marginal = dens.sum(axis=1) / (dens.sum() * (grid[1] - grid[0]))
    for u0 in (-1.0, 0.3, 2.0):
        i = np.argmin(np.abs(grid - u0))
        us = np.array([[grid[i]], [0.0]])
        log_p = belief.gaussian_prefix_loglik(us, mean, P)[1]
        assert np.exp(log_p) == pytest.approx(marginal[i], rel=1e-6)


def test_continuation_formula_is_exact_in_the_lq_case():
    """Fig. 7.1 (x' = u, quadratic): the Laplace-around-the-continuation likelihood equals the Gaussian marginal."""
    task, w0, w1 = es.figure_scenario("7.1", steps=12)
    optima = es.solve_hypotheses(task, w0, w1)
    costs = es.lq_hypothesis_costs(task, w0, w1)
    us = optima["legible"].us + 0.3 * np.random.default_rng(1).normal(size=optima["legible"].us.shape)
    for name, w in (("H0", w0), ("H1", w1)):
        exact = belief.gaussian_prefix_loglik(us, *belief.lq_gaussian(single_integrator(2, task.dt), costs[name],
                                                                        task.x0, task.steps))
        approx = task_belief.continuation_loglik(task, w, us, optima[name])
        np.testing.assert_allclose(approx, exact, atol=1e-8)


def _tiny_nonlinear(beta):
    task = es.EvidentSafetyTask(x0=[0.0, 0.0, 0.0], goal=[1.2, 0.6], hazard=[0.6, 0.6], horizon=1.5, steps=2)
    return task, beta * es.hypothesis_weights(5, 0.5), beta * es.hypothesis_weights(5, 0.5, hazard=2)


def _brute_posterior(task, w0, w1, grid):
    """P(H1 | u_0) by quadrature of exp(-J_i(u_0, u_1)) over u_1 (uniform prior, N = 2 Dubins steps)."""
    U = jnp.asarray(np.stack(np.meshgrid(grid, grid, indexing="ij"), axis=-1).reshape(-1, 2))

    def cost(u, p):
        xa = jnp.asarray(task.x0)
        xb = es._step(xa, u[0:1], p)
        return es._running(xa, u[0:1], p) + es._running(xb, u[1:2], p) + es._terminal(es._step(xb, u[1:2], p), p)

    with jax.enable_x64(True):
        J = [np.asarray(jax.vmap(cost, (0, None))(U, task.params(w))).reshape(len(grid), len(grid)) for w in (w0, w1)]
    m = [np.exp(-(j - j.min())) for j in J]
    m = [x.sum(axis=1) / x.sum() for x in m]
    with np.errstate(invalid="ignore"):  # far out both marginals underflow; those cells are not used
        return m[1] / (m[0] + m[1])


@pytest.mark.parametrize("beta", [1.0, 16.0])
def test_laplace_belief_against_brute_force_on_a_tiny_nonlinear_problem(beta):
    """Two Dubins steps of 0.75 s (turns up to ~1 rad): the assumption of the notebook is an
    approximation; measured error about 0.011 (beta = 1) and 0.008 (beta = 16), below 0.02."""
    task, w0, w1 = _tiny_nonlinear(beta)
    optima = {"H0": es.solve(task, w0), "H1": es.solve(task, w1)}
    grid = np.linspace(-15, 15, 601)
    brute = _brute_posterior(task, w0, w1, grid)
    errors = []
    for u0 in (optima["H0"].us[0, 0], optima["H1"].us[0, 0], optima["H1"].us[0, 0] + 0.2):
        i = np.argmin(np.abs(grid - u0))
        ours = task_belief.belief_over_time(task, w0, w1, np.array([[grid[i]], [0.0]]), optima, times=np.array([1]))[0]
        errors.append(abs(ours - brute[i]))
    assert max(errors) < 0.02


def test_belief_starts_at_the_prior_and_bad_inputs_are_named():
    task, w0, w1 = es.figure_scenario("7.1", steps=10)
    optima = es.solve_hypotheses(task, w0, w1)
    b = task_belief.belief_over_time(task, w0, w1, optima["legible"].us, optima, prior=0.2)
    assert b[0] == pytest.approx(0.2)
    assert b[-1] > 0.2  # the legible motion is evidence for H1
    with pytest.raises(ValueError, match="prior"):
        task_belief.belief_over_time(task, w0, w1, optima["legible"].us, optima, prior=1.0)
    with pytest.raises(ValueError, match="positive definite"):
        belief.gaussian_prefix_loglik(np.zeros((2, 1)), np.zeros((2, 1)), -np.eye(2))


CASES = [
    # belief, MPC, animation, explore
    (belief.posterior_over_time, (np.zeros((2, 1)), (np.zeros((2, 1)), np.eye(2)), (np.zeros((2, 1)), np.eye(2))),
     {"prior": 0.0}, ValueError, "prior must be a probability"),
    (belief.gaussian_prefix_loglik, (np.zeros((2, 1)), np.zeros((3, 1)), np.eye(2)), {}, ValueError, "same shape"),
    (belief.gaussian_prefix_loglik, (np.zeros((2, 1)), np.zeros((2, 1)), -np.eye(2)), {}, ValueError,
     "not positive definite"),
]


@pytest.mark.parametrize("fn, args, kwargs, error, phrase", CASES,
                         ids=[f"{i}-{c[0].__name__}-{c[4][:24]}" for i, c in enumerate(CASES)])
def test_bad_input_is_refused_with_a_reason(fn, args, kwargs, error, phrase):
    with pytest.raises(error, match=phrase.replace("(", r"\(").replace(")", r"\)")):
        fn(*args, **kwargs)
