"""Avoid value functions of eq. (4.3) for the Dubins car family, and a library of them over w_max.

``V(x) = lim_{T -> inf} V(x, -T)`` is computed with hj-reachability (backward reachable tube,
``min(0, H)`` Hamiltonian) by stepping in chunks of ``SolverSpec.chunk_time`` until no value
changes by more than ``SolverSpec.tolerance`` over a chunk (the time-invariant limit of Sec. 4.2).
The grid is ``[-L, L]^2`` around the obstacle centre times ``theta`` in ``[-pi, pi)``, periodic.

One solver is compiled per (grid, accuracy) with ``w_max`` a traced argument, so a library over
``w_max`` (Fig. 4.2) compiles once; ``batch="vmap"`` advances all members together (for a GPU),
``batch="loop"`` one after another (faster on a small CPU). Every member is cached on disk under
``mutual.cache.cache_dir() / "reachability"``, keyed by everything that changes it.

Interpolation is trilinear and vectorised in numpy (periodic in theta); outside the (x, y)
domain it returns ``fill_value`` (NaN unless asked otherwise).
"""

import functools
import hashlib
import json
from dataclasses import dataclass, field

import hj_reachability as hj
import jax
import jax.numpy as jnp
import jaxlib
import numpy as np
from tqdm import tqdm

from .. import __version__
from ..atomic import atomic_path
from .dubins import SPEED, DubinsCar, _check_positive, check_states, unsafe_reach
from ..cache import cache_dir

ACCURACIES = ("low", "medium", "high", "very_high")
_CACHE_FORMAT = 1


@dataclass(frozen=True)
class GridSpec:
    """The state grid: ``(x, y)`` in ``[-half_width, half_width]^2``, ``theta`` periodic in ``[-pi, pi)``."""
    half_width: float = 8.0
    shape: tuple = (101, 101, 64)

    def __post_init__(self):
        _check_positive("half_width", self.half_width)
        shape = tuple(self.shape)
        if len(shape) != 3 or any(int(n) != n or n < 5 for n in shape):
            raise ValueError(f"shape must be three integers >= 5 (nx, ny, ntheta), got {self.shape!r}")
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

    def build(self):
        """The hj-reachability ``Grid`` (theta periodic)."""
        return _hj_grid(self)


FULL_GRID = GridSpec()
QUICK_GRID = GridSpec(8.0, (41, 41, 24))


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
            _check_positive(name, getattr(self, name))


@functools.lru_cache(maxsize=None)
def _hj_grid(spec):
    domain = hj.sets.Box(jnp.array([-spec.half_width, -spec.half_width, -np.pi]),
                         jnp.array([spec.half_width, spec.half_width, np.pi]))
    return hj.Grid.from_lattice_parameters_and_boundary_conditions(domain, spec.shape, periodic_dims=2)


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
    """Step V(x, t) backwards in chunks until max |dV| < tolerance; return (values (b, ...), times (b,))."""
    l0 = _initial_values(spec, radius)
    groups = [np.asarray(w_maxes)] if batch == "vmap" else [np.array([w]) for w in w_maxes]
    out, times = [], []
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
                if change < solver.tolerance:
                    break
                if -t >= solver.max_time:
                    raise RuntimeError(f"V did not converge for w_max in {group.tolist()} within max_time="
                                       f"{solver.max_time} s (last max |dV| {change:.3g} > tolerance "
                                       f"{solver.tolerance}); raise max_time or enlarge the grid")
            values = np.asarray(values, dtype=np.float32).reshape((len(group),) + spec.shape)
            out.extend(values)
            times.extend([-t] * len(group))
            bar.update(len(group))
    return out, times


def _versions():
    return {"jax": jax.__version__, "jaxlib": jaxlib.__version__, "hj_reachability": hj.__version__,
            "numpy": np.__version__, "mutual": __version__}


def cache_key(w_max, radius, speed, d_max, spec, solver):
    """Hex digest of everything that changes a member: dynamics, obstacle, grid, solver, package versions."""
    payload = {"format": _CACHE_FORMAT, "w_max": float(w_max), "radius": float(radius), "speed": float(speed),
               "d_max": float(d_max), "grid": [float(spec.half_width), list(spec.shape)],
               "solver": [solver.accuracy, float(solver.chunk_time), float(solver.tolerance),
                          float(solver.max_time)], "versions": _versions()}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()[:20]


def _cache_file(key):
    return cache_dir() / "reachability" / f"avoid-{key}.npz"


@dataclass(frozen=True, eq=False)
class ValueFunction:
    """A converged avoid value function V(x) on a grid (eq. 4.3, T -> inf), with interpolation and control."""
    w_max: float
    obstacle_radius: float
    grid_spec: GridSpec
    values: np.ndarray
    speed: float = SPEED
    d_max: float = 0.0
    horizon: float = float("nan")
    dvalues_dtheta: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        values = np.asarray(self.values, dtype=np.float32)
        if values.shape != self.grid_spec.shape:
            raise ValueError(f"values must have the grid's shape {self.grid_spec.shape}, got {values.shape}")
        dtheta = (np.roll(values, -1, axis=2) - np.roll(values, 1, axis=2)) / (2 * self.grid_spec.spacings[2])
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "dvalues_dtheta", dtheta.astype(np.float32))

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
        _check_positive("u_max", u_max)
        return np.where(self.interp_dtheta(states, fill_value=0.0) >= 0, u_max, -u_max)

    def safe_set(self, level=0.0):
        """Boolean grid of the safe set at ``level``, ``{x : V(x) >= level}`` (Omega at level 0)."""
        return self.values >= level

    def theta_slice(self, theta, resolution=201):
        """``(xs, ys, V)`` on a regular (x, y) mesh at heading ``theta`` (V indexed [y, x], for contour plots)."""
        w = self.grid_spec.half_width
        xs = ys = np.linspace(-w, w, resolution)
        gx, gy = np.meshgrid(xs, ys)
        states = np.stack([gx.ravel(), gy.ravel(), np.full(gx.size, float(theta))], axis=1)
        return xs, ys, self.interp(states).reshape(gx.shape)


def _interpolate(spec, flat_values, states, fill_value):
    """Trilinear interpolation of each row of ``flat_values`` (b, nx*ny*nt) at ``states`` -> (b, n)."""
    s = check_states(states)
    nx, ny, nt = spec.shape
    pos = (s - spec.lo) / spec.spacings
    ix = np.clip(np.floor(pos[:, 0]).astype(int), 0, nx - 2)
    iy = np.clip(np.floor(pos[:, 1]).astype(int), 0, ny - 2)
    it = np.floor(pos[:, 2]).astype(int)
    wx, wy, wt = pos[:, 0] - ix, pos[:, 1] - iy, pos[:, 2] - it
    it0, it1 = it % nt, (it + 1) % nt
    result = 0.0
    for dx, fx in ((0, 1 - wx), (1, wx)):
        for dy, fy in ((0, 1 - wy), (1, wy)):
            base = ((ix + dx) * ny + iy + dy) * nt
            result = result + fx * fy * ((1 - wt) * flat_values[:, base + it0] + wt * flat_values[:, base + it1])
    inside = np.all(np.abs(s[:, :2]) <= spec.half_width, axis=1)
    return np.where(inside, result, fill_value)


@dataclass(frozen=True, eq=False)
class ValueLibrary:
    """The library ``{V_i}`` of eq. (4.12) over ``w_max`` (Fig. 4.2), all on one grid."""
    members: tuple
    flat_values: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        if not self.members:
            raise ValueError("members must hold at least one ValueFunction")
        specs = {(m.grid_spec, m.obstacle_radius, m.speed, m.d_max) for m in self.members}
        if len(specs) != 1:
            raise ValueError("members must share one grid, obstacle radius, speed and disturbance bound")
        object.__setattr__(self, "members", tuple(self.members))
        object.__setattr__(self, "flat_values", np.stack([m.values.ravel() for m in self.members]))

    @property
    def w_maxes(self):
        return np.array([m.w_max for m in self.members])

    @property
    def grid_spec(self):
        return self.members[0].grid_spec

    @property
    def obstacle_radius(self):
        return self.members[0].obstacle_radius

    def __len__(self):
        return len(self.members)

    def __getitem__(self, i):
        return self.members[i]

    def __iter__(self):
        return iter(self.members)

    def index_of(self, w_max):
        """Index of the member with this ``w_max`` (ValueError if none within 1e-9)."""
        i = int(np.argmin(np.abs(self.w_maxes - w_max)))
        if abs(self.w_maxes[i] - w_max) > 1e-9:
            raise ValueError(f"w_max={w_max!r} is not in the library {self.w_maxes.tolist()}")
        return i

    def interp(self, i, states, fill_value=np.nan):
        """V_i at states (n, 3) -> (n,)."""
        return self.members[i].interp(states, fill_value)

    def interp_all(self, states, fill_value=np.nan):
        """Every member at states (n, 3) -> (b, n), sharing the interpolation weights."""
        return _interpolate(self.grid_spec, self.flat_values, states, fill_value)


def unsafe_set_contains(outer, inner, level=0.0):
    """Whether ``{V_inner < 0}`` lies inside ``{V_outer < level}`` at every grid node.

    ``level = 0``: the conservativeness prior of Sec. 4.4 (on the Dubins family it holds for
    ``w_outer <= w_inner``). ``level = mu``: eq. (4.4) for a supervisor ``V_S = outer`` with margin
    ``mu``, i.e. ``Omega_S`` inside ``Omega``.
    """
    if outer.grid_spec != inner.grid_spec:
        raise ValueError("outer and inner must share one grid_spec")
    return bool(np.all(outer.values[inner.values < 0] < level))


def _check_domain(w_maxes, radius, speed, spec):
    need = unsafe_reach(float(np.min(w_maxes)), radius, speed) + 4 * spec.spacings[0]
    if spec.half_width < need:
        raise ValueError(f"grid_spec.half_width={spec.half_width} is too small: the unsafe set of w_max="
                         f"{np.min(w_maxes):g} reaches {unsafe_reach(float(np.min(w_maxes)), radius, speed):.3g} "
                         f"from the obstacle centre; need at least {need:.3g} (reach + 4 cells)")


def value_library(w_maxes, obstacle_radius, grid_spec=FULL_GRID, solver=SolverSpec(), speed=SPEED, d_max=0.0,
                  batch="loop", cache=True, progress=True):
    """Converged avoid value functions for each ``w_max`` (one compiled solver; disk cache; progress bar).

    ``batch``: "loop" (members one after another; fastest on a small CPU) or "vmap" (all together, for
    a GPU). Cached members load from disk; only missing ones are computed.
    """
    w = np.asarray(w_maxes, dtype=float)
    if w.ndim != 1 or len(w) == 0 or not np.all(np.isfinite(w)) or np.any(w <= 0):
        raise ValueError(f"w_maxes must be a non-empty 1-D sequence of positive finite numbers, got {w_maxes!r}")
    if len(np.unique(w)) != len(w):
        raise ValueError(f"w_maxes must not repeat values, got {w.tolist()}")
    _check_positive("obstacle_radius", obstacle_radius)
    _check_positive("speed", speed)
    if not np.isfinite(d_max) or d_max < 0:
        raise ValueError(f"d_max must be a non-negative finite number, got {d_max!r}")
    if batch not in ("loop", "vmap"):
        raise ValueError(f"batch must be 'loop' or 'vmap', got {batch!r}")
    if not isinstance(grid_spec, GridSpec) or not isinstance(solver, SolverSpec):
        raise ValueError("grid_spec must be a GridSpec and solver a SolverSpec")
    _check_domain(w, obstacle_radius, speed, grid_spec)

    keys = {wi: cache_key(wi, obstacle_radius, speed, d_max, grid_spec, solver) for wi in w}
    found = {}
    if cache:
        for wi, key in keys.items():
            if _cache_file(key).exists():
                with np.load(_cache_file(key)) as f:
                    found[wi] = (f["values"], float(f["horizon"]))
    missing = [wi for wi in w if wi not in found]
    if missing:
        values, horizons = _converge(missing, obstacle_radius, speed, d_max, grid_spec, solver, batch, progress)
        for wi, v, h in zip(missing, values, horizons):
            found[wi] = (v, h)
            if cache:
                with atomic_path(_cache_file(keys[wi])) as tmp:
                    np.savez(tmp, values=v, horizon=h)
    members = tuple(ValueFunction(float(wi), float(obstacle_radius), grid_spec, found[wi][0], float(speed),
                                  float(d_max), found[wi][1]) for wi in w)
    return ValueLibrary(members)


def avoid_value_function(w_max, obstacle_radius, grid_spec=FULL_GRID, solver=SolverSpec(), speed=SPEED, d_max=0.0,
                         cache=True, progress=True):
    """The converged avoid value function V of eq. (4.3) for one Dubins car (see ``value_library``)."""
    return value_library([w_max], obstacle_radius, grid_spec, solver, speed, d_max, cache=cache,
                         progress=progress)[0]
