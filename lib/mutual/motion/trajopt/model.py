"""The local model of one iLQR pass (Todorov & Li 2005, section 2; Tassa, Erez & Todorov 2012,
eqs. (5)-(6)): along the current trajectory, the dynamics' Jacobian and the running cost's
gradient and Hessian in ``z = (x, u)`` at every stage, and the terminal cost's (DDP also keeps the
dynamics' curvature ``f_zz``). All derivatives are JAX autodiff, exact."""

from typing import NamedTuple

import jax
import jax.numpy as jnp


class Model(NamedTuple):
    """Stacked stage derivatives: ``F`` (N, n, n+m) the dynamics' Jacobian ``[f_x f_u]``, ``g``
    (N, n+m) and ``H`` (N, n+m, n+m) the running cost's gradient and Hessian, ``curvature``
    (N, n, n+m, n+m) the dynamics' Hessians (DDP) or None, ``vN``, ``VN`` the terminal cost's
    gradient and Hessian, ``c`` the largest control curvature (the scale of the regularisation)."""

    F: jax.Array
    g: jax.Array
    H: jax.Array
    curvature: jax.Array | None
    vN: jax.Array
    VN: jax.Array
    c: jax.Array


def quadratic_model(problem, xs, us, params, second_order, near=True):
    """The :class:`Model` along ``(xs, us)``; with ``second_order`` the dynamics' curvature is
    computed only where ``near`` holds (the DDP phase of ``second_order="auto"``), zeros elsewhere."""
    n = xs.shape[1]
    xu = jnp.concatenate([xs[:-1], us], axis=1)

    def f(z):
        return problem.dynamics(z[:n], z[n:], params)

    def ell(z):
        return problem.running_cost(z[:n], z[n:], params)

    F = jax.vmap(jax.jacfwd(f))(xu)
    g = jax.vmap(jax.grad(ell))(xu)
    H = jax.vmap(jax.hessian(ell))(xu)
    vN = jax.grad(problem.terminal_cost)(xs[-1], params)
    VN = jax.hessian(problem.terminal_cost)(xs[-1], params)
    curvature = None
    if second_order:
        shape = (xu.shape[0], n, xu.shape[1], xu.shape[1])
        curvature = jax.lax.cond(near, lambda: jax.vmap(jax.hessian(f))(xu), lambda: jnp.zeros(shape))
    fu2 = jnp.max(jnp.abs(F[:, :, n:])) ** 2
    c = jnp.maximum(jnp.max(jnp.abs(H[:, n:, n:])),
                    fu2 * jnp.maximum(jnp.max(jnp.abs(VN)), jnp.max(jnp.abs(H[:, :n, :n]))))
    return Model(F, g, H, curvature, vN, VN, jnp.where(c > 0, c, 1.0))
