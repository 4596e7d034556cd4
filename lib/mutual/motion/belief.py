"""The observer's belief over time: ``P(H1 | u_0, ..., u_{t-1})``, the posterior of the Boltzmann
observer of eq. (6.8) after watching the first ``t`` controls (the quantity Dragan and Srinivasa
integrate in their anticipative objective, section 6.5).

``P(u | H_i) = exp(-H_Ji(u)) / Z_i`` is a density over the stacked controls ``u`` (N m,). The
likelihood of the motion so far is its marginal over the controls not yet seen, and by Bayes'
rule with prior ``P(H1) = p``::

    logit P(H1 | u_{0:t}) = log P(u_{0:t} | H1) - log P(u_{0:t} | H0) + logit p

* **Linear dynamics, quadratic costs** (chapter 6, Fig. 7.1): ``P(u | H_i)`` is exactly Gaussian,
  ``N(mu_i, P_i^-1)`` with ``P_i`` the Hessian of ``H_Ji`` in the controls
  (:func:`lq_gaussian`, from :func:`mutual.motion.observer.lifted_cost`), and the prefix's
  marginal is the Gaussian marginal: exact.
* **Nonlinear dynamics** (Figs. 6.1, 7.2): *assumption* -- the Laplace approximation of each
  hypothesis around its optimum ``u_i*``: ``P(u | H_i) ~ N(u_i*, [d^2 H_Ji(u_i*)]^-1)`` with the
  exact (autodiff) Hessian of the single-shooting cost (:func:`laplace_gaussian`). It is exact
  when ``H_Ji`` is quadratic in ``u`` and close to exact when the observer's distribution is
  concentrated where ``H_Ji`` is nearly quadratic; far from both optima it extrapolates each
  hypothesis's cost quadratically.

Marginals of every prefix come from one Cholesky factor: with ``Sigma = L L'`` (lower ``L``) and
``z = L^-1 (u - mu)``, the first ``j`` entries of ``z`` depend only on the first ``j`` controls, so
``log N(u_{0:t}) = sum_{j < t m} (-z_j^2 / 2 - log L_jj - log(2 pi) / 2)``.
"""

import jax.numpy as jnp
import numpy as np

from .observer import lifted_cost
from .trajopt.checks import check_problem, x64
from .trajopt.compiled import kernels


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


def gaussian_prefix_loglik(us, mean, precision):
    """``log N(u_{0:t}; mu_{0:t}, Sigma_{0:t,0:t})`` for ``t = 0..N`` (N+1,), ``Sigma = precision^-1``.

    ``us`` and ``mean`` (N, m) control sequences; ``t`` counts control steps (``t = 0``: nothing
    seen, log-likelihood 0).
    """
    us, mean = np.asarray(us, float), np.asarray(mean, float)
    if us.ndim != 2 or us.shape != mean.shape:
        raise ValueError(f"us and mean must be (N, m) arrays of the same shape, got {us.shape} and {mean.shape}")
    if not np.all(np.isfinite(us)):
        raise ValueError("us must be finite")
    N, m = us.shape
    P = _precision("precision", precision, N * m)
    L = np.linalg.cholesky(np.linalg.inv(P))
    z = np.linalg.solve(L, (us - mean).ravel()) if N * m else np.zeros(0)
    terms = -0.5 * z ** 2 - np.log(np.diag(L)) - 0.5 * np.log(2 * np.pi)
    per_step = terms.reshape(N, m).sum(axis=1)
    return np.concatenate([[0.0], np.cumsum(per_step)])


def posterior_over_time(us, gaussian0, gaussian1, prior=0.5):
    """``P(H1 | u_{0:t})`` for ``t = 0..N`` (N+1,) from the Gaussians ``(mean, precision)`` of
    ``P(u | H0)`` and ``P(u | H1)`` and the prior ``P(H1) = prior`` (eq. (6.8) and Bayes' rule)."""
    check_prior(prior)
    log0 = gaussian_prefix_loglik(us, *gaussian0)
    log1 = gaussian_prefix_loglik(us, *gaussian1)
    logit = log1 - log0 + np.log(prior / (1 - prior))
    return 0.5 * (1 + np.tanh(0.5 * logit))  # the logistic function, without overflow


def lq_gaussian(dynamics, cost, x0, N):
    """The exact Gaussian ``P(u | H) = N(mean, precision^-1)`` of eq. (6.8) for linear dynamics
    (:class:`mutual.motion.legible.LinearDynamics`) and a quadratic cost
    (:class:`mutual.motion.legible.QuadraticCost`); returns ``(mean (N, m), precision)``."""
    H, h, _ = lifted_cost(dynamics, cost, x0, N)
    P = _precision("the cost's Hessian in the controls", H, H.shape[0])
    return np.linalg.solve(P, -h).reshape(N, -1), P


@x64
def laplace_gaussian(dynamics, running_cost, terminal_cost, x0, us_opt, params=None):
    """The Laplace approximation ``N(u*, [d^2 H_J(u*)]^-1)`` of eq. (6.8) around an optimum ``u*``
    (N, m) (e.g. an :class:`mutual.motion.trajopt.ILQRResult`'s ``us``): the exact Hessian of the
    single-shooting cost by autodiff. Returns ``(mean (N, m), precision)``; raises ValueError when
    the Hessian is not positive definite (``u*`` is not a strict local minimum)."""
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us_opt, params)
    H = np.asarray(kernels(dynamics, running_cost, terminal_cost)[4](jnp.asarray(us), x0, params))
    return us, _precision("the Hessian of the cost at us_opt", H, H.shape[0])


def trailing_logdets(H):
    """``log det H[j:, j:]`` for ``j = 0..d`` (d+1,), 0 for the empty block: the Cholesky factor of
    ``H`` with its variables in reverse order has the trailing blocks as leading blocks."""
    L = np.linalg.cholesky(H[::-1, ::-1])
    lead = np.concatenate([[0.0], np.cumsum(2 * np.log(np.diag(L)))])  # log det of the leading k x k
    return lead[::-1]
