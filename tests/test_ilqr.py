"""iLQR against the exact Riccati solution (chapter 6's solver), a closed form, and its own failure modes."""

import jax.numpy as jnp
import numpy as np
import pytest
from scipy.optimize import minimize

from mutual.motion.ilqr import ILQRError, ilqr, rollout, trajectory_cost, trajectory_cost_grad
from mutual.motion.lqr import solve_lq


def _random_lq(seed=0, n=4, m=2, N=30):
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.1 * rng.normal(size=(n, n))
    B = rng.normal(size=(n, m))
    Q = np.diag(rng.uniform(0.5, 2, n))
    R = 0.3 * np.eye(m)
    QN, q, qN, x0 = 5 * np.eye(n), rng.normal(size=n), rng.normal(size=n), rng.normal(size=n)
    return A, B, Q, R, QN, q, qN, x0, N


def _lq_callables(A, B, Q, R, QN, q, qN):
    def dynamics(x, u, params):
        return jnp.asarray(A) @ x + jnp.asarray(B) @ u

    def running(x, u, params):
        return 0.5 * x @ Q @ x + q @ x + 0.5 * u @ R @ u

    def terminal(x, params):
        return 0.5 * x @ QN @ x + qN @ x

    return dynamics, running, terminal


def test_lq_problem_converges_in_one_step_to_the_riccati_solution():
    A, B, Q, R, QN, q, qN, x0, N = _random_lq()
    dyn, run, term = _lq_callables(A, B, Q, R, QN, q, qN)
    result = ilqr(dyn, run, term, x0, np.zeros((N, B.shape[1])))
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    assert result.iterations <= 2
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)
    np.testing.assert_allclose(result.xs, exact.xs, atol=1e-9)
    assert result.cost == pytest.approx(exact.cost, rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(result.K, exact.K, atol=1e-8)  # the feedback gains of the Riccati pass


@pytest.mark.parametrize("m", [3, 6])  # Q_uu factorised by unrolled arithmetic (m <= 4) and by LAPACK
def test_lq_problems_with_more_controls_match_the_riccati_solution(m):
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=4, n=7, m=m, N=15)
    result = ilqr(*_lq_callables(A, B, Q, R, QN, q, qN), x0, np.zeros((N, m)))
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)
    np.testing.assert_allclose(result.K, exact.K, atol=1e-8)


def test_indefinite_but_bounded_lq_problem_is_solved_exactly():
    """A negative state weight (as in (1 + alpha) J1 - J0) that the control cost still dominates."""
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=1, N=10)
    Q = -0.02 * np.eye(4)
    exact = solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    result = ilqr(*_lq_callables(A, B, Q, R, QN, q, qN), x0, np.zeros((N, 2)))
    np.testing.assert_allclose(result.us, exact.us, atol=1e-9)


def test_unbounded_lq_problem_is_reported_as_the_riccati_solver_does():
    A, B, Q, R, QN, q, qN, x0, N = _random_lq(seed=2)
    Q = -2.0 * np.eye(4)  # rewards running away faster than controls cost
    with pytest.raises(ValueError, match="unbounded"):
        solve_lq(A, B, Q, R, x0, N, q=q, QN=QN, qN=qN)
    with pytest.raises(ILQRError, match="unbounded"):
        ilqr(*_lq_callables(A, B, Q, R, QN, q, qN), x0, np.zeros((N, 2)))


def test_objective_unbounded_in_the_controls_is_reported():
    """u = 0 is stationary for -|u|^2 + |x_N|^2 but a maximum: iLQR must not return it."""
    def dynamics(x, u, params):
        return x + u

    def running(x, u, params):
        return -jnp.sum(u ** 2)

    def terminal(x, params):
        return jnp.sum(x ** 2)

    with pytest.raises(ILQRError, match="not a local minimum|unbounded"):
        ilqr(dynamics, running, terminal, np.zeros(2), np.zeros((5, 2)))
    with pytest.raises(ILQRError, match="unbounded"):
        ilqr(dynamics, running, terminal, np.zeros(2), np.ones((5, 2)))


def _pendulum():
    dt = 0.05

    def dynamics(x, u, params):
        return jnp.stack([x[0] + dt * x[1], x[1] + dt * (-9.81 * jnp.sin(x[0]) + u[0])])

    def running(x, u, params):
        return dt * (0.1 * x @ x + params * u @ u)

    def terminal(x, params):
        return 50.0 * ((x[0] - np.pi) ** 2 + x[1] ** 2)

    return dynamics, running, terminal


def test_nonlinear_optimum_is_stationary_and_no_better_by_lbfgs():
    """Pendulum swing-up: iLQR's controls zero the autodiff gradient and L-BFGS cannot improve them."""
    dyn, run, term = _pendulum()
    x0, us0 = np.zeros(2), np.full((60, 1), 0.1)
    result = ilqr(dyn, run, term, x0, us0, 0.01)
    cost, grad = trajectory_cost_grad(dyn, run, term, x0, result.us, 0.01)
    assert cost == pytest.approx(result.cost, rel=1e-12)
    assert np.abs(grad).max() < 1e-6 * (1 + abs(cost))

    def fun(flat):
        c, g = trajectory_cost_grad(dyn, run, term, x0, flat.reshape(-1, 1), 0.01)
        return c, g.ravel()

    polished = minimize(fun, result.us.ravel(), jac=True, method="L-BFGS-B")
    assert polished.fun >= result.cost - 1e-9 * abs(result.cost)


def test_second_order_ddp_finds_the_same_optimum():
    dyn, run, term = _pendulum()
    x0, us0 = np.zeros(2), np.full((60, 1), 0.1)
    first = ilqr(dyn, run, term, x0, us0, 0.01)
    second = ilqr(dyn, run, term, x0, us0, 0.01, second_order=True)
    assert second.cost == pytest.approx(first.cost, rel=1e-10)
    np.testing.assert_allclose(second.us, first.us, atol=1e-4)  # a flat valley: weak control cost


def test_params_are_traced_not_baked_in():
    dyn, run, term = _pendulum()
    x0, us = np.zeros(2), np.full((60, 1), 0.3)
    low, high = trajectory_cost(dyn, run, term, x0, us, 0.01), trajectory_cost(dyn, run, term, x0, us, 1.0)
    assert high - low == pytest.approx(0.99 * 0.05 * 60 * 0.09, rel=1e-9)


def test_rollout_matches_a_numpy_loop():
    dyn, _, _ = _pendulum()
    us = np.random.default_rng(3).normal(size=(20, 1))
    xs = [np.array([0.3, -0.2])]
    for u in us:
        x = xs[-1]
        xs.append(np.array([x[0] + 0.05 * x[1], x[1] + 0.05 * (-9.81 * np.sin(x[0]) + u[0])]))
    np.testing.assert_allclose(rollout(dyn, xs[0], us), np.array(xs), atol=1e-12)


def test_bad_inputs_are_named():
    dyn, run, term = _pendulum()
    with pytest.raises(ValueError, match="us must have shape"):
        ilqr(dyn, run, term, np.zeros(2), np.zeros(5))
    with pytest.raises(ValueError, match="x0 must be a state vector"):
        ilqr(dyn, run, term, np.zeros((2, 1)), np.zeros((5, 1)))
    with pytest.raises(ValueError, match="dynamics must map"):
        ilqr(lambda x, u, p: x[:1], run, term, np.zeros(2), np.zeros((5, 1)), 0.01)
    with pytest.raises(ValueError, match="running_cost must return a scalar"):
        ilqr(dyn, lambda x, u, p: x, term, np.zeros(2), np.zeros((5, 1)), 0.01)
    with pytest.raises(ValueError, match="max_iter"):
        ilqr(dyn, run, term, np.zeros(2), np.zeros((5, 1)), 0.01, max_iter=0)
