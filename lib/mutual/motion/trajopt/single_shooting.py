"""Single shooting, the baseline to iLQR: minimise ``H_J(u)`` of eq. (6.6), the total cost of the
rollout of the controls, over the flattened controls with L-BFGS.

Two drivers on the same jit-compiled objective and autodiff gradient as iLQR
(:func:`.compiled.kernels`): scipy's L-BFGS-B called from Python, and optax's
L-BFGS (zoom line search) with the whole loop compiled into one ``jax.lax.while_loop``, which
is what a practitioner who writes the problem in JAX would use.
"""

from functools import lru_cache

import jax
import jax.numpy as jnp
import numpy as np

from .checks import check_problem, x64
from .compiled import kernels


@x64
def solve_single_shooting(dynamics, running_cost, terminal_cost, x0, us0, params=None, gtol=1e-8,
                          max_iter=20000):
    """Minimise ``H_J(u)`` with scipy L-BFGS-B; returns ``(us, cost, scipy_result)``."""
    from scipy.optimize import minimize

    x0, us0 = check_problem(dynamics, running_cost, terminal_cost, x0, us0, params)
    value_and_grad = kernels(dynamics, running_cost, terminal_cost).value_and_grad
    shape = us0.shape
    x0, params = jax.device_put((x0, params))  # once, so that the evaluations do not convert them again

    def fun(flat):
        value, grad = value_and_grad(flat.reshape(shape), x0, params)
        return float(value), np.asarray(grad, dtype=float).ravel()

    res = minimize(fun, us0.ravel(), jac=True, method="L-BFGS-B",
                   options={"maxiter": max_iter, "maxfun": 2 * max_iter, "gtol": gtol, "ftol": 1e-15})
    return res.x.reshape(shape), float(res.fun), res


@lru_cache(maxsize=64)
def _optax_kernel(dynamics, running_cost, terminal_cost, memory_size):
    import optax

    value_and_grad = kernels(dynamics, running_cost, terminal_cost).value_and_grad

    def solve(us0, x0, params, target, rtol, max_iter):
        def fun(us):
            return value_and_grad(us, x0, params)[0]

        opt = optax.lbfgs(memory_size=memory_size)
        vag = optax.value_and_grad_from_state(fun)

        def body(carry):
            us, state, _, previous, k = carry
            value, grad = vag(us, state=state)
            updates, state = opt.update(grad, state, us, value=value, grad=grad, value_fn=fun)
            us = optax.apply_updates(us, updates)
            return us, state, optax.tree_utils.tree_get(state, "value"), value, k + 1

        def keep_going(carry):
            _, _, value, previous, k = carry
            scale = jnp.maximum(jnp.abs(value), jnp.abs(previous))
            return (value > target) & (k < max_iter) & ~((k > 1) & (previous - value <= rtol * scale))

        first = fun(us0)
        us, _, value, _, k = jax.lax.while_loop(keep_going, body, (us0, opt.init(us0), first, jnp.inf * first, 0))
        return us, fun(us), k

    return jax.jit(solve, static_argnames=("max_iter",))


@x64
def solve_lbfgs_jit(dynamics, running_cost, terminal_cost, x0, us0, params=None, target=-np.inf, rtol=1e-15,
                    max_iter=20000, memory_size=10):
    """Minimise ``H_J(u)`` with optax L-BFGS, the whole loop jit-compiled; ``(us, cost, iterations)``.

    Stops at the first iterate whose cost is at most ``target`` (an oracle stop, e.g. a known
    optimum plus 1e-9 relative, which favours this baseline in a benchmark), when an iteration
    lowers the cost by at most ``rtol`` relative, or after ``max_iter`` iterations.
    """
    x0, us0 = check_problem(dynamics, running_cost, terminal_cost, x0, us0, params)
    solve = _optax_kernel(dynamics, running_cost, terminal_cost, int(memory_size))
    us, cost, k = jax.device_get(solve(us0, x0, params, float(target), float(rtol), max_iter=int(max_iter)))
    return np.asarray(us), float(cost), int(k)
