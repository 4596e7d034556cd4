"""The compiled programs behind :func:`mutual.motion.trajopt.ilqr`: one solve is one jit-compiled
``jax.lax.while_loop`` over :func:`.iteration.iteration`, so no Python runs between passes; a
batch of problems runs the same pass under ``jax.vmap``, in a batch that shrinks as its members
stop. :func:`kernels` compiles them once per problem (its three callables) and keeps them, so
every later problem of the same shape reuses the compilation (and, across processes, JAX's
persistent compilation cache, :mod:`mutual.jax_cache`)."""

from functools import lru_cache, partial
from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from .iteration import finish, initial, is_near, iteration, running
from .problem import Problem, rollout, shooting_cost
from .settings import Tolerances

SHRINK_FROM = 16  # a batch of fewer problems runs to its end (a smaller one would cost another compilation)


class Kernels(NamedTuple):
    """The compiled programs of one problem (see :func:`kernels`)."""

    rollout: Callable
    value_and_grad: Callable
    solve: Callable
    solve_batch: Callable
    hessian: Callable


@jax.jit
def _take(tree, index):
    return jax.tree_util.tree_map(lambda a: a[index], tree)


@jax.jit
def _put(tree, index, values):
    return jax.tree_util.tree_map(lambda a, b: a.at[index].set(b), tree, values)


def solve(problem, x0, us, params, tolerances, second_order, max_iter):
    """iLQR to convergence as one ``while_loop`` over backward passes.

    ``tolerances``: :attr:`.settings.ILQRSettings.tolerances` (one array, read as a
    :class:`.settings.Tolerances`). Returns what :func:`.iteration.finish` returns.
    """
    tol = Tolerances(*tolerances)
    end = jax.lax.while_loop(lambda s: running(s, max_iter),
                             lambda s: iteration(problem, s, x0, params, tol, second_order),
                             initial(problem, x0, us, params, max_iter))
    return finish(problem, end, params)


def advance(problem, states, x0, params, tolerances, second_order, max_iter, keep):
    """Passes of a batch of solves (leading axis) until at most ``keep`` of them still run.

    A member that has stopped keeps its state while the others go on; the loop ends for the
    whole batch once few enough run, so the caller can gather the rest into a smaller batch."""
    tol = Tolerances(*tolerances)
    step = jax.vmap(partial(iteration, problem), in_axes=(0, 0, 0, None, None, None))

    def body(states):
        on = running(states, max_iter)
        any_near = jnp.any(jax.vmap(is_near, in_axes=(0, None))(states, second_order) & on)
        new = step(states, x0, params, tol, second_order, any_near)
        return jax.tree_util.tree_map(lambda a, b: jnp.where(on.reshape(on.shape + (1,) * (a.ndim - 1)), a, b),
                                      new, states)

    def go_on(states):
        on = running(states, max_iter)
        return jnp.any(on) & (jnp.sum(on) > keep)
    return jax.lax.while_loop(go_on, body, states)


def solve_batch(problem, programs, x0, us, params, tolerances, second_order, max_iter):
    """:func:`solve` for a batch (leading axis on ``x0``, ``us`` and every leaf of ``params``).

    A batch of at least ``SHRINK_FROM`` problems shrinks as its members stop: once at most a
    quarter of it still runs, those members are gathered into a batch whose size is a power of
    4 (padded with repeats) and go on there, so a few slow members do not keep the whole batch
    busy (a vmapped pass costs the same however many of its members still run). Gathering
    moves whole states, so every member takes the same passes as alone."""
    start_batch, advance_batch, finish_batch = programs
    states = start_batch(x0, us, params, max_iter)
    live = np.arange(len(x0))
    size = live.size
    while live.size:
        pick = np.concatenate([live, np.repeat(live[:1], size - live.size)])
        part = (states, x0, params) if size == len(x0) else _take((states, x0, params), pick)
        done = advance_batch(*part, tolerances, second_order, max_iter, size // 4 if size >= SHRINK_FROM else 0)
        states = done if size == len(x0) else _put(states, pick, done)
        live = live[np.asarray(running(done, max_iter))[:live.size]]
        size = 4 ** int(np.ceil(np.log(max(live.size, 1)) / np.log(4) - 1e-9))
    return finish_batch(states, params)


def hessian(problem, us, x0, params):
    """The exact Hessian of the single-shooting cost in the stacked controls (N m, N m)."""
    shape = us.shape
    return jax.hessian(lambda flat: shooting_cost(problem, flat.reshape(shape), x0, params))(us.ravel())


@lru_cache(maxsize=64)
def kernels(dynamics, running_cost, terminal_cost):
    """The compiled :class:`Kernels` of one problem's callables.

    ``rollout(x0, us, params)``; ``value_and_grad(us, x0, params)`` of the single-shooting cost;
    ``solve(x0, us, params, tolerances, second_order, max_iter)`` (one jit-compiled loop; the last two
    static); ``solve_batch`` the same for a batch (a leading axis on ``x0``, ``us`` and ``params``);
    ``hessian(us, x0, params)``.
    """
    problem = Problem(dynamics, running_cost, terminal_cost)
    programs = (jax.jit(jax.vmap(partial(initial, problem), in_axes=(0, 0, 0, None)), static_argnums=3),
                jax.jit(partial(advance, problem), static_argnums=(4, 5)),
                jax.jit(jax.vmap(partial(finish, problem))))
    return Kernels(rollout=jax.jit(partial(rollout, problem)),
                   value_and_grad=jax.jit(jax.value_and_grad(partial(shooting_cost, problem))),
                   solve=jax.jit(partial(solve, problem), static_argnums=(4, 5)),
                   solve_batch=partial(solve_batch, problem, programs),
                   hessian=jax.jit(partial(hessian, problem)))
