"""The observer's belief over time: ``P(H1 | u_0, ..., u_{t-1})``, the posterior of the Boltzmann
observer of eq. (6.8) after watching the first ``t`` controls (the quantity Dragan and Srinivasa
integrate in their anticipative objective, section 6.5).

``P(u | H_i) = exp(-H_Ji(u)) / Z_i`` is a density over the stacked controls ``u`` (N m,). The
likelihood of the motion so far is its marginal over the controls not yet seen, and by Bayes'
rule with prior ``P(H1) = p``::

    logit P(H1 | u_{0:t}) = log P(u_{0:t} | H1) - log P(u_{0:t} | H0) + logit p

* **Linear dynamics, quadratic costs** (chapter 6, Fig. 7.1): ``P(u | H_i)`` is exactly Gaussian,
  ``N(mu_i, P_i^-1)`` with ``P_i`` the Hessian of ``H_Ji`` in the controls
  (:func:`lq_gaussian`, by the Riccati recursion), and the prefix's marginal is the Gaussian
  marginal: exact.
* **Nonlinear dynamics** (Figs. 6.1, 7.2): *assumption* -- the Laplace approximation of each
  hypothesis around its optimum ``u_i*``: ``P(u | H_i) ~ N(u_i*, [d^2 H_Ji(u_i*)]^-1)`` with the
  exact Hessian of the single-shooting cost (:func:`laplace_gaussian`: autodiff stage derivatives,
  factored by the DDP backward pass at the optimum). It is exact
  when ``H_Ji`` is quadratic in ``u`` and close to exact when the observer's distribution is
  concentrated where ``H_Ji`` is nearly quadratic; far from both optima it extrapolates each
  hypothesis's cost quadratically.

Both are :class:`mutual.motion.chain.ChainGaussian` objects: the precision is block-banded (the problem is
a chain), and its Riccati factorisation gives every prefix marginal as a running sum of the
stage conditionals, O(N) at any horizon. A Gaussian given by a dense precision (any structure)
is served too, by one Cholesky factor: with ``Sigma = L L'`` (lower ``L``) and
``z = L^-1 (u - mu)``, the first ``j`` entries of ``z`` depend only on the first ``j`` controls.
"""

from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from .chain import ChainGaussian, NotRepresentable, log_ratio_prefix, lq_chains, riccati_factor
from .trajopt.checks import check_problem, x64
from .trajopt.model import quadratic_model
from .trajopt.problem import Problem, rollout


def _precision(name, precision, d):
    P = np.asarray(precision, float)
    if P.shape != (d, d) or not np.all(np.isfinite(P)):
        raise ValueError(f"{name} must be a finite ({d}, {d}) precision matrix, got shape {P.shape}")
    P = 0.5 * (P + P.T)
    try:
        np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        raise ValueError(f"{name} is not positive definite: exp(-J) is not normalisable around this point, "
                         "so P(u | H) of eq. (6.8) has no Gaussian (Laplace) form here") from None
    return P


def check_prior(prior):
    """Refuse a prior ``P(H1)`` that is not a number strictly between 0 and 1."""
    if isinstance(prior, (bool, np.bool_)) or not isinstance(prior, (int, float, np.integer, np.floating)) \
            or not 0 < prior < 1:
        raise ValueError(f"prior must be a probability strictly between 0 and 1, got {prior!r}")


def _dense_terms(us, mean, precision):
    """``(L^-1 u, L^-1 mu, log L_jj)`` of a dense Gaussian (module docstring): ``z = L^-1 u - L^-1 mu``,
    its two parts apart so that a ratio of two Gaussians with one factor ``L`` cancels ``L^-1 u`` exactly."""
    us, mean = np.asarray(us, float), np.asarray(mean, float)
    if us.ndim != 2 or us.shape != mean.shape:
        raise ValueError(f"us and mean must be (N, m) arrays of the same shape, got {us.shape} and {mean.shape}")
    if not np.all(np.isfinite(us)):
        raise ValueError("us must be finite")
    N, m = us.shape
    P = _precision("precision", precision, N * m)
    L = np.linalg.cholesky(np.linalg.inv(P))
    with np.errstate(over="ignore", invalid="ignore"):
        return np.linalg.solve(L, us.ravel()), np.linalg.solve(L, mean.ravel()), np.log(np.diag(L))


def gaussian_prefix_loglik(us, gaussian, precision=None):
    """``log N(u_{0:t}; mu_{0:t}, Sigma_{0:t,0:t})`` for ``t = 0..N`` (N+1,).

    ``gaussian``: a :class:`mutual.motion.chain.ChainGaussian` (from :func:`lq_gaussian` or
    :func:`laplace_gaussian`; O(N)), or the mean (N, m) of a Gaussian whose dense ``precision``
    (``Sigma^-1``, any structure; O((N m)^3)) is given. ``us`` (N, m) controls; ``t`` counts control
    steps (``t = 0``: nothing seen, log-likelihood 0).
    """
    if isinstance(gaussian, ChainGaussian) and precision is None:
        return gaussian.prefix_loglik(us)
    if precision is None:
        raise ValueError("gaussian must be a ChainGaussian, or a mean (N, m) given with its precision")
    zu, zm, log_diag = _dense_terms(us, gaussian, precision)
    N, m = np.shape(us)
    with np.errstate(over="ignore", invalid="ignore"):
        terms = -0.5 * (zu - zm) ** 2 - log_diag - 0.5 * np.log(2 * np.pi)
        out = np.concatenate([[0.0], np.cumsum(terms.reshape(N, m).sum(axis=1))])
    if not np.all(np.isfinite(out)):
        raise NotRepresentable("us: log N(u) of these controls is beyond float64's range")
    return out


def _log_ratio(us, gaussian0, gaussian1):
    """``log N0(u_{0:t}) - log N1(u_{0:t})`` (N+1,), as ``-1/2 (z0 - z1).(z0 + z1)`` plus log-determinants."""
    if isinstance(gaussian0, ChainGaussian) and isinstance(gaussian1, ChainGaussian):
        return log_ratio_prefix(us, gaussian0, gaussian1)
    (u0, m0, d0), (u1, m1, d1) = (_dense_terms(us, *g) for g in (gaussian0, gaussian1))
    with np.errstate(over="ignore", invalid="ignore"):
        diff, total = (u0 - u1) - (m0 - m1), (u0 - m0) + (u1 - m1)
        out = np.concatenate([[0.0], np.cumsum((-0.5 * diff * total - d0 + d1).reshape(len(us), -1).sum(axis=1))])
    if not np.all(np.isfinite(out)):
        raise NotRepresentable("us: the log-likelihood ratio of these controls is beyond float64's range")
    return out


def posterior_over_time(us, gaussian0, gaussian1, prior=0.5):
    """``P(H1 | u_{0:t})`` for ``t = 0..N`` (N+1,) from the Gaussians of ``P(u | H0)`` and ``P(u | H1)``
    (:class:`mutual.motion.chain.ChainGaussian` objects, or ``(mean, precision)`` pairs) and the prior
    ``P(H1) = prior`` (eq. (6.8) and Bayes' rule), from the log-likelihood ratio in its stable form."""
    check_prior(prior)
    logit = -_log_ratio(us, gaussian0, gaussian1) + np.log(prior / (1 - prior))
    return 0.5 * (1 + np.tanh(0.5 * logit))  # the logistic function, without overflow


def lq_gaussian(dynamics, cost, x0, N):
    """The exact Gaussian ``P(u | H)`` of eq. (6.8) for linear dynamics
    (:class:`mutual.motion.legible.LinearDynamics`) and a quadratic cost
    (:class:`mutual.motion.legible.QuadraticCost`), as a :class:`mutual.motion.chain.ChainGaussian`
    (its mean is the optimal controls; ``mean, precision = lq_gaussian(...)`` gives the dense form)."""
    return lq_chains(dynamics, [cost], x0, N)[0]


@lru_cache(maxsize=64)
def _expansion(dynamics, running_cost, terminal_cost):
    """The compiled rollout and second-order expansion (DDP's, with the dynamics' curvature) of a problem."""
    problem = Problem(dynamics, running_cost, terminal_cost)

    def expand(x0, us, params):
        xs = rollout(problem, x0, us, params)
        return xs, quadratic_model(problem, xs, us, params, True)
    return jax.jit(expand)


@x64
def laplace_gaussian(dynamics, running_cost, terminal_cost, x0, us_opt, params=None):
    """The Laplace approximation ``N(u*, [d^2 H_J(u*)]^-1)`` of eq. (6.8) around an optimum ``u*``
    (N, m) (e.g. an :class:`mutual.motion.trajopt.ILQRResult`'s ``us``), as a
    :class:`mutual.motion.chain.ChainGaussian`: the exact Hessian of the single-shooting cost
    factored by the DDP backward pass at ``u*`` (the dynamics' second derivatives weighted by the
    costates), O(N). Raises ValueError when the Hessian is not positive definite (``u*`` is not a
    strict local minimum)."""
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us_opt, params)
    xs, model = _expansion(dynamics, running_cost, terminal_cost)(jnp.asarray(x0), jnp.asarray(us), params)
    return second_order_gaussian(np.asarray(xs), us, *(np.asarray(a) for a in (model.F, model.g, model.H,
                                                                              model.curvature, model.vN, model.VN)))


def second_order_gaussian(xs, us, F, g, H, curvature, vN, VN):
    """The Gaussian ``N(us, [d^2 J]^-1)`` of the single-shooting cost's exact Hessian at ``(xs, us)``
    from its stage derivatives (:class:`mutual.motion.trajopt.model.Model`): with the costates
    ``lambda_N = vN``, ``lambda_t = l_x + f_x' lambda_{t+1}``, the Hessian is that of the LQ problem
    along ``A = f_x``, ``B = f_u`` with stage Hessian ``l_zz + sum_i lambda_{t+1,i} f^i_zz`` and terminal
    ``VN``, factored by :func:`mutual.motion.chain.riccati_factor`."""
    N, m = us.shape
    n = xs.shape[1]
    A, B = F[:, :, :n], F[:, :, n:]
    lam = np.empty((N + 1, n))
    lam[N] = vN
    for t in range(N - 1, 0, -1):
        lam[t] = g[t, :n] + A[t].T @ lam[t + 1]
    Hz = H + np.einsum("ti,tijk->tjk", lam[1:], curvature)
    K, _, L = riccati_factor(A, B, Hz[None], np.zeros((1, N, n + m)), VN[None], np.zeros((1, n)),
                             "the Hessian of the cost at us_opt is not positive definite (u* is not a strict "
                             "local minimum), so P(u | H) of eq. (6.8) has no Laplace form there")
    k = us - np.einsum("tij,tj->ti", K[0], xs[:-1])                      # u_t = u*_t + K_t (x_t - x*_t)
    c = xs[1:] - np.einsum("tij,tj->ti", A, xs[:-1]) - np.einsum("tij,tj->ti", B, us)
    return ChainGaussian(A, B, c, xs[0], K[0], k, L[0], us)


def trailing_logdets(H):
    """``log det H[j:, j:]`` for ``j = 0..d`` (d+1,), 0 for the empty block. ``H``: a
    :class:`mutual.motion.chain.ChainGaussian` (O(N)) or a dense precision (the Cholesky factor of
    ``H`` with its variables in reverse order has the trailing blocks as leading blocks)."""
    if isinstance(H, ChainGaussian):
        return H.trailing_logdets()
    L = np.linalg.cholesky(H[::-1, ::-1])
    lead = np.concatenate([[0.0], np.cumsum(2 * np.log(np.diag(L)))])  # log det of the leading k x k
    return lead[::-1]
