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

import jax
import jax.numpy as jnp
import numpy as np

from . import evident_safety as es
from .ilqr_core import kernels
from .mpc import continuation_costs
from .legibility import single_integrator
from .observer import lifted_cost
from .problem_checks import check_problem, x64


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
    if isinstance(prior, (bool, np.bool_)) or not isinstance(prior, (int, float, np.integer, np.floating)) \
            or not 0 < prior < 1:
        raise ValueError(f"prior must be a probability strictly between 0 and 1, got {prior!r}")
    log0 = gaussian_prefix_loglik(us, *gaussian0)
    log1 = gaussian_prefix_loglik(us, *gaussian1)
    logit = log1 - log0 + np.log(prior / (1 - prior))
    return 0.5 * (1 + np.tanh(0.5 * logit))  # the logistic function, without overflow


def lq_gaussian(dynamics, cost, x0, N):
    """The exact Gaussian ``P(u | H) = N(mean, precision^-1)`` of eq. (6.8) for linear dynamics
    (:class:`mutual.motion.legibility.LinearDynamics`) and a quadratic cost
    (:class:`mutual.motion.legibility.QuadraticCost`); returns ``(mean (N, m), precision)``."""
    H, h, _ = lifted_cost(dynamics, cost, x0, N)
    P = _precision("the cost's Hessian in the controls", H, H.shape[0])
    return np.linalg.solve(P, -h).reshape(N, -1), P


@x64
def laplace_gaussian(dynamics, running_cost, terminal_cost, x0, us_opt, params=None):
    """The Laplace approximation ``N(u*, [d^2 H_J(u*)]^-1)`` of eq. (6.8) around an optimum ``u*``
    (N, m) (e.g. an :class:`mutual.motion.ilqr.ILQRResult`'s ``us``): the exact Hessian of the
    single-shooting cost by autodiff. Returns ``(mean (N, m), precision)``; raises ValueError when
    the Hessian is not positive definite (``u*`` is not a strict local minimum)."""
    x0, us = check_problem(dynamics, running_cost, terminal_cost, x0, us_opt, params)
    H = np.asarray(kernels(dynamics, running_cost, terminal_cost)[4](jnp.asarray(us), x0, params))
    return us, _precision("the Hessian of the cost at us_opt", H, H.shape[0])


def _trailing_logdets(H):
    """``log det H[j:, j:]`` for ``j = 0..d`` (d+1,), 0 for the empty block: the Cholesky factor of
    ``H`` with its variables in reverse order has the trailing blocks as leading blocks."""
    L = np.linalg.cholesky(H[::-1, ::-1])
    lead = np.concatenate([[0.0], np.cumsum(2 * np.log(np.diag(L)))])  # log det of the leading k x k
    return lead[::-1]


def continuation_loglik(task, weights, us, optimum, times=None):
    """``log P(u_{0:t} | H)`` (len(times),) for a hypothesis with feature ``weights`` on ``task``,
    by the Laplace approximation around the *optimal continuation* of the motion so far::

        log P(u_{0:t} | H) = -J_{0:t}(u) - V_t(x_t) + J* + 1/2 [log det Hess - log det Hess_{t:,t:}]
                             - (t m / 2) log(2 pi)

    ``J_{0:t}``: the cost of the controls seen so far (exact); ``V_t(x_t)``: the optimal cost-to-go
    from the state they reached (iLQR on the remaining horizon, all ``t`` solved at once,
    :mod:`mutual.motion.mpc`'s frozen stages); ``J* = V_0(x_0)``: the hypothesis's optimal cost;
    ``Hess``: the Hessian of ``H_J`` in the controls at the optimum ``optimum`` (an ILQRResult),
    whose Schur complement onto the first ``t`` steps measures the volume of near-optimal
    continuations. For linear dynamics and quadratic costs every term is exact (the integral of
    the Gaussian over the unseen controls), so this equals the Gaussian marginal of
    :func:`gaussian_prefix_loglik`; it is Dragan and Srinivasa's ``exp(-C(xi_{S->Q}) - V(Q)) /
    exp(-V(S))`` with that volume correction. Raises ValueError if a continuation does not converge.
    """
    us = np.asarray(us, float)
    N, m = task.steps, task.controls
    if us.shape != (N, m) or not np.all(np.isfinite(us)):
        raise ValueError(f"us must be finite controls of shape {(N, m)}, got {us.shape}")
    times = np.arange(N + 1) if times is None else np.asarray(times)
    if times.ndim != 1 or times.size == 0 or not np.issubdtype(times.dtype, np.integer) \
            or times.min() < 0 or times.max() > N:
        raise ValueError(f"times must be integers in [0, {N}], got {times!r}")
    dyn, run, term, x0, params = es.problem(task, weights)
    _, H = laplace_gaussian(dyn, run, term, x0, optimum.us, params)
    logdet = _trailing_logdets(H)
    xs = es.rollout(task, us)
    with jax.enable_x64(True):
        stage = np.asarray(jax.vmap(run, in_axes=(0, 0, None))(jnp.asarray(xs[:-1]), jnp.asarray(us), params))
    prefix = np.concatenate([[0.0], np.cumsum(stage)])
    # V_0(x_0) by the same search as every V_t, so that nothing seen gives log-likelihood 0
    to_go = continuation_costs(task, weights, xs[np.r_[0, times]], np.r_[0, times], (optimum.us, us))
    full = logdet[0] - logdet[times * m]
    return -prefix[times] - to_go[1:] + to_go[0] + 0.5 * full - 0.5 * times * m * np.log(2 * np.pi)


def belief_over_time(task, w0, w1, us, optima, prior=0.5, times=None):
    """``P(H1 | u_{0:t})`` for ``t`` in ``times`` (default ``0..N``) of controls ``us`` on ``task``,
    with each hypothesis's likelihood from :func:`continuation_loglik` around its optimum
    ``optima = {"H0": result, "H1": result}`` (exact for ``x' = u``)."""
    if isinstance(prior, (bool, np.bool_)) or not isinstance(prior, (int, float, np.integer, np.floating)) \
            or not 0 < prior < 1:
        raise ValueError(f"prior must be a probability strictly between 0 and 1, got {prior!r}")
    if task.x0.shape == (2,) and np.asarray(w0)[3] == 0 and np.asarray(w1)[3] == 0 and np.asarray(w0)[2] == 0:
        # x' = u with quadratic features: the exact Gaussians of chapter 6 (numpy, no solves)
        costs = es.lq_hypothesis_costs(task, w0, w1)
        gaussians = [lq_gaussian(single_integrator(2, task.dt), costs[k], task.x0, task.steps) for k in ("H0", "H1")]
        b = posterior_over_time(us, *gaussians, prior=prior)
        return b if times is None else b[np.asarray(times)]
    log0 = continuation_loglik(task, w0, us, optima["H0"], times)
    log1 = continuation_loglik(task, w1, us, optima["H1"], times)
    return 0.5 * (1 + np.tanh(0.5 * (log1 - log0 + np.log(prior / (1 - prior)))))


def task_gaussians(task, w0, w1, optima):
    """``(P(u|H0), P(u|H1))`` as Gaussians ``(mean, precision)`` for a task, Laplace-approximated
    around the hypotheses' optima ``optima = {"H0": result, "H1": result}`` (the *global*
    Laplace approximation; exact for ``x' = u``, whose feature costs are quadratic)."""
    return tuple(laplace_gaussian(*es.problem(task, w)[:4], optima[name].us, es.problem(task, w)[4])
                 for name, w in (("H0", w0), ("H1", w1)))
