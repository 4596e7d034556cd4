"""The optimal-control problem iLQR solves (eq. (6.4) in discrete time), as three JAX callables::

    min_u  sum_{k<N} running_cost(x_k, u_k, params) + terminal_cost(x_N, params)
    s.t.   x_{k+1} = dynamics(x_k, u_k, params)

with its rollout and its single-shooting cost ``H_J(u)`` (eq. (6.6)). Every function here is
traced inside the compiled solver (:mod:`.compiled`); ``params`` is any pytree.
"""

from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp


class Problem(NamedTuple):
    """The three callables of one problem (hashable: one compilation per problem)."""

    dynamics: Callable
    running_cost: Callable
    terminal_cost: Callable


def rollout(problem, x0, us, params):
    """States ``x_0..x_N`` (N+1, n) reached from ``x0`` under the controls ``us`` (N, m)."""
    def step(x, u):
        x_next = problem.dynamics(x, u, params)
        return x_next, x_next
    return jnp.concatenate([x0[None], jax.lax.scan(step, x0, us)[1]])


def cost_and_magnitude(problem, xs, us, params):
    """The total cost of a trajectory and its magnitude ``M`` (sum of the absolute stage and
    terminal costs: the scale the cost is known to, see :mod:`.iteration`)."""
    running = jax.vmap(problem.running_cost, in_axes=(0, 0, None))(xs[:-1], us, params)
    final = problem.terminal_cost(xs[-1], params)
    return jnp.sum(running) + final, jnp.sum(jnp.abs(running)) + jnp.abs(final)


def shooting_cost(problem, us, x0, params):
    """``H_J(u)`` of eq. (6.6): the total cost of the rollout of ``us``."""
    return cost_and_magnitude(problem, rollout(problem, x0, us, params), us, params)[0]
