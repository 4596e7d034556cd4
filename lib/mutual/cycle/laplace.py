"""The observer's posterior over time for continuous controls: chapter 6's Boltzmann observer
(eq. 6.8, P(u | H) = exp(-J_H(u)) / Z_H) asked after every step, by the Laplace approximation.

After seeing the first t controls u_{0:t} (and so the states x_0..x_t) the observer's likelihood is
the Boltzmann density marginalised over the controls still to come,

    P(u_{0:t} | H) = int exp(-J_H(u_{0:t}, u_{t:N})) du_{t:N} / Z_H.

Costs are additive, J_H = J_pre(u_{0:t}) + J_tail(x_t, u_{t:N}), and the Laplace approximation
around the optimal tail (iLQR from x_t, multi-start) gives

    log P(u_{0:t} | H) ~ -J_pre - J*_tail(x_t) - 1/2 log det H_tail(x_t) + J*_tail(x_0) + 1/2 log det H_tail(x_0)
                         - (t m / 2) log 2 pi,

with H_tail the exact Hessian of the tail's single-shooting cost in its controls (JAX autodiff). It
is exact for linear dynamics and quadratic costs (the Gaussian case of :mod:`mutual.motion.observer`).
Tails of every length share one compiled iLQR: the problem is padded to N stages with a stage clock,
the first t stages frozen (the state stays put and their control costs u^2 / 2, a unit Gaussian whose
log-determinant is 0).
"""

from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from ..motion import ILQRError, ilqr


@lru_cache(maxsize=64)
def _padded(dynamics, running_cost, terminal_cost):
    """Dynamics and costs on the state (x, clock) with stages before ``params["t0"]`` frozen."""

    def dyn(z, u, params):
        live = z[-1] >= params["t0"] - 0.5
        x = jnp.where(live, dynamics(z[:-1], u, params["inner"]), z[:-1])
        return jnp.concatenate([x, z[-1:] + 1.0])

    def run(z, u, params):
        live = z[-1] >= params["t0"] - 0.5
        return jnp.where(live, running_cost(z[:-1], u, params["inner"]), 0.5 * jnp.sum(u ** 2))

    def term(z, params):
        return terminal_cost(z[:-1], params["inner"])

    def shooting(us, z0, params):
        def step(z, u):
            return dyn(z, u, params), run(z, u, params)
        z, costs = jax.lax.scan(step, z0, us)
        return jnp.sum(costs) + term(z, params)

    return dyn, run, term, jax.jit(jax.hessian(shooting))


@lru_cache(maxsize=64)
def _stage_costs(dynamics, running_cost):
    """A compiled rollout returning the states x_0..x_N and each stage's running cost."""

    def rollout(x0, us, params):
        def step(x, u):
            return dynamics(x, u, params), (x, running_cost(x, u, params))
        last, (xs, costs) = jax.lax.scan(step, x0, us)
        return jnp.concatenate([xs, last[None]]), costs

    return jax.jit(rollout)


def _prefix_costs(dynamics, running_cost, x0, us, params):
    """States x_0..x_N and the running costs of each stage along the controls ``us``."""
    with jax.enable_x64(True):
        xs, costs = _stage_costs(dynamics, running_cost)(jnp.asarray(x0, float), jnp.asarray(us, float), params)
    return np.asarray(xs), np.asarray(costs)


def best_tail(dynamics, running_cost, terminal_cost, x, t, params, guesses, **ilqr_options):
    """The lowest-cost iLQR optimum of the tail from state ``x`` at stage ``t`` over runs from the (N, m)
    control ``guesses`` (their stages before t are ignored), in the padded problem (state (x, clock)).
    Returns the padded :class:`mutual.motion.trajopt.ILQRResult`; raises ILQRError if no run converges.
    With ``t = 0`` this solves the whole problem (one compiled iLQR serves paths and tails alike)."""
    dyn, run, term, _ = _padded(dynamics, running_cost, terminal_cost)
    z0 = np.concatenate([np.asarray(x, float), [0.0]])
    p = {"inner": params, "t0": np.float64(t)}
    best = None
    for guess in guesses:
        us0 = np.array(guess, dtype=float)
        us0[:t] = 0.0
        try:
            result = ilqr(dyn, run, term, z0, us0, p, **ilqr_options)
        except ILQRError:
            continue
        if best is None or result.cost < best.cost:
            best = result
    if best is None:
        raise ILQRError(f"no iLQR start converged for the tail from stage {t}")
    return best


def tail_optimum(dynamics, running_cost, terminal_cost, x, t, steps, params, guesses, **ilqr_options):
    """The best local optimum of the tail from state ``x`` at stage ``t`` (N = ``steps`` in all), by
    :func:`best_tail`, with the log-determinant of the tail's Hessian in its controls. Returns
    ``(cost J*_tail, log det H_tail, tail controls (N - t, m))``; raises ILQRError if no run converges or
    the Hessian is not positive definite. ``ilqr_options`` go to :func:`mutual.motion.trajopt.ilqr`."""
    best = best_tail(dynamics, running_cost, terminal_cost, x, t, params, guesses, **ilqr_options)
    hessian = _padded(dynamics, running_cost, terminal_cost)[3]
    z0 = np.concatenate([np.asarray(x, float), [0.0]])
    with jax.enable_x64(True):
        H = np.asarray(hessian(jnp.asarray(best.us), jnp.asarray(z0), {"inner": params, "t0": np.float64(t)}))
    H = H.reshape(steps * best.us.shape[1], -1)
    sign, logdet = np.linalg.slogdet(0.5 * (H + H.T))
    if sign <= 0:
        raise ILQRError(f"the tail's Hessian from stage {t} is not positive definite: no Laplace approximation")
    # the frozen stages cost u^2 / 2 (zero at the optimum) and add log det I = 0
    return best.cost - 0.5 * np.sum(best.us[:t] ** 2), logdet, best.us[t:]


def prefix_log_likelihoods(dynamics, running_cost, terminal_cost, x0, us, params, guesses=(), **ilqr_options):
    """log P(u_{0:t} | H) for t = 0..N of the controls ``us`` (N, m) under the Boltzmann hypothesis
    with these dynamics, costs and ``params`` (module docstring); entry 0 is 0.

    ``guesses``: extra (N, m) starting controls for the tails' iLQR (e.g. the hypothesis's own optimum);
    the robot's own remaining controls, the previous tail's optimum and zero controls are always tried;
    ``ilqr_options`` go to every iLQR run.
    """
    us = np.asarray(us, dtype=float)
    if us.ndim != 2:
        raise ValueError(f"us: must have shape (N, m), got {us.shape}")
    N, m = us.shape
    xs, stage = _prefix_costs(dynamics, running_cost, x0, us, params)
    extra = [np.asarray(g, float).reshape(N, m) for g in guesses]
    previous = np.zeros((N, m))
    out = np.zeros(N + 1)
    J0, logdet0 = None, None
    for t in range(N + 1):
        if t == N:
            with jax.enable_x64(True):
                Jt, logdet = float(terminal_cost(jnp.asarray(xs[N]), params)), 0.0
        else:
            Jt, logdet, tail = tail_optimum(dynamics, running_cost, terminal_cost, xs[t], t, N, params,
                                            [us, previous, np.zeros((N, m))] + extra, **ilqr_options)
            previous = np.concatenate([np.zeros((t, m)), tail])
        if t == 0:
            J0, logdet0 = Jt, logdet
        out[t] = -stage[:t].sum() - Jt - 0.5 * logdet + J0 + 0.5 * logdet0 - 0.5 * t * m * np.log(2 * np.pi)
    return out


def posterior_over_time(log_lik_h1, log_lik_h0, prior=0.5):
    """P(H1 | u_{0:t}) for each t from the two hypotheses' prefix log-likelihoods."""
    if not 0 < prior < 1:
        raise ValueError(f"prior: P(H1) must lie in (0, 1), got {prior!r}")
    log_odds = np.log(prior) - np.log1p(-prior) + np.asarray(log_lik_h1) - np.asarray(log_lik_h0)
    return 1.0 / (1.0 + np.exp(-log_odds))
