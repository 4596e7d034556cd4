"""The finite-horizon Riccati solver against a dense KKT solve, cvxpy and python-control."""

import control
import cvxpy as cp
import numpy as np
import pytest

from mutual.motion.legible.lqr import lq_cost, solve_lq


def random_problem(seed, n=3, m=2, N=12, convex_state=True, q_scale=0.02):
    """A time-varying LQ problem with cross terms and affine dynamics."""
    rng = np.random.default_rng(seed)
    A = np.eye(n) + 0.1 * rng.normal(size=(N, n, n))
    B = rng.normal(size=(N, n, m))
    c = 0.1 * rng.normal(size=(N, n))
    L = rng.normal(size=(N, n, n))
    Q = L @ L.transpose(0, 2, 1) / n if convex_state else q_scale * (L + L.transpose(0, 2, 1))
    Lr = rng.normal(size=(N, m, m))
    R = Lr @ Lr.transpose(0, 2, 1) / m + np.eye(m)
    M = 0.1 * rng.normal(size=(N, n, m)) if not convex_state else np.zeros((N, n, m))
    LN = rng.normal(size=(n, n))
    return dict(A=A, B=B, c=c, Q=Q, R=R, M=M, q=rng.normal(size=(N, n)), r=rng.normal(size=(N, m)),
                QN=LN @ LN.T, qN=rng.normal(size=n), x0=rng.normal(size=n), N=N)


def kkt_solve(p):
    """Minimise the LQ cost by one dense KKT system in z = (x_0..x_N, u_0..u_{N-1})."""
    A, B, N = p["A"], p["B"], p["N"]
    n, m = B.shape[1:]
    nx, nz = (N + 1) * n, (N + 1) * n + N * m
    H = np.zeros((nz, nz))
    g = np.zeros(nz)
    xi = lambda k: slice(k * n, (k + 1) * n)  # noqa: E731
    ui = lambda k: slice(nx + k * m, nx + (k + 1) * m)  # noqa: E731
    for k in range(N):
        H[xi(k), xi(k)] += p["Q"][k]
        H[ui(k), ui(k)] += p["R"][k]
        H[xi(k), ui(k)] += p["M"][k]
        H[ui(k), xi(k)] += p["M"][k].T
        g[xi(k)] += p["q"][k]
        g[ui(k)] += p["r"][k]
    H[xi(N), xi(N)] += p["QN"]
    g[xi(N)] += p["qN"]
    E = np.zeros(((N + 1) * n, nz))
    e = np.zeros((N + 1) * n)
    E[:n, :n] = np.eye(n)
    e[:n] = p["x0"]
    for k in range(N):
        rows = slice((k + 1) * n, (k + 2) * n)
        E[rows, xi(k + 1)] = np.eye(n)
        E[rows, xi(k)] = -A[k]
        E[rows, ui(k)] = -B[k]
        e[rows] = p["c"][k]
    kkt = np.block([[H, E.T], [E, np.zeros((len(e), len(e)))]])
    z = np.linalg.solve(kkt, np.concatenate([-g, e]))[:nz]
    return z[:nx].reshape(N + 1, n), z[nx:].reshape(N, m)


def control_hessian(p):
    """Hessian of the total cost in the stacked controls (the dynamics eliminated), densely."""
    N, (n, m) = p["N"], p["B"].shape[1:]
    G = np.zeros((N + 1, n, N * m))                    # d x_k / d u
    for k in range(N):
        G[k + 1] = p["A"][k] @ G[k]
        G[k + 1, :, k * m:(k + 1) * m] += p["B"][k]
    H = np.einsum("kia,kij,kjb->ab", G[:N], p["Q"], G[:N]) + G[N].T @ p["QN"] @ G[N]
    for k in range(N):
        U = np.zeros((m, N * m))
        U[:, k * m:(k + 1) * m] = np.eye(m)
        H += U.T @ p["R"][k] @ U + G[k].T @ p["M"][k] @ U + U.T @ p["M"][k].T @ G[k]
    return H


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
