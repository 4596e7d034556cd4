"""Avoid value functions of eq. (4.3) for the Dubins car family, and a library of them over w_max.

``V(x) = lim_{T -> inf} V(x, -T)`` is computed with hj-reachability (backward reachable tube,
``min(0, H)`` Hamiltonian) by stepping in chunks of ``SolverSpec.chunk_time`` until no value
changes by more than ``SolverSpec.tolerance`` over a chunk (the time-invariant limit of Sec. 4.2).
Without a disturbance the exact value is also available in closed form (``method="closed-form"``).

One solver is compiled per (grid, accuracy) with ``w_max`` a traced argument, so a library over
``w_max`` (Fig. 4.2) compiles once; ``batch="vmap"`` advances all members together (for a GPU),
``batch="loop"`` one after another (faster on a small CPU). Every member is cached on disk
(:mod:`.value_cache`: keyed by everything that changes it, checksummed, verified on load, saved as
soon as it converges). The grid, the value function and the library are in :mod:`.value_function`.
"""

import functools
import hashlib
import inspect
import platform
import textwrap
from dataclasses import dataclass

import hj_reachability as hj
import jax
import jax.numpy as jnp
import jaxlib
import numpy as np
import pandas as pd
from tqdm import tqdm

from .. import __version__, budget
from ..dubins import DubinsCar, avoid_value
from ..inputs import positive, real
from . import value_cache, value_function
from .dubins import SPEED, unsafe_reach
from .value_function import (FULL_GRID, METHODS, QUICK_GRID, GridSpec, ValueFunction, ValueLibrary,  # noqa: F401
                             unsafe_set_contains)

PLAUSIBLE_REACH_CELLS = 1.0   # a cached member's head-on reach must match the closed form within this many cells

ACCURACIES = ("low", "medium", "high", "very_high")


@dataclass(frozen=True)
class SolverSpec:
    """How V is computed: hj-reachability accuracy, chunk length (s), convergence tolerance, time cap (s)."""
    accuracy: str = "low"
    chunk_time: float = 0.5
    tolerance: float = 2e-3
    max_time: float = 60.0

    def __post_init__(self):
        if self.accuracy not in ACCURACIES:
            raise ValueError(f"accuracy must be one of {ACCURACIES}, got {self.accuracy!r}")
        for name in ("chunk_time", "tolerance", "max_time"):
            positive(name, getattr(self, name))


@functools.lru_cache(maxsize=None)
def _chunk_stepper(spec, accuracy, batched):
    """A compiled ``advance(w_max, d_max, speed, values, t0, t1)``; ``w_max`` is traced (vmapped if batched)."""
    grid = spec.build()
    settings = hj.SolverSettings.with_accuracy(accuracy,
                                               hamiltonian_postprocessor=hj.solver.backwards_reachable_tube)

    def advance(w_max, d_max, speed, values, t0, t1):
        return hj.step(settings, DubinsCar(w_max, speed, d_max), grid, t0, values, t1, progress_bar=False)

    if batched:
        advance = jax.vmap(advance, in_axes=(0, None, None, 0, None, None))
    return jax.jit(advance)


def _initial_values(spec, radius):
    states = spec.build().states
    return jnp.hypot(states[..., 0], states[..., 1]) - radius


def _converge(w_maxes, radius, speed, d_max, spec, solver, batch, progress):
    """Step V(x, t) backwards in chunks until max |dV| < tolerance; yield ``(w_max, values, horizon)``
    for each member as soon as it (or, with ``batch="vmap"``, its whole batch) has converged."""
    l0 = _initial_values(spec, radius)
    groups = [np.asarray(w_maxes)] if batch == "vmap" else [np.array([w]) for w in w_maxes]
    with tqdm(total=len(w_maxes), desc="avoid value functions", unit="member", disable=not progress) as bar:
        for group in groups:
            stepper = _chunk_stepper(spec, solver.accuracy, batch == "vmap")
            w = jnp.asarray(group if batch == "vmap" else group[0], dtype=jnp.float32)
            values = jnp.broadcast_to(l0, (len(group),) + l0.shape) if batch == "vmap" else l0
            t = 0.0
            while True:
                new = stepper(w, d_max, speed, values, t, t - solver.chunk_time)
                change = float(jnp.max(jnp.abs(new - values)))
                values, t = new, t - solver.chunk_time
                bar.set_postfix(w_max=f"{group.min():.3g}", horizon=f"{-t:.1f}s", change=f"{change:.1e}")
                if not np.isfinite(change):
                    raise RuntimeError(f"the HJ solver produced NaN or infinite values for w_max in {group.tolist()}")
                if change < solver.tolerance:
                    break
                if -t >= solver.max_time:
                    raise RuntimeError(f"V did not converge for w_max in {group.tolist()} within max_time="
                                       f"{solver.max_time} s (last max |dV| {change:.3g} > tolerance "
                                       f"{solver.tolerance}); raise max_time or enlarge the grid")
            values = np.asarray(values, dtype=np.float32).reshape((len(group),) + spec.shape)
            bar.update(len(group))
            for wi, v in zip(group, values):
                yield float(wi), v, -t


@functools.lru_cache(maxsize=None)
def solver_code_version():
    """SHA-256 (16 hex digits) of the source of everything that computes a member's values: the
    dynamics, the grid, the initial values, the compiled step and the convergence loop. Part of the
    cache key, so that a change to the solver's code never serves values of the old code."""
    parts = (DubinsCar, value_function.GridSpec, value_function._hj_grid, _chunk_stepper, _initial_values, _converge)
    digest = hashlib.sha256()
    for part in parts:   # dedented: DubinsCar is defined inside mutual.dubins._hj_face (loaded on first use)
        digest.update(textwrap.dedent(inspect.getsource(inspect.unwrap(part))).encode())
    return digest.hexdigest()[:16]


def _versions():
    return {"jax": jax.__version__, "jaxlib": jaxlib.__version__, "hj_reachability": hj.__version__,
            "numpy": np.__version__, "mutual": __version__, "python": platform.python_version(),
            "solver_code": solver_code_version()}


def cache_params(w_max, radius, speed, d_max, spec, solver):
    """Everything that makes a member's values (stored in its cache file and checked on load)."""
    return value_cache.cache_params(w_max, radius, speed, d_max, spec, solver, _versions())


def cache_key(w_max, radius, speed, d_max, spec, solver):
    """Hex digest of everything that makes a member: dynamics, obstacle, grid, solver, versions, solver code."""
    return value_cache.cache_key(w_max, radius, speed, d_max, spec, solver, _versions())


def plausibility_check(w_max, radius, speed, d_max, spec):
    """A check of cached values against the physics, independent of the file's own records: the unsafe
    set's head-on reach must match the closed form ``sqrt(2 R r + r^2)`` within ``PLAUSIBLE_REACH_CELLS``
    grid cells (a disturbance only enlarges it: then it must not fall short). Catches another member's
    values stored under this member's key, parameters and a recomputed checksum."""
    expected = unsafe_reach(w_max, radius, speed)
    tolerance = PLAUSIBLE_REACH_CELLS * spec.spacings[0]

    def check(values):
        reach = ValueFunction(w_max, radius, spec, values, speed, d_max).head_on_reach()
        if reach < expected - tolerance or (d_max == 0 and reach > expected + tolerance):
            raise ValueError(f"its unsafe set reaches {reach:.3f} ahead of the obstacle, where w_max={w_max:g}, "
                             f"radius {radius:g} give {expected:.3f} (closed form; tolerance {tolerance:.3f}): "
                             "these are another member's values")
    return check


def _check_domain(w_maxes, radius, speed, spec):
    reach = unsafe_reach(float(np.min(w_maxes)), radius, speed)
    need = reach + 4 * spec.spacings[0]
    if spec.half_width < need:
        room = spec.half_width - 4 * spec.spacings[0]      # reach = sqrt(2 (v / w) r + r^2) <= room, solved for w
        fits = f"the smallest w_max it holds is {2 * speed * radius / (room ** 2 - radius ** 2):.3g}" \
            if room > radius else "no w_max fits: the obstacle itself is wider than the grid"
        raise ValueError(f"grid_spec.half_width={spec.half_width} is too small: the unsafe set of w_max="
                         f"{np.min(w_maxes):g} (obstacle radius {radius:g}, speed {speed:g}) reaches {reach:.3g} "
                         f"from the obstacle centre; need at least {need:.3g} (reach + 4 cells); at this radius "
                         f"and speed {fits}")


def _check_library_args(w_maxes, obstacle_radius, grid_spec, solver, speed, d_max, batch, method):
    if isinstance(w_maxes, (str, bytes)) or np.ndim(w_maxes) != 1:
        raise ValueError(f"w_maxes must be a non-empty 1-D sequence of positive finite numbers, got {w_maxes!r}")
    try:
        w = np.asarray(w_maxes, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"w_maxes must be a non-empty 1-D sequence of positive finite numbers, "
                         f"got {w_maxes!r}") from None
    if len(w) == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ValueError(f"w_maxes must be a non-empty 1-D sequence of positive finite numbers, got {w_maxes!r}")
    if len(np.unique(w)) != len(w):
        raise ValueError(f"w_maxes must not repeat values, got {w.tolist()}")
    positive("obstacle_radius", obstacle_radius)
    positive("speed", speed)
    if real(d_max) is None or not np.isfinite(real(d_max)) or d_max < 0:
        raise ValueError(f"d_max must be a non-negative finite number, got {d_max!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if method == "closed-form" and d_max > 0:
        raise ValueError(f"method='closed-form' is exact only without a disturbance (d_max=0), got d_max={d_max!r}; "
                         "use method='hj' (the HJI solver) for a disturbed car")
    if batch not in ("loop", "vmap"):
        raise ValueError(f"batch must be 'loop' or 'vmap', got {batch!r}")
    if not isinstance(grid_spec, GridSpec):
        raise ValueError(f"grid_spec must be a GridSpec, got {type(grid_spec).__name__}")
    if not isinstance(solver, SolverSpec):
        raise ValueError(f"solver must be a SolverSpec, got {type(solver).__name__}")
    _check_domain(w, obstacle_radius, speed, grid_spec)
    return w


def closed_form_values(w_max, obstacle_radius, grid_spec, speed=SPEED, tol=1e-9):
    """The exact avoid value of eq. (4.3) (no disturbance) at every node of ``grid_spec``, float32:
    :func:`mutual.dubins.avoid_value` broadcast over the grid's axes (x, y, theta)."""
    big_r = positive("speed", speed) / positive("w_max", w_max)
    radius = positive("obstacle_radius", obstacle_radius)
    xs, ys, ts = grid_spec.coordinate_vectors
    return avoid_value(xs[:, None, None], ys[None, :, None], ts[None, None, :], big_r, radius, tol).astype(np.float32)


def value_library(w_maxes, obstacle_radius, grid_spec=FULL_GRID, solver=SolverSpec(), speed=SPEED, d_max=0.0,
                  batch="loop", cache=True, progress=True, method="hj", allow_large=None):
    """Converged avoid value functions of eq. (4.3) for each ``w_max`` (Fig. 4.2, the library of eq. 4.12).

    ``method="hj"`` (default; the thesis's method, Sec. 5.2.1): hj-reachability, one compiled solver
    for the whole family, disk cache, progress bar. ``batch``: "loop" (members one after another;
    fastest on a small CPU) or "vmap" (all together, for a GPU). Cached members that verify load
    from disk; missing or damaged ones are computed and each is saved as soon as it converges.

    ``method="closed-form"``: the exact value of :func:`~mutual.supervision.dubins.avoid_value_closed_form`
    at the grid nodes, for trying things out (no solver, no cache; the whole library in about a
    second). Only without a disturbance: ``d_max > 0`` is refused (the HJI solver is the only method then).

    ``allow_large``: as :func:`mutual.budget.check`: the library's memory is checked before anything is
    loaded, and the time of the members to compute before any is solved.
    """
    w = _check_library_args(w_maxes, obstacle_radius, grid_spec, solver, speed, d_max, batch, method)
    budget.check(budget.value_library(len(w), grid_spec.shape, len(w) if method == "closed-form" else 0, method),
                 allow_large)
    if method == "closed-form":
        members = tuple(ValueFunction(float(wi), float(obstacle_radius), grid_spec,
                                      closed_form_values(wi, obstacle_radius, grid_spec, speed), float(speed), 0.0,
                                      float("inf"), method) for wi in w)
        return ValueLibrary(members)
    params = {wi: cache_params(wi, obstacle_radius, speed, d_max, grid_spec, solver) for wi in w}
    keys = {wi: cache_key(wi, obstacle_radius, speed, d_max, grid_spec, solver) for wi in w}
    found = {}
    if cache:
        for wi, key in keys.items():
            check = plausibility_check(wi, obstacle_radius, speed, d_max, grid_spec)
            stored = value_cache.load_member(key, grid_spec.shape, params[wi], check)
            if stored is not None:
                found[wi] = stored
    missing = [wi for wi in w if wi not in found]
    budget.check(budget.value_library(len(w), grid_spec.shape, len(missing), method), allow_large)
    if missing:
        for wi, v, h in _converge(missing, obstacle_radius, speed, d_max, grid_spec, solver, batch, progress):
            found[wi] = (v, h)
            if cache:
                value_cache.save_member(keys[wi], v, h, params[wi])
    members = tuple(ValueFunction(float(wi), float(obstacle_radius), grid_spec, found[wi][0], float(speed),
                                  float(d_max), found[wi][1], method) for wi in w)
    return ValueLibrary(members)


def avoid_value_function(w_max, obstacle_radius, grid_spec=FULL_GRID, solver=SolverSpec(), speed=SPEED, d_max=0.0,
                         cache=True, progress=True, method="hj"):
    """The converged avoid value function V of eq. (4.3) for one Dubins car (see ``value_library``)."""
    if real(w_max) is None:
        raise ValueError(f"w_max must be a positive finite number, got {w_max!r}")
    return value_library([w_max], obstacle_radius, grid_spec, solver, speed, d_max, cache=cache,
                         progress=progress, method=method)[0]


def value_drift(value_fn, extra_time, solver=SolverSpec()):
    """How much a converged HJ value function still changes when the horizon grows by ``extra_time`` s.

    Steps ``value_fn.values`` backwards another ``extra_time`` seconds with the same dynamics and
    returns ``(max |dV| over the safe set {V >= 0}, max |dV| over all nodes)``: Sec. 4.2's claim that
    V becomes independent of t as T -> inf, measured.
    """
    if not isinstance(value_fn, ValueFunction) or value_fn.method != "hj":
        raise ValueError("value_fn must be a ValueFunction computed with method='hj'")
    positive("extra_time", extra_time)
    if not isinstance(solver, SolverSpec):
        raise ValueError(f"solver must be a SolverSpec, got {type(solver).__name__}")
    stepper = _chunk_stepper(value_fn.grid_spec, solver.accuracy, False)
    values, t = jnp.asarray(value_fn.values), -value_fn.horizon
    n_chunks = int(np.ceil(extra_time / solver.chunk_time))
    for _ in range(n_chunks):
        values = stepper(jnp.float32(value_fn.w_max), value_fn.d_max, value_fn.speed, values, t,
                         t - solver.chunk_time)
        t -= solver.chunk_time
    change = np.abs(np.asarray(values) - value_fn.values)
    return float(change[value_fn.values >= 0].max(initial=0.0)), float(change.max())


def closed_form_agreement(library, near_cells=2.0):
    """Where HJ value functions and the exact closed form disagree, member by member (no disturbance).

    Returns a DataFrame with, per ``w_max``: ``mean_abs_error_cells`` (mean ``|V_hj - V_exact|`` over
    nodes within ``near_cells`` grid cells of the exact zero level set, in cells), ``max_abs_error_cells``
    (there), ``sign_mismatch_nodes`` and ``sign_mismatch_fraction`` (nodes judged safe by one and unsafe by
    the other) and ``farthest_mismatch_cells`` (how far from the exact zero level such a node lies).
    """
    if not isinstance(library, ValueLibrary) or library.method != "hj":
        raise ValueError("library must be a ValueLibrary computed with method='hj'")
    if library.members[0].d_max > 0:
        raise ValueError("the closed form has no disturbance: library must have d_max = 0")
    positive("near_cells", near_cells)
    spec, dx = library.grid_spec, library.grid_spec.spacings[0]
    rows = []
    for vf in library:
        exact = closed_form_values(vf.w_max, vf.obstacle_radius, spec, vf.speed)
        near = np.abs(exact) < near_cells * dx
        err = np.abs(vf.values - exact)[near] / dx
        flipped = (vf.values < 0) != (exact < 0)
        rows.append({"w_max": vf.w_max, "mean_abs_error_cells": float(err.mean()),
                     "max_abs_error_cells": float(err.max()), "sign_mismatch_nodes": int(flipped.sum()),
                     "sign_mismatch_fraction": float(flipped.mean()),
                     "farthest_mismatch_cells": float(np.abs(exact[flipped]).max(initial=0.0) / dx)})
    return pd.DataFrame(rows)
