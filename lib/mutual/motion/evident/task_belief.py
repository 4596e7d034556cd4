"""The observer's belief over time for an evident-safety task (chapter 7, Figs. 7.1-7.2):
``P(H1 | u_0, ..., u_{t-1})`` for the car or the single integrator of :mod:`.safety`, each
hypothesis's likelihood of the motion so far by the Laplace approximation around its optimal
continuation (exact for ``x' = u``; the general Gaussian machinery is :mod:`mutual.motion.belief`)."""

import jax
import jax.numpy as jnp
import numpy as np

from ..belief import check_prior, laplace_gaussian, lq_gaussian, posterior_over_time
from ..legible.problem import single_integrator
from . import safety as es
from .mpc import continuation_costs


def continuation_loglik(task, weights, us, optimum, times=None):
    """``log P(u_{0:t} | H)`` (len(times),) for a hypothesis with feature ``weights`` on ``task``,
    by the Laplace approximation around the *optimal continuation* of the motion so far::

        log P(u_{0:t} | H) = -J_{0:t}(u) - V_t(x_t) + J* + 1/2 [log det Hess - log det Hess_{t:,t:}]
                             - (t m / 2) log(2 pi)

    ``J_{0:t}``: the cost of the controls seen so far (exact); ``V_t(x_t)``: the optimal cost-to-go
    from the state they reached (iLQR on the remaining horizon, all ``t`` solved at once,
    :mod:`.mpc`'s frozen stages); ``J* = V_0(x_0)``: the hypothesis's optimal cost;
    ``Hess``: the Hessian of ``H_J`` in the controls at the optimum ``optimum`` (an ILQRResult),
    whose Schur complement onto the first ``t`` steps measures the volume of near-optimal
    continuations (its log-determinant is a running sum of the DDP backward pass's
    ``log det Q_uu``, :meth:`mutual.motion.chain.ChainGaussian.prefix_logdets`). For linear
    dynamics and quadratic costs every term is exact (the integral of the Gaussian over the
    unseen controls), so this equals the Gaussian marginal of
    :func:`mutual.motion.belief.gaussian_prefix_loglik`; it is Dragan and Srinivasa's ``exp(-C(xi_{S->Q}) - V(Q)) /
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
    schur = laplace_gaussian(dyn, run, term, x0, optimum.us, params).prefix_logdets()
    xs = es.rollout(task, us)
    with jax.enable_x64(True):
        stage = np.asarray(jax.vmap(run, in_axes=(0, 0, None))(jnp.asarray(xs[:-1]), jnp.asarray(us), params))
    prefix = np.concatenate([[0.0], np.cumsum(stage)])
    # V_0(x_0) by the same search as every V_t, so that nothing seen gives log-likelihood 0
    to_go = continuation_costs(task, weights, xs[np.r_[0, times]], np.r_[0, times], (optimum.us, us))
    return -prefix[times] - to_go[1:] + to_go[0] + 0.5 * schur[times] - 0.5 * times * m * np.log(2 * np.pi)


def belief_over_time(task, w0, w1, us, optima, prior=0.5, times=None):
    """``P(H1 | u_{0:t})`` for ``t`` in ``times`` (default ``0..N``) of controls ``us`` on ``task``,
    with each hypothesis's likelihood from :func:`continuation_loglik` around its optimum
    ``optima = {"H0": result, "H1": result}`` (exact for ``x' = u``)."""
    check_prior(prior)
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
