"""The forward pass with a backtracking line search (Tassa, Erez & Todorov 2012, section II-D,
eqs. (12)-(13)): roll the policy ``u = u_ref + a k + K (x - x_ref)`` out through the true dynamics
for ``a = 1, 1/2, ..., 1/1024`` and accept the first step whose actual decrease is at least
``ARMIJO`` times the model's predicted decrease ``-(a d1 + a^2 d2)``."""

import jax
import jax.numpy as jnp
import numpy as np

from .problem import cost_and_magnitude

STEP_SIZES = 0.5 ** np.arange(11)  # backtracking line search 1, 1/2, ..., 1/1024
ARMIJO = 1e-4  # accept a step whose actual decrease is at least this fraction of the predicted one


def _trial(problem, a, x0, xs, us, cost, G, d1, d2, params):
    """The rollout of the step of size ``a`` and whether it is accepted."""
    def step(x, stage):
        x_ref, u_ref, Gk = stage
        u = u_ref + a * Gk[:, 0] + jnp.sum(Gk[:, 1:] * (x - x_ref)[None, :], axis=1)
        x_next = problem.dynamics(x, u, params)
        return x_next, (x_next, u)
    _, (x_new, u_new) = jax.lax.scan(step, x0, (xs[:-1], us, G))
    x_new = jnp.concatenate([x0[None], x_new])
    c_new, mag_new = cost_and_magnitude(problem, x_new, u_new, params)
    expected = -(a * d1 + a ** 2 * d2)
    accept = jnp.isfinite(c_new) & (c_new < cost) & (cost - c_new >= ARMIJO * expected)
    return x_new, u_new, c_new, mag_new, accept


def line_search(problem, x0, xs, us, cost, G, d1, d2, params, active):
    """``(xs, us, cost, magnitude, accepted, a)`` of the first accepted step size (the last tried if
    none). Searches only while ``active``: under ``vmap`` both branches of the caller's ``cond``
    run, and a member that is not searching must not keep the batch's search going."""
    steps = jnp.asarray(STEP_SIZES)

    def body(state):
        i, *_ = state
        return (i + 1, *_trial(problem, steps[i], x0, xs, us, cost, G, d1, d2, params))

    def keep_going(state):
        return active & ~state[-1] & (state[0] < len(STEP_SIZES))

    first = _trial(problem, steps[0], x0, xs, us, cost, G, d1, d2, params)
    i, x_new, u_new, c_new, mag_new, accept = jax.lax.while_loop(keep_going, body, (1, *first))
    return x_new, u_new, c_new, mag_new, accept, steps[i - 1]


def no_step(problem, x0, xs, us, cost, *_):
    """The same outputs as :func:`line_search` for a pass that takes no step."""
    return xs, us, cost, jnp.zeros(()), jnp.zeros((), bool), jnp.zeros(())
