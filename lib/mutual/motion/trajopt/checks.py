"""Input checks shared by iLQR and its single-shooting baselines: every problem is validated up
front, so a bad input raises a ValueError naming the argument instead of a tracing error."""

from functools import lru_cache, wraps

import jax
import jax.numpy as jnp
import numpy as np


def x64(fn):
    """Run ``fn`` (and everything it traces or compiles) with 64-bit JAX types, leaving the
    global JAX setting of other modules alone."""
    @wraps(fn)
    def wrapped(*args, **kwargs):
        with jax.enable_x64(True):
            return fn(*args, **kwargs)
    return wrapped


@lru_cache(maxsize=256)
def _check_outputs(dynamics, running_cost, terminal_cost, n, m, treedef, specs):
    """Abstractly evaluate the callables once per problem signature and check their output shapes."""
    x, u = jax.ShapeDtypeStruct((n,), jnp.float64), jax.ShapeDtypeStruct((m,), jnp.float64)
    params = jax.tree_util.tree_unflatten(treedef, [jax.ShapeDtypeStruct(shape, dtype) for shape, dtype in specs])
    out = jax.eval_shape(dynamics, x, u, params).shape
    if out != (n,):
        raise ValueError(f"dynamics must map a state of shape {(n,)} to the same shape, got {out}")
    for name, shape in (("running_cost", jax.eval_shape(running_cost, x, u, params).shape),
                        ("terminal_cost", jax.eval_shape(terminal_cost, x, params).shape)):
        if shape != ():
            raise ValueError(f"{name} must return a scalar, got shape {shape}")


def _array(name, value):
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of numbers, got {type(value).__name__}") from None


def check_callables(dynamics, running_cost, terminal_cost):
    for name, fn in (("dynamics", dynamics), ("running_cost", running_cost), ("terminal_cost", terminal_cost)):
        if not callable(fn):
            raise ValueError(f"{name} must be callable, got {type(fn).__name__}")


def params_signature(params, batch=False):
    """The tree structure and the (shape, dtype) of each leaf of ``params`` (without the batch axis)."""
    leaves, treedef = jax.tree_util.tree_flatten(params)
    specs = []
    for leaf in leaves:
        array = _array("params", leaf)
        if not np.isfinite(array).all():
            raise ValueError("params must be finite")
        dtype = leaf.dtype if isinstance(leaf, (np.ndarray, np.generic, jax.Array)) else np.result_type(leaf)
        specs.append((array.shape[1 if batch else 0:], dtype.name))
    return treedef, tuple(specs)


def check_problem(dynamics, running_cost, terminal_cost, x0, us, params):
    """Validate the inputs and the callables' output shapes; return ``x0`` and ``us`` as float arrays."""
    check_callables(dynamics, running_cost, terminal_cost)
    x0, us = _array("x0", x0), _array("us", us)
    if x0.ndim != 1 or x0.shape[0] < 1:
        raise ValueError(f"x0 must be a state vector, got shape {x0.shape}")
    if us.ndim != 2 or us.shape[0] < 1 or us.shape[1] < 1:
        raise ValueError(f"us must have shape (N, m) with N >= 1, got {us.shape}")
    if not np.isfinite(x0).all():
        raise ValueError("x0 must be finite")
    if not np.isfinite(us).all():
        raise ValueError("us must be finite")
    _check_outputs(dynamics, running_cost, terminal_cost, x0.shape[0], us.shape[1], *params_signature(params))
    return x0, us


def check_batch(dynamics, running_cost, terminal_cost, x0, us, params):
    """Validate a batch: ``x0`` (B, n), ``us`` (B, N, m), every leaf of ``params`` with leading axis B."""
    check_callables(dynamics, running_cost, terminal_cost)
    x0, us = _array("x0", x0), _array("us", us)
    if x0.ndim != 2 or x0.shape[0] < 1 or x0.shape[1] < 1:
        raise ValueError(f"x0 must have shape (B, n) for a batch, got {x0.shape}")
    if us.ndim != 3 or us.shape[0] != x0.shape[0] or us.shape[1] < 1 or us.shape[2] < 1:
        raise ValueError(f"us must have shape (B, N, m) with B = {x0.shape[0]} problems, got {us.shape}")
    if not np.all(np.isfinite(x0)):
        raise ValueError("x0 must be finite")
    if not np.all(np.isfinite(us)):
        raise ValueError("us must be finite")
    for leaf in jax.tree_util.tree_leaves(params):
        if np.ndim(leaf) < 1 or np.shape(leaf)[0] != x0.shape[0]:
            raise ValueError(f"every leaf of params must have a leading batch axis of length {x0.shape[0]}, "
                             f"got shape {np.shape(leaf)}")
    _check_outputs(dynamics, running_cost, terminal_cost, x0.shape[1], us.shape[2],
                   *params_signature(params, batch=True))
    return x0, us
