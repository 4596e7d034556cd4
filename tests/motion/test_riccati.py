"""The one Riccati step (mutual.motion.riccati) in both faces, against the dense solution of the lifted LQ
problem, LAPACK, and eigenvalues."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mutual.motion.riccati import LQStage, positive_definite, riccati_step, spd_solve


def random_problem(rng, n=3, m=2, N=6):
    """A random LQ problem with cross terms and affine dynamics, convex in the controls."""
    A = np.eye(n) + 0.3 * rng.normal(size=(N, n, n))
    B = rng.normal(size=(N, n, m))
    c = 0.2 * rng.normal(size=(N, n))
    root = rng.normal(size=(N, n + m, n + m))
    H = root @ root.transpose(0, 2, 1) + 0.5 * np.eye(n + m)
    g = rng.normal(size=(N, n + m))
    QN = np.eye(n) + 0.1 * np.ones((n, n))
    qN = rng.normal(size=n)
    return A, B, c, H, g, QN, qN, rng.normal(size=n)


def recursion_controls(problem, xp=np, reg=None):
    """The optimal controls of ``problem`` from the backward pass of riccati_step, then the rollout."""
    A, B, c, H, g, QN, qN, x0 = problem
    N = len(A)
    F = np.concatenate([A, B], axis=2)
    V, v, gains = xp.asarray(QN), xp.asarray(qN), []
    for t in reversed(range(N)):
        step = riccati_step(V, v, LQStage(F=xp.asarray(F[t]), H=xp.asarray(H[t]), g=xp.asarray(g[t]), c=xp.asarray(c[t])),
                            xp, reg=None if reg is None else xp.asarray(reg))
        V, v = step.V, step.v
        gains.insert(0, (np.asarray(step.K), np.asarray(step.k)))
    x, us = x0, []
    for t, (K, k) in enumerate(gains):
        us.append(K @ x + k)
        x = A[t] @ x + B[t] @ us[-1] + c[t]
    return np.array(us)


def dense_controls(problem):
    """The same optimum from the lifted problem: states as an affine map of the stacked controls, the total
    cost a quadratic in them, its minimiser by one dense solve."""
    A, B, c, H, g, QN, qN, x0 = problem
    N, n, m = B.shape
    G = np.zeros((n, N * m))                   # x_t = G u + h
    h = x0.copy()
    hess, grad = np.zeros((N * m, N * m)), np.zeros(N * m)
    for t in range(N):
        Z = np.zeros((n + m, N * m))           # z_t = (x_t, u_t) = Z u + z0
        Z[:n], Z[n:, t * m:(t + 1) * m] = G, np.eye(m)
        z0 = np.concatenate([h, np.zeros(m)])
        hess += Z.T @ H[t] @ Z
        grad += Z.T @ (H[t] @ z0 + g[t])
        G, h = A[t] @ G, A[t] @ h + c[t]
        G[:, t * m:(t + 1) * m] += B[t]
    hess += G.T @ QN @ G
    grad += G.T @ (QN @ h + qN)
    return np.linalg.solve(hess, -grad).reshape(N, m)


@pytest.mark.parametrize("seed", range(4))
def test_numpy_recursion_finds_the_dense_optimum(seed):
    problem = random_problem(np.random.default_rng(seed))
    np.testing.assert_allclose(recursion_controls(problem), dense_controls(problem), rtol=1e-9, atol=1e-10)


@pytest.mark.parametrize("seed", range(2))
def test_jax_face_finds_the_same_optimum(seed):
    problem = random_problem(np.random.default_rng(seed))
    with jax.enable_x64(True):
        ours = recursion_controls(problem, jnp)
    np.testing.assert_allclose(ours, dense_controls(problem), rtol=1e-9, atol=1e-10)


@pytest.mark.parametrize("xp", [np, jnp], ids=["numpy", "jax"])
def test_regularised_update_at_zero_regularisation_is_the_short_form(xp):
    """Tassa et al.'s eq. (11) (written with K'Q_uu K and K'Q_ux) equals V = Q_xx + Q_ux'K when K is exact."""
    problem = random_problem(np.random.default_rng(7))
    with jax.enable_x64(True):
        np.testing.assert_allclose(recursion_controls(problem, xp, reg=np.zeros((2, 2))), dense_controls(problem),
                                   rtol=1e-9, atol=1e-10)


def test_a_batch_of_problems_is_the_problems_one_by_one():
    """NumPy's leading batch axis: two problems sharing the dynamics, stepped at once."""
    rng = np.random.default_rng(3)
    A, B, c, H, g, QN, qN, _ = random_problem(rng, N=1)
    H2, g2 = H[0] + np.eye(5), g[0] + 1.0
    F = np.concatenate([A[0], B[0]], axis=1)
    both = riccati_step(np.stack([QN, 2 * QN]), np.stack([qN, qN]), LQStage(F=F, H=np.stack([H[0], H2]),
                                                                              g=np.stack([g[0], g2]), c=c[0]))
    for i, (Hi, gi, Vi) in enumerate([(H[0], g[0], QN), (H2, g2, 2 * QN)]):
        one = riccati_step(Vi, qN, LQStage(F=F, H=Hi, g=gi, c=c[0]))
        np.testing.assert_allclose(both.V[i], one.V, rtol=1e-13)
        np.testing.assert_allclose(both.K[i], one.K, rtol=1e-13)


@pytest.mark.parametrize("m", [1, 2, 3, 4, 5, 6])
def test_spd_solve_agrees_with_lapack_in_both_faces(m):
    """Unrolled Cholesky (JAX, m <= 4) and LAPACK (NumPy; JAX beyond 4) against numpy.linalg.solve."""
    rng = np.random.default_rng(m)
    root = rng.normal(size=(m, m))
    S, rhs = root @ root.T + 0.1 * np.eye(m), rng.normal(size=(m, 3))
    truth = np.linalg.solve(S, rhs)
    X, L = spd_solve(S, rhs)
    np.testing.assert_allclose(X, truth, rtol=1e-10)
    np.testing.assert_allclose(L @ L.T, S, rtol=1e-12, atol=1e-12)
    with jax.enable_x64(True):
        Xj, Lj = jax.jit(lambda S, b: spd_solve(S, b, jnp))(S, rhs)
        assert bool(positive_definite(Lj))
    np.testing.assert_allclose(np.asarray(Xj), truth, rtol=1e-10)
    np.testing.assert_allclose(np.tril(np.asarray(Lj)), L, rtol=1e-12, atol=1e-12)


NOT_POSITIVE_DEFINITE = {
    "indefinite": np.array([[1.0, 2.0], [2.0, 1.0]]),
    "singular": np.array([[1.0, 1.0], [1.0, 1.0]]),
    "negative definite": -np.eye(2),
    "zero 1x1": np.zeros((1, 1)),
    "indefinite 5x5": np.diag([1.0, 1.0, -1.0, 1.0, 1.0]),
    "not finite": np.array([[np.nan, 0.0], [0.0, 1.0]]),
}


@pytest.mark.parametrize("S", NOT_POSITIVE_DEFINITE.values(), ids=NOT_POSITIVE_DEFINITE.keys())
def test_matrices_that_are_not_positive_definite_are_flagged_not_raised(S):
    if np.all(np.isfinite(S)):
        assert np.linalg.eigvalsh(S)[0] <= 0                          # the truth: an eigenvalue <= 0
    rhs = np.ones((len(S), 2))
    _, L = spd_solve(S, rhs)
    assert not positive_definite(L)
    with jax.enable_x64(True):
        _, Lj = spd_solve(jnp.asarray(S), jnp.asarray(rhs), jnp)
        assert not bool(positive_definite(Lj))
