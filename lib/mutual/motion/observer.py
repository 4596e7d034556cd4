"""The Boltzmann observer of chapter 6 in closed form: for linear dynamics and quadratic costs,
``P(u | H) = exp(-J(u)) / Z`` (eq. 6.8) is Gaussian in the stacked controls, so its likelihoods,
the likelihood ratio ``Lambda`` (eq. 6.7) and its minimiser (Theorem 6.4.2) are exact.

The observer's likelihoods and beliefs are computed stage by stage (:mod:`mutual.motion.chain`:
the Riccati factorisation of the block-banded precision, O(N) at any horizon). The lifted forms
(:func:`lifted_dynamics`, :func:`lifted_cost`: the dense (N m)^2 Hessian over all stages) remain for
what needs the whole matrix on small problems: the dense QP of :mod:`.legible.qp`, the second
route of Theorem 6.4.2 (:func:`likelihood_ratio_minimiser`) and sampling; they refuse, before
allocating, sizes beyond :data:`mutual.motion.chain.DENSE_LIMIT_BYTES`."""

import numpy as np

from .chain import check_dense_size, check_x0_N, log_ratio_prefix, lq_chains


def _check_controls(dynamics, us, name="us"):
    """``us`` as a finite (N, m) array, or a ValueError naming it."""
    us = np.asarray(us, float)
    if us.ndim != 2 or us.shape[1] != dynamics.m or len(us) < 1:
        raise ValueError(f"{name} must be an (N, {dynamics.m}) array of controls, got shape {us.shape}")
    if not np.all(np.isfinite(us)):
        raise ValueError(f"{name} contains non-finite values (NaN or inf): the likelihood is undefined")
    return us


def lifted_dynamics(dynamics, x0, N):
    """``x_k = Phi_k x0 + G_k u`` for the stacked controls ``u`` (N m,): returns ``(Phi x0, G)``
    with shapes (N+1, n) and (N+1, n, N m)."""
    x0 = check_x0_N(dynamics, x0, N)
    check_dense_size(N, dynamics.m, dynamics.n, "the lifted (dense) form over all stages")
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
    """``log P(u | H) = -J(u) - log Z`` (eqs. (6.8)-(6.9)), as the sum of the observer's stage
    conditionals (:mod:`mutual.motion.chain`): O(N), no partition function."""
    us = _check_controls(dynamics, us)
    return float(lq_chains(dynamics, [cost], x0, len(us))[0].prefix_loglik(us)[-1])


def log_likelihood_ratio(dynamics, J0, J1, x0, us):
    """``log Lambda(u) = log P(u|H0) - log P(u|H1)`` (eq. (6.7)), exact and O(N) (the stable form of
    :func:`mutual.motion.chain.log_ratio_prefix`). Negative values are evidence for H1 over H0 (nats)."""
    us = _check_controls(dynamics, us)
    g0, g1 = lq_chains(dynamics, [J0, J1], x0, len(us))
    return float(log_ratio_prefix(us, g0, g1)[-1])


def log_boltzmann_prefix(dynamics, cost, x0, us):
    """``log P(u_{0:k} | H)`` for every prefix ``k = 0 .. N`` of the controls ``us`` (N, m): the
    marginal of the Boltzmann density (eq. (6.8)) over the controls seen so far, the observer's
    evidence from a partial motion. Returns (N+1,); entry 0 is 0 and entry N is :func:`log_boltzmann`.

    Exact and O(N): the marginal of a prefix is the product of its stage conditionals, the
    maximum-entropy LQR policy (:mod:`mutual.motion.chain`).
    """
    us = _check_controls(dynamics, us)
    return lq_chains(dynamics, [cost], x0, len(us))[0].prefix_loglik(us)


def weighted_prefix_log_likelihood(dynamics, cost, x0, N, weights):
    """``sum_k weights[k-1] log P(u_{0:k} | H)`` over the prefixes ``k = 1 .. N`` as a quadratic in the
    stacked controls: returns ``(Hw, hw, cw)`` with the sum equal to ``-(1/2 u'Hw u + hw'u + cw)``.

    A partial-viewing evidence weighted over time, as Dragan and Srinivasa weight their observer's
    belief with ``f(t) = T - t`` (section 6.5). Exact: prefix ``k`` is the sum of the stage
    conditionals ``t < k`` (:mod:`mutual.motion.chain`), so with the whitened residual
    ``r = W u + r0`` the weighted sum is ``-1/2 (Wu + r0)' F (Wu + r0)`` plus log-determinants, ``F_t``
    the total weight of the prefixes that contain stage ``t``. Dense (N m)^2 output: small N.
    """
    w = np.asarray(weights, float)
    if w.shape != (N,) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be {N} finite numbers (one per prefix k = 1 .. N), got shape {w.shape}")
    chain = lq_chains(dynamics, [cost], x0, N)[0]
    W, r0 = chain.whitening()
    F_stage = np.cumsum(w[::-1])[::-1]                          # F_t = sum_{k > t} w_k
    F = np.repeat(F_stage, chain.m)
    Hw = W.T @ (F[:, None] * W)
    log_norm = F_stage @ chain.half_logdets - F.sum() * 0.5 * np.log(2 * np.pi)
    return 0.5 * (Hw + Hw.T), W.T @ (F * r0), float(0.5 * r0 @ (F * r0) - log_norm)


def posterior_over_time(dynamics, costs, x0, us, prior=None):
    """The observer's belief ``P(H_i | u_{0:k})`` over the hypotheses ``costs`` after each prefix
    ``k = 0 .. N`` of the motion (Bayes' rule on :func:`log_boltzmann_prefix`, eq. (6.8));
    shape (N+1, len(costs)), row 0 the prior (default uniform). Each hypothesis's log-likelihood is
    taken relative to the first one's in the stable form of :func:`mutual.motion.chain.log_ratio_prefix`,
    then normalised by log-sum-exp."""
    costs = list(costs)
    if len(costs) < 2:
        raise ValueError(f"costs must list at least two hypotheses, got {len(costs)}")
    us = _check_controls(dynamics, us)
    return posterior_from_chains(lq_chains(dynamics, costs, x0, len(us)), us, prior)


def posterior_from_chains(chains, us, prior=None):
    """:func:`posterior_over_time` from the hypotheses' Gaussians (:func:`mutual.motion.chain.lq_chains`),
    computed once for many motions of the same problem."""
    if prior is None:
        log_prior = np.full(len(chains), -np.log(len(chains)))
    else:
        p = np.asarray(prior, float)
        if p.shape != (len(chains),) or not np.all(np.isfinite(p)) or np.any(p <= 0):
            raise ValueError(f"prior must be {len(chains)} positive probabilities, got {prior!r}")
        log_prior = np.log(p / p.sum())
    logs = np.stack([-log_ratio_prefix(us, chains[0], g) for g in chains], axis=1) + log_prior  # log P_i - log P_0
    top = logs.max(axis=1, keepdims=True)
    return np.exp(logs - top - np.log(np.exp(logs - top).sum(axis=1, keepdims=True)))      # log-sum-exp


def likelihood_ratio_minimiser(dynamics, J0, J1, x0, N, alpha=0.0):
    """Minimiser of ``log Lambda(u) + alpha J1(u)`` from the two Gaussians' means and precisions
    (not through the stage costs): solves ``((1+alpha) P1 - P0) u = (1+alpha) P1 mu1 - P0 mu0``.

    By Theorem 6.4.2 and eq. (6.15) this equals the minimiser of ``(1 + alpha) J1 - J0``.
    Returns the controls (N, m); raises ValueError if the objective is unbounded.
    """
    if not isinstance(alpha, (int, float, np.integer, np.floating)) or not np.isfinite(alpha):
        raise ValueError(f"alpha must be a finite number, got {alpha!r}")
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
    if us.ndim != 3 or us.shape[2] != dynamics.m or 0 in us.shape:
        raise ValueError(f"us must be a (B, N, {dynamics.m}) batch of control sequences, got shape {us.shape}")
    if not np.all(np.isfinite(us)):
        raise ValueError("us contains non-finite values (NaN or inf)")
    H, h, c = lifted_cost(dynamics, cost, x0, us.shape[1])
    U = us.reshape(len(us), -1)
    return 0.5 * np.einsum("bi,ij,bj->b", U, H, U) + U @ h + c


def sample_boltzmann(dynamics, cost, x0, N, size, rng):
    """Draw ``size`` control sequences (size, N, m) from ``P(u | H) = exp(-J(u)) / Z`` (eq. (6.8))."""
    if not isinstance(size, (int, np.integer)) or size < 1:
        raise ValueError(f"size must be a positive integer, got {size!r}")
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy Generator (np.random.default_rng(seed)), got {type(rng).__name__}")
    H, h, c = lifted_cost(dynamics, cost, x0, N)
    mean, L, _ = _gaussian(H, h, c, "cost")
    z = rng.standard_normal((size, len(mean)))
    # u = mean + L^{-T} z has covariance (L L')^{-1} = H^{-1}
    u = mean + np.linalg.solve(L.T, z.T).T
    return u.reshape(size, N, -1)
