"""Value functions on a grid: the state grid, one converged avoid value function ``V(x)`` of
eq. (4.3) with interpolation and its optimal control, and the library ``{V_i}`` of eq. (4.12).

The grid is ``[-L, L]^2`` around the obstacle centre times ``theta`` in ``[-pi, pi)``, periodic.
Interpolation is trilinear and vectorised in numpy (periodic in theta); outside the (x, y)
domain it returns ``fill_value`` (NaN unless asked otherwise). How the values are computed
(hj-reachability or the closed form) is in :mod:`.reachability`.
"""

import functools
import numbers
from dataclasses import dataclass, field

import numpy as np

from ..inputs import finite, positive, real
from .dubins import SPEED, check_states

METHODS = ("hj", "closed-form")


def _fmt(x):
    return f"{x:.4g}"


@dataclass(frozen=True)
class GridSpec:
    """The state grid: ``(x, y)`` in ``[-half_width, half_width]^2``, ``theta`` periodic in ``[-pi, pi)``."""
    half_width: float = 8.0
    shape: tuple = (101, 101, 64)

    def __post_init__(self):
        positive("half_width", self.half_width)
        if isinstance(self.shape, (str, bytes)) or not hasattr(self.shape, "__len__"):
            raise ValueError(f"shape must be three integers >= 5 (nx, ny, ntheta), got {self.shape!r}")
        shape = tuple(self.shape)
        if len(shape) != 3 or any(isinstance(n, bool) or not isinstance(n, numbers.Real) or int(n) != n or n < 5
                                  for n in shape):
            raise ValueError(f"shape must be three integers >= 5 (nx, ny, ntheta), got {self.shape!r}")
        object.__setattr__(self, "half_width", float(self.half_width))
        object.__setattr__(self, "shape", tuple(int(n) for n in shape))

    @property
    def lo(self):
        return np.array([-self.half_width, -self.half_width, -np.pi])

    @property
    def spacings(self):
        nx, ny, nt = self.shape
        return np.array([2 * self.half_width / (nx - 1), 2 * self.half_width / (ny - 1), 2 * np.pi / nt])

    @property
    def coordinate_vectors(self):
        """The grid's x, y and theta nodes (numpy)."""
        nx, ny, nt = self.shape
        w = self.half_width
        return np.linspace(-w, w, nx), np.linspace(-w, w, ny), -np.pi + 2 * np.pi * np.arange(nt) / nt

    @property
    def nodes(self):
        """Every grid node as an ``(nx * ny * nt, 3)`` array of states, in the order of ``values.ravel()``."""
        xs, ys, ts = self.coordinate_vectors
        return np.stack(np.meshgrid(xs, ys, ts, indexing="ij"), -1).reshape(-1, 3)

    def build(self):
        """The hj-reachability ``Grid`` (theta periodic)."""
        return _hj_grid(self)

    def describe(self):
        """A short text, e.g. ``101x101x64 on [-8, 8]^2``."""
        return "x".join(map(str, self.shape)) + f" on [-{self.half_width:g}, {self.half_width:g}]^2"


@functools.lru_cache(maxsize=None)
def _hj_grid(spec):
    import hj_reachability as hj
    import jax.numpy as jnp

    domain = hj.sets.Box(jnp.array([-spec.half_width, -spec.half_width, -np.pi]),
                         jnp.array([spec.half_width, spec.half_width, np.pi]))
    return hj.Grid.from_lattice_parameters_and_boundary_conditions(domain, spec.shape, periodic_dims=2)


FULL_GRID = GridSpec()
QUICK_GRID = GridSpec(8.0, (41, 41, 24))


@dataclass(frozen=True, eq=False, repr=False)
class ValueFunction:
    """A converged avoid value function V(x) on a grid (eq. 4.3, T -> inf), with interpolation and control.

    ``method`` says how the values were computed: ``"hj"`` (hj-reachability) or ``"closed-form"``
    (the exact value of :func:`mutual.supervision.dubins.avoid_value_closed_form` at the nodes).
    The full arrays stay available as ``values`` and ``dvalues_dtheta``.
    """
    w_max: float
    obstacle_radius: float
    grid_spec: GridSpec
    values: np.ndarray
    speed: float = SPEED
    d_max: float = 0.0
    horizon: float = float("nan")
    method: str = "hj"
    dvalues_dtheta: np.ndarray = field(init=False)
    exact = False  # True for :class:`mutual.supervision.exact.ExactValueFunction` (no interpolation)

    def __post_init__(self):
        if not isinstance(self.grid_spec, GridSpec):
            raise ValueError(f"grid_spec must be a GridSpec, got {type(self.grid_spec).__name__}")
        positive("w_max", self.w_max)
        positive("obstacle_radius", self.obstacle_radius)
        positive("speed", self.speed)
        if real(self.d_max) is None or not np.isfinite(real(self.d_max)) or self.d_max < 0:
            raise ValueError(f"d_max must be a non-negative finite number, got {self.d_max!r}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {METHODS}, got {self.method!r}")
        values = np.asarray(self.values, dtype=np.float32)
        if values.shape != self.grid_spec.shape:
            raise ValueError(f"values must have the grid's shape {self.grid_spec.shape}, got {values.shape}")
        if not np.all(np.isfinite(values)):
            raise ValueError(f"values contain {int(np.sum(~np.isfinite(values)))} NaN or infinite entries")
        dtheta = (np.roll(values, -1, axis=2) - np.roll(values, 1, axis=2)) / (2 * self.grid_spec.spacings[2])
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "dvalues_dtheta", dtheta.astype(np.float32))

    def __repr__(self):
        disturbance = f", d_max={_fmt(self.d_max)}" if self.d_max else ""
        horizon = f", horizon={_fmt(self.horizon)} s" if np.isfinite(self.horizon) else ""
        return (f"ValueFunction(w_max={_fmt(self.w_max)}, obstacle_radius={_fmt(self.obstacle_radius)}, "
                f"speed={_fmt(self.speed)}{disturbance}, method={self.method!r}, grid {self.grid_spec.describe()}"
                f"{horizon}, unsafe fraction {np.mean(self.values < 0):.3f})")

    def inside(self, states):
        """Whether each state's (x, y) lies in the grid's domain (theta is periodic)."""
        s = check_states(states)
        return np.all(np.abs(s[:, :2]) <= self.grid_spec.half_width, axis=1)

    def interp(self, states, fill_value=np.nan):
        """V at states (n, 3) -> (n,), trilinear; ``fill_value`` outside the (x, y) domain."""
        return _interpolate(self.grid_spec, self.values.reshape(1, -1), states, fill_value)[0]

    def interp_dtheta(self, states, fill_value=np.nan):
        """dV/dtheta at states (n, 3) -> (n,) (central differences on the grid, then trilinear)."""
        return _interpolate(self.grid_spec, self.dvalues_dtheta.reshape(1, -1), states, fill_value)[0]

    def safe_control(self, states, u_max=None):
        """The optimal avoid control ``u* = u_max sign(dV/dtheta)`` (Sec. 4.2; ties turn left).

        ``u_max`` defaults to this model's ``w_max``; a robot whose true turn rate differs passes its own.
        """
        u_max = self.w_max if u_max is None else u_max
        positive("u_max", u_max)
        return np.where(self.interp_dtheta(states, fill_value=0.0) >= 0, u_max, -u_max)

    def safe_set(self, level=0.0):
        """Boolean grid of the safe set at ``level``, ``{x : V(x) >= level}`` (Omega at level 0)."""
        return self.values >= finite("level", level)

    def theta_slice(self, theta, resolution=201):
        """``(xs, ys, V)`` on a regular (x, y) mesh at heading ``theta`` (V indexed [y, x], for contour plots)."""
        theta = finite("theta", theta)
        if isinstance(resolution, bool) or not isinstance(resolution, numbers.Integral) or resolution < 2:
            raise ValueError(f"resolution must be an integer >= 2, got {resolution!r}")
        w = self.grid_spec.half_width
        xs = ys = np.linspace(-w, w, resolution)
        gx, gy = np.meshgrid(xs, ys)
        states = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, theta)], axis=1)
        return xs, ys, self.interp(states).reshape(gx.shape)

    def head_on_reach(self, level=0.0):
        """How far ahead of the obstacle centre ``{V < level}`` reaches for a car heading straight at it
        (``theta = 0`` on the negative x axis), from the grid nodes linearly interpolated along x.

        For the Dubins car without disturbance at ``level = 0`` this is ``sqrt(2 R r + r^2)``, ``R = v / w_max``.
        """
        level = finite("level", level)
        xs, _, _ = self.grid_spec.coordinate_vectors
        ahead = xs <= 0
        states = np.stack([xs[ahead], np.zeros(ahead.sum()), np.zeros(ahead.sum())], axis=1)
        v = self.interp(states) - level
        unsafe = np.flatnonzero(v < 0)
        if len(unsafe) == 0:
            return 0.0
        i = unsafe[0]
        if i == 0:
            return float(-xs[0])
        x0, x1, v0, v1 = xs[i - 1], xs[i], v[i - 1], v[i]
        return float(-(x0 + (x1 - x0) * v0 / (v0 - v1)))


def trilinear(spec, states, node_values):
    """Trilinear interpolation on the grid ``spec`` at ``states`` (n, 3) (checked), periodic in theta: the
    eight nodes around each state weighted by their distances, ``node_values(ix, iy, it)`` giving the values
    at nodes (index arrays of n). Outside the (x, y) domain it extrapolates from the border cells."""
    nx, ny, nt = spec.shape
    pos = (states - spec.lo) / spec.spacings
    ix = np.clip(np.floor(pos[:, 0]).astype(int), 0, nx - 2)
    iy = np.clip(np.floor(pos[:, 1]).astype(int), 0, ny - 2)
    it = np.floor(pos[:, 2]).astype(int)
    wx, wy, wt = pos[:, 0] - ix, pos[:, 1] - iy, pos[:, 2] - it
    it0, it1 = it % nt, (it + 1) % nt
    result = 0.0
    for dx, fx in ((0, 1 - wx), (1, wx)):
        for dy, fy in ((0, 1 - wy), (1, wy)):
            result = result + fx * fy * ((1 - wt) * node_values(ix + dx, iy + dy, it0)
                                         + wt * node_values(ix + dx, iy + dy, it1))
    return result


def _interpolate(spec, flat_values, states, fill_value):
    """Trilinear interpolation of each row of ``flat_values`` (b, nx*ny*nt) at ``states`` -> (b, n)."""
    s = check_states(states)
    _, ny, nt = spec.shape
    result = trilinear(spec, s, lambda ix, iy, it: flat_values[:, (ix * ny + iy) * nt + it])
    inside = np.all(np.abs(s[:, :2]) <= spec.half_width, axis=1)
    return np.where(inside, result, fill_value)


@dataclass(frozen=True, eq=False, repr=False)
class ValueLibrary:
    """The library ``{V_i}`` of eq. (4.12) over ``w_max`` (Fig. 4.2), all on one grid.

    The stacked values stay available as ``flat_values`` (b, nodes); the members as ``members``.
    """
    members: tuple
    flat_values: np.ndarray = field(init=False)

    def __post_init__(self):
        members = tuple(self.members) if isinstance(self.members, (list, tuple)) else None
        if not members:
            raise ValueError("members must be a non-empty list or tuple of ValueFunction")
        if not all(isinstance(m, ValueFunction) for m in members):
            raise ValueError("members must all be mutual.supervision.ValueFunction")
        specs = {(m.grid_spec, m.obstacle_radius, m.speed, m.d_max, m.method, m.exact) for m in members}
        if len(specs) != 1:
            raise ValueError("members must share one grid, obstacle radius, speed, disturbance bound and method "
                             "(all exact or none)")
        w = np.array([m.w_max for m in members])
        if len(np.unique(w)) != len(w):
            raise ValueError(f"members must have distinct w_max, got {w.tolist()}")
        object.__setattr__(self, "members", members)
        object.__setattr__(self, "flat_values", np.stack([m.values.ravel() for m in members]))

    def __repr__(self):
        w = self.w_maxes
        first = self.members[0]
        span = _fmt(w[0]) if len(w) == 1 else f"{_fmt(w.min())}..{_fmt(w.max())}"
        return (f"ValueLibrary({len(self)} members, w_max {span}, obstacle_radius={_fmt(self.obstacle_radius)}, "
                f"speed={_fmt(first.speed)}, method={first.method!r}, grid {self.grid_spec.describe()})")

    @property
    def w_maxes(self):
        return np.array([m.w_max for m in self.members])

    @property
    def grid_spec(self):
        return self.members[0].grid_spec

    @property
    def obstacle_radius(self):
        return self.members[0].obstacle_radius

    @property
    def method(self):
        return self.members[0].method

    def __len__(self):
        return len(self.members)

    def __getitem__(self, i):
        return self.members[i]

    def __iter__(self):
        return iter(self.members)

    def index_of(self, w_max):
        """Index of the member with this ``w_max`` (ValueError if none within 1e-9)."""
        w_max = finite("w_max", w_max)
        i = int(np.argmin(np.abs(self.w_maxes - w_max)))
        if abs(self.w_maxes[i] - w_max) > 1e-9:
            raise ValueError(f"w_max={w_max!r} is not in the library {self.w_maxes.tolist()}")
        return i

    def interp(self, i, states, fill_value=np.nan):
        """V_i at states (n, 3) -> (n,)."""
        return self.members[i].interp(states, fill_value)

    def interp_all(self, states, fill_value=np.nan):
        """Every member at states (n, 3) -> (b, n), sharing the interpolation weights (exact members:
        each evaluated exactly)."""
        if self.members[0].exact:
            return np.stack([m.interp(states, fill_value) for m in self.members])
        return _interpolate(self.grid_spec, self.flat_values, states, fill_value)


def boundary_values(value_fn, n_points=36, n_headings=72):
    """V on the boundary of the keep-out disk, ``|p| = r`` (line 862: the zero level set and the boundary of H),
    at ``n_points`` positions around it and ``n_headings`` headings at each: ``(values, approaching)``, arrays of
    shape (n_points, n_headings) from ``value_fn.interp`` (exact for an exact value function). ``approaching``
    marks the headings that point into the disk (``p . h < 0``); the headings sit half a step off the tangents,
    so none is exactly tangent."""
    if not isinstance(value_fn, ValueFunction):
        raise ValueError(f"value_fn must be a ValueFunction, got {type(value_fn).__name__}")
    for name, n in (("n_points", n_points), ("n_headings", n_headings)):
        if isinstance(n, bool) or not isinstance(n, numbers.Integral) or n < 2:
            raise ValueError(f"{name} must be an integer >= 2, got {n!r}")
    around = 2 * np.pi * np.arange(n_points) / n_points
    offset = np.tile(2 * np.pi * (np.arange(n_headings) + 0.5) / n_headings, n_points)  # from the outward normal
    position = np.repeat(around, n_headings)
    r = value_fn.obstacle_radius
    states = np.stack([r * np.cos(position), r * np.sin(position), np.remainder(position + offset + np.pi, 2 * np.pi) - np.pi], 1)
    shape = (n_points, n_headings)
    return value_fn.interp(states).reshape(shape), (np.cos(offset) < 0).reshape(shape)


def unsafe_set_contains(outer, inner, level=0.0):
    """Whether ``{V_inner < 0}`` lies inside ``{V_outer < level}`` at every grid node.

    ``level = 0``: the conservativeness prior of Sec. 4.4 (on the Dubins family it holds for
    ``w_outer <= w_inner``). ``level = mu``: eq. (4.4) for a supervisor ``V_S = outer`` with margin
    ``mu``, i.e. ``Omega_S`` inside ``Omega``.
    """
    if not isinstance(outer, ValueFunction) or not isinstance(inner, ValueFunction):
        raise ValueError("outer and inner must both be mutual.supervision.ValueFunction")
    level = finite("level", level)
    if outer.grid_spec != inner.grid_spec:
        raise ValueError("outer and inner must share one grid_spec")
    return bool(np.all(outer.values[inner.values < 0] < level))
