"""The finite-horizon Riccati solver against a dense KKT solve, cvxpy and python-control (both backends);
unboundedness detected exactly; bad inputs (tables)."""

import control
import cvxpy as cp
import numpy as np
import pytest

from mutual.motion.legible.lqr import lq_cost, solve_lq

from helpers.lq import control_hessian, kkt_solve, random_problem


def solve(p):
    return solve_lq(p["A"], p["B"], p["Q"], p["R"], p["x0"], p["N"], q=p["q"], r=p["r"], QN=p["QN"],
                    qN=p["qN"], M=p["M"], c=p["c"])


@pytest.mark.parametrize("seed,convex_state", [(0, True), (1, True), (2, False), (3, False)])
def test_riccati_equals_dense_kkt(seed, convex_state):
    p = random_problem(seed, convex_state=convex_state)
    sol = solve(p)
    xs, us = kkt_solve(p)
    np.testing.assert_allclose(sol.us, us, atol=1e-8)
    np.testing.assert_allclose(sol.xs, xs, atol=1e-8)
    assert sol.cost == pytest.approx(lq_cost(xs, us, p["Q"], p["R"], p["q"], p["r"], p["QN"], p["qN"], p["M"]))


def test_riccati_equals_cvxpy():
    p = random_problem(7, n=2, m=2, N=20)
    sol = solve(p)
    N, n, m = p["N"], 2, 2
    x, u = cp.Variable((N + 1, n)), cp.Variable((N, m))
    cost = 0.5 * cp.quad_form(x[N], p["QN"]) + p["qN"] @ x[N]
    cons = [x[0] == p["x0"]]
    for k in range(N):
        cost += (0.5 * cp.quad_form(x[k], p["Q"][k]) + p["q"][k] @ x[k]
                 + 0.5 * cp.quad_form(u[k], p["R"][k]) + p["r"][k] @ u[k])
        cons.append(x[k + 1] == p["A"][k] @ x[k] + p["B"][k] @ u[k] + p["c"][k])
    prob = cp.Problem(cp.Minimize(cost), cons)
    prob.solve(solver="CLARABEL")
    np.testing.assert_allclose(sol.us, u.value, atol=1e-5)
    assert sol.cost == pytest.approx(prob.value, rel=1e-7)


def test_policy_reproduces_trajectory_and_value_function():
    p = random_problem(4)
    sol = solve(p)
    us = np.einsum("kij,kj->ki", sol.K, sol.xs[:-1]) + sol.k
    np.testing.assert_allclose(us, sol.us, atol=1e-12)
    # the optimal cost is 1/2 x0'V_0 x0 + v_0'x0 + const: check its gradient by finite differences
    eps = 1e-4
    grad = []
    for i in range(3):
        d = np.zeros(3)
        d[i] = eps
        plus = solve({**p, "x0": p["x0"] + d}).cost
        minus = solve({**p, "x0": p["x0"] - d}).cost
        grad.append((plus - minus) / (2 * eps))
    np.testing.assert_allclose(grad, sol.V[0] @ p["x0"] + sol.v[0], atol=1e-5)


def test_reference_case_single_integrator():
    """x_{k+1} = x_k + dt u_k with J = |x_N - g|^2 + dt sum |u|^2 ends at g / (1 + N dt)."""
    dt, N, I = 0.01, 100, np.eye(2)
    g = np.array([1.0, 1.0])
    sol = solve_lq(I, dt * I, np.zeros((2, 2)), 2 * dt * I, np.zeros(2), N, QN=2 * I, qN=-2 * g)
    np.testing.assert_allclose(sol.xs[-1], [0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(sol.us, np.full((N, 2), 0.5), atol=1e-12)


def test_long_horizon_gain_matches_dlqr():
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    B = np.array([[0.005], [0.1]])
    Q, R = np.diag([1.0, 0.5]), np.array([[0.2]])
    sol = solve_lq(A, B, Q, R, np.array([1.0, 0.0]), 400, QN=Q)
    K, S, _ = control.dlqr(A, B, Q, R)
    np.testing.assert_allclose(sol.K[0], -K, rtol=1e-8)
    np.testing.assert_allclose(sol.V[0], S, rtol=1e-8)


@pytest.mark.parametrize("seed", range(12))
def test_unboundedness_detected_exactly(seed):
    """solve_lq refuses a problem iff its dense control Hessian is not positive definite."""
    p = random_problem(seed, convex_state=False, q_scale=0.05)  # a mix of both kinds
    bounded = np.linalg.eigvalsh(control_hessian(p))[0] > 1e-9
    if bounded:
        np.testing.assert_allclose(solve(p).us, kkt_solve(p)[1], atol=1e-7)
    else:
        with pytest.raises(ValueError, match="unbounded LQ problem"):
            solve(p)


@pytest.mark.parametrize("R,QN", [
    (np.zeros((2, 2)), np.zeros((2, 2))),      # no curvature at all: linear cost, unbounded
    (-np.eye(2), np.zeros((2, 2))),            # concave in u
    (0.01 * np.eye(2), -10 * np.eye(2)),       # terminal reward outweighs the effort
])
def test_unbounded_problems_raise(R, QN):
    I = np.eye(2)
    with pytest.raises(ValueError, match="unbounded LQ problem"):
        solve_lq(I, 0.1 * I, np.zeros((2, 2)), R, np.zeros(2), 10, QN=QN, qN=np.ones(2))


def test_indefinite_state_cost_is_fine_when_bounded():
    """Q need not be PSD (the legible objective subtracts costs): only R + B'VB must be PD."""
    I = np.eye(2)
    sol = solve_lq(I, 0.1 * I, -0.01 * I, I, np.ones(2), 10)
    assert np.all(np.isfinite(sol.xs))


@pytest.mark.parametrize("kwargs,match", [
    (dict(A=np.eye(3)), "A has shape"),
    (dict(B=np.ones((3, 2))), "B has shape"),
    (dict(Q=np.ones((5, 2, 2))), "Q has shape"),
    (dict(N=0), "N must be a positive integer"),
    (dict(x0=np.array([np.nan, 0.0])), "x0 contains non-finite"),
    (dict(qN=np.ones(3)), "qN has shape"),
])
def test_bad_input_names_the_argument(kwargs, match):
    args = dict(A=np.eye(2), B=np.eye(2), Q=np.eye(2), R=np.eye(2), x0=np.zeros(2), N=4, qN=np.zeros(2))
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        solve_lq(**args)


@pytest.mark.parametrize("seed,convex_state,m", [(0, True, 2), (2, False, 2), (3, True, 5)])
def test_compiled_backend_matches_numpy(seed, convex_state, m):
    """The compiled recursion (JAX, padded horizon; unrolled Cholesky for m <= 4, LAPACK above) gives the
    reference solution, gains and value function."""
    p = random_problem(seed, convex_state=convex_state, m=m)
    ref, fast = solve(p), solve_lq(p["A"], p["B"], p["Q"], p["R"], p["x0"], p["N"], q=p["q"], r=p["r"], QN=p["QN"],
                                   qN=p["qN"], M=p["M"], c=p["c"], backend="jax")
    for name in ("xs", "us", "K", "k", "V", "v"):
        np.testing.assert_allclose(getattr(fast, name), getattr(ref, name), atol=1e-10, err_msg=name)
    assert fast.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-12)


def test_compiled_backend_time_invariant_long_horizon():
    A = np.array([[1.0, 0.1], [0.0, 1.0]])
    B = np.array([[0.005], [0.1]])
    args = (A, B, np.diag([1.0, 0.5]), np.array([[0.2]]), np.array([1.0, -1.0]), 333)
    ref, fast = solve_lq(*args, QN=np.eye(2)), solve_lq(*args, QN=np.eye(2), backend="jax")
    np.testing.assert_allclose(fast.us, ref.us, atol=1e-12)
    assert fast.cost == pytest.approx(ref.cost, rel=1e-12)


@pytest.mark.parametrize("m", [2, 5])
def test_compiled_backend_refuses_unbounded(m):
    I = np.eye(m)
    with pytest.raises(ValueError, match="unbounded LQ problem: the control Hessian R \\+ B'VB at stage 9"):
        solve_lq(I, 0.1 * I, np.zeros((m, m)), 0.01 * I, np.zeros(m), 10, QN=-10 * I, qN=np.ones(m), backend="jax")


def test_solution_repr_is_short():
    p = random_problem(0, N=200)
    text = repr(solve(p))
    assert text.startswith("LQSolution(N=200, n=3, m=2, cost=") and len(text) < 120


DT, N = 0.1, 10
X0 = np.zeros(2)
I2 = np.eye(2)
SKEW_R = np.array([[1.0, 5.0], [-5.0, 1.0]])


def lq(**kw):
    args = dict(A=I2, B=DT * I2, Q=np.zeros((2, 2)), R=I2, x0=X0, N=N, QN=I2, qN=np.zeros(2))
    args.update(kw)
    return solve_lq(**args)


CASES = [
    # the LQ solver
    (lq, (), dict(R=SKEW_R), ValueError, "R is not symmetric"),
    (lq, (), dict(R=SKEW_R, backend="jax"), ValueError, "R is not symmetric"),
    (lq, (), dict(Q=np.array([[0.0, 1.0], [0.0, 0.0]])), ValueError, "Q is not symmetric"),
    (lq, (), dict(QN=np.array([[1.0, 2.0], [0.0, 1.0]])), ValueError, "QN is not symmetric"),
    (lq, (), dict(backend="torch"), ValueError, "backend must be"),
    (lq, (), dict(N=2.5), ValueError, "N must be a positive integer"),
    (lq, (), dict(x0=np.array([np.nan, 0.0])), ValueError, "x0 contains non-finite"),
    (lq, (), dict(A=np.array([[1.0, np.inf], [0.0, 1.0]])), ValueError, "A contains non-finite"),
    (lq, (), dict(R=0.001 * I2, QN=-10 * I2, backend="jax"), ValueError, "unbounded LQ problem"),
]


@pytest.mark.parametrize("fn,args,kwargs,error,phrase", CASES,
                         ids=[f"{i}-{c[0].__name__ if hasattr(c[0], '__name__') else c[0]}" for i, c in
                              enumerate(CASES)])
def test_bad_input_is_refused_with_a_clear_message(fn, args, kwargs, error, phrase):
    if error is None:
        out = fn(*args, **kwargs)
        assert np.all(np.isfinite(out.us))
        return
    with pytest.raises(error) as info:
        fn(*args, **kwargs)
    assert phrase in str(info.value)


def test_non_symmetric_r_is_not_silently_another_problem():
    """R = [[1, 5], [-5, 1]] has the quadratic form of I; we refuse it rather than solve a different
    problem, and the symmetric part gives the same answer as I."""
    with pytest.raises(ValueError, match="pass \\(R \\+ R'\\)/2"):
        lq(R=SKEW_R)
    np.testing.assert_allclose(lq(R=0.5 * (SKEW_R + SKEW_R.T)).us, lq(R=I2).us, atol=1e-14)
