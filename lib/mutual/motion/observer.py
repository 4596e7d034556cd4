"""The Boltzmann observer of chapter 6 in closed form: for linear dynamics and quadratic costs,
``P(u | H) = exp(-J(u)) / Z`` (eq. 6.8) is Gaussian in the stacked controls, so its partition
function, the likelihood ratio ``Lambda`` (eq. 6.7) and its minimiser (Theorem 6.4.2) are exact."""

import numpy as np


def lifted_dynamics(dynamics, x0, N):
    """``x_k = Phi_k x0 + G_k u`` for the stacked controls ``u`` (N m,): returns ``(Phi x0, G)``
    with shapes (N+1, n) and (N+1, n, N m)."""
    dyn = dynamics.stages(0, N)
    n, m = dyn.n, dyn.m
    A = np.broadcast_to(dyn.A, (N, n, n))
    B = np.broadcast_to(dyn.B, (N, n, m))
    free = np.empty((N + 1, n))
    G = np.zeros((N + 1, n, N * m))
    free[0] = x0
    for k in range(N):
        free[k + 1] = A[k] @ free[k]
        G[k + 1] = A[k] @ G[k]
        G[k + 1, :, k * m:(k + 1) * m] += B[k]
    return free, G


def lifted_cost(dynamics, cost, x0, N):
    """``J(u) = 1/2 u'H u + h'u + c`` over the stacked controls; returns ``(H, h, c)``."""
    free, G = lifted_dynamics(dynamics, x0, N)
    c = cost.stages(0, N)
    n, m = c.QN.shape[0], c.R.shape[-1]
    Q = np.broadcast_to(c.Q, (N, n, n))
    q = np.broadcast_to(c.q, (N, n))
    R = np.broadcast_to(c.R, (N, m, m))
    r = np.broadcast_to(c.r, (N, m))
    Gs, Gn, fs, fN = G[:N], G[N], free[:N], free[N]
    H = np.einsum("kia,kij,kjb->ab", Gs, Q, Gs) + Gn.T @ c.QN @ Gn
    idx = np.arange(N)
    Hu = H.reshape(N, m, N, m)
    Hu[idx, :, idx, :] += R
    h = (np.einsum("kia,ki->a", Gs, np.einsum("kij,kj->ki", Q, fs) + q) + Gn.T @ (c.QN @ fN + c.qN)
         + r.reshape(-1))
    const = (0.5 * np.einsum("ki,kij,kj->", fs, Q, fs) + np.einsum("ki,ki->", q, fs)
             + 0.5 * fN @ c.QN @ fN + c.qN @ fN + c.const)
    return 0.5 * (H + H.T), h, float(const)


def _gaussian(H, h, c, name):
    """Mean, Cholesky factor of the precision and log Z of ``exp(-(1/2 u'Hu + h'u + c))``."""
    try:
        L = np.linalg.cholesky(H)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name}: exp(-J) is not normalisable (its control Hessian is not positive "
                         "definite), so P(u | H) of eq. (6.8) is undefined") from None
    mean = -np.linalg.solve(H, h)
    d = h.shape[0]
    log_z = -c - 0.5 * h @ mean + 0.5 * d * np.log(2 * np.pi) - np.log(np.diag(L)).sum()
    return mean, L, log_z


def log_boltzmann(dynamics, cost, x0, us):
    """``log P(u | H) = -J(u) - log Z`` (eqs. (6.8)-(6.9)); Gaussian in the stacked controls."""
    us = np.asarray(us, float)
    N = us.shape[0]
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    _, _, log_z = _gaussian(H, h, c, "cost")
    u = us.reshape(-1)
    J = 0.5 * u @ H @ u + h @ u + c
    return float(-J - log_z)


def log_likelihood_ratio(dynamics, J0, J1, x0, us):
    """``log Lambda(u) = log P(u|H0) - log P(u|H1)`` (eq. (6.7)) with the closed-form partition
    functions. Negative values are evidence for H1 over H0 (nats)."""
    return log_boltzmann(dynamics, J0, x0, us) - log_boltzmann(dynamics, J1, x0, us)


def likelihood_ratio_minimiser(dynamics, J0, J1, x0, N, alpha=0.0):
    """Minimiser of ``log Lambda(u) + alpha J1(u)`` from the two Gaussians' means and precisions
    (not through the stage costs): solves ``((1+alpha) P1 - P0) u = (1+alpha) P1 mu1 - P0 mu0``.

    By Theorem 6.4.2 and eq. (6.15) this equals the minimiser of ``(1 + alpha) J1 - J0``.
    Returns the controls (N, m); raises ValueError if the objective is unbounded.
    """
    H0, h0, c0 = lifted_cost(dynamics, J0, x0, N)
    H1, h1, c1 = lifted_cost(dynamics, J1, x0, N)
    mu0, _, _ = _gaussian(H0, h0, c0, "J0")
    mu1, _, _ = _gaussian(H1, h1, c1, "J1")
    P = (1 + alpha) * H1 - H0
    P = 0.5 * (P + P.T)
    if np.linalg.eigvalsh(P)[0] <= 1e-9 * np.abs(H1).max():
        raise ValueError("log Lambda + alpha J1 has no finite minimiser: (1+alpha) P1 - P0 is not "
                         "positive definite")
    u = np.linalg.solve(P, (1 + alpha) * H1 @ mu1 - H0 @ mu0)
    return u.reshape(N, -1)


def batch_costs(dynamics, cost, x0, us):
    """``J(u)`` for a batch of control sequences ``us`` (B, N, m), through the lifted form."""
    us = np.asarray(us, float)
    H, h, c = lifted_cost(dynamics, cost, x0, us.shape[1])
    U = us.reshape(len(us), -1)
    return 0.5 * np.einsum("bi,ij,bj->b", U, H, U) + U @ h + c


def sample_boltzmann(dynamics, cost, x0, N, size, rng):
    """Draw ``size`` control sequences (size, N, m) from ``P(u | H) = exp(-J(u)) / Z`` (eq. (6.8))."""
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    mean, L, _ = _gaussian(H, h, c, "cost")
    z = rng.standard_normal((size, len(mean)))
    # u = mean + L^{-T} z has covariance (L L')^{-1} = H^{-1}
    u = mean + np.linalg.solve(L.T, z.T).T
    return u.reshape(size, N, -1)
