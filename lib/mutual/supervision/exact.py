"""Exact values where a closed form exists: the Dubins avoid value of a disk without disturbance,
evaluated at the states themselves rather than interpolated from a grid (so that our numerics are
never the thesis's fault), and the grid's error measured against it.

:class:`ExactValueFunction` has the interface of :class:`~mutual.supervision.value_function.ValueFunction`
(its grid values are the closed form at the nodes, for plots and set tests) but ``interp``,
``interp_dtheta`` and so ``safe_control`` evaluate the closed form exactly (dV/dtheta by a central
difference), so every simulation, supervisor and fit that takes a value function can run on exact
values. :func:`grid_error` says how far a grid's interpolated values are from the exact ones at given
states: trilinear interpolation across the kink of V in theta (head-on, where turning left and right
are equally good) overestimates V by up to |dV/dtheta| dtheta / 2.
"""

from dataclasses import dataclass

import numpy as np

from ..inputs import positive
from .dubins import check_states, closed_form_dtheta, closed_form_values
from .value_function import FULL_GRID, GridSpec, ValueFunction, ValueLibrary, trilinear


@dataclass(frozen=True, eq=False, repr=False)
class ExactValueFunction(ValueFunction):
    """The closed-form avoid value (no disturbance), exact at every state; ``fill_value`` off the grid's
    (x, y) domain, as for the grid's value functions."""

    exact = True

    def __repr__(self):
        return "Exact" + super().__repr__().replace(", method='closed-form'", ", exact closed form")

    def _params(self):
        return self.speed / self.w_max, self.obstacle_radius

    def interp(self, states, fill_value=np.nan):
        s = check_states(states)
        v = closed_form_values(s[:, 0], s[:, 1], s[:, 2], *self._params())
        return np.where(self.inside(s), v, fill_value)

    def interp_dtheta(self, states, fill_value=np.nan):
        s = check_states(states)
        d = closed_form_dtheta(s[:, 0], s[:, 1], s[:, 2], *self._params())
        return np.where(self.inside(s), d, fill_value)


def exact_value_function(w_max, radius, grid_spec=FULL_GRID, speed=None):
    """The exact value function of the Dubins car with turn rate ``w_max`` around a disk of ``radius``."""
    from .dubins import SPEED

    speed = SPEED if speed is None else positive("speed", speed)
    if not isinstance(grid_spec, GridSpec):
        raise ValueError(f"grid_spec must be a GridSpec, got {type(grid_spec).__name__}")
    nodes = grid_spec.nodes
    values = closed_form_values(nodes[:, 0], nodes[:, 1], nodes[:, 2], speed / positive("w_max", w_max),
                                positive("radius", radius)).reshape(grid_spec.shape)
    return ExactValueFunction(float(w_max), float(radius), grid_spec, values, speed=speed, method="closed-form")


def exact_library(w_maxes, radius, grid_spec=FULL_GRID):
    """A library (eq. 4.12) of exact value functions over ``w_maxes``."""
    return ValueLibrary(tuple(exact_value_function(w, radius, grid_spec) for w in w_maxes))


def has_closed_form(value_fn):
    """Whether the closed form gives ``value_fn``'s exact values: a Dubins avoid value with no disturbance."""
    return isinstance(value_fn, ValueFunction) and value_fn.d_max == 0


def exact_counterpart(value_fn):
    """The exact value function with ``value_fn``'s turn rate, obstacle radius, speed and grid (a ValueError
    where no closed form exists: a disturbance)."""
    if not has_closed_form(value_fn):
        raise ValueError(f"value_fn: no closed form for a value function with a disturbance (d_max = {value_fn.d_max:g})")
    if getattr(value_fn, "exact", False):
        return value_fn
    return exact_value_function(value_fn.w_max, value_fn.obstacle_radius, value_fn.grid_spec, value_fn.speed)


def grid_error(value_fn, states, exact=None):
    """How far ``value_fn``'s interpolated values are from the exact ones at ``states`` (n, 3): a dict of
    ``bias`` (mean of grid - exact), ``rms`` and ``max`` (largest |error|), in the value's units. ``exact``
    defaults to :func:`exact_counterpart`; for a value function with a disturbance, pass the exact value of
    the same car without it to measure the grid's interpolation error alone."""
    s = check_states(states)
    exact = exact_counterpart(value_fn) if exact is None else exact
    err = value_fn.interp(s) - exact.interp(s)
    err = err[np.isfinite(err)]
    if err.size == 0:
        raise ValueError("states: none lies on the grid")
    return {"bias": float(err.mean()), "rms": float(np.sqrt(np.mean(err ** 2))), "max": float(np.abs(err).max())}


def interpolated_closed_form(grid_spec, states, turn_radius, radius):
    """The closed form sampled at the grid's nodes around each state and interpolated trilinearly (as a grid
    value function would be): its difference from the exact value is the grid's interpolation error alone."""
    xs, ys, ts = grid_spec.coordinate_vectors
    return trilinear(grid_spec, check_states(states),
                     lambda ix, iy, it: closed_form_values(xs[ix], ys[iy], ts[it], turn_radius, radius))
