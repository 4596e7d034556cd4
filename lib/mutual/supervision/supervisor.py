"""The noisy idealized supervisor (Sec. 4.3), the approach scenes it watches, and the
interventions CSV it produces. Its maximum-likelihood safe set is in :mod:`.fit` (Sec. 4.4), the
minimally invasive controller on a learned safe set in :mod:`.control` (Sec. 4.5).

States are ``(x, y, theta)`` relative to the obstacle centre unless ``obstacles`` are given.

Interventions CSV (one row per intervention; ``read_interventions`` / ``write_interventions``):

=============  ======  =========================================================================
column         type    meaning
=============  ======  =========================================================================
participant    str     participant id (e.g. "P01" or "sim-03")
trial          int     scene / trial number within the participant's session (>= 0)
time           float   seconds since the trial started when the supervisor intervened (>= 0)
x, y           float   robot position at the intervention (same units as the obstacle radius)
theta          float   robot heading (rad), any real value (wrapped to [-pi, pi) on reading)
obstacle_x     float   centre of the obstacle the robot approached (optional, default 0)
obstacle_y     float   (optional, default 0)
=============  ======  =========================================================================
"""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from ..inputs import angle_unit_warning, count, name_column, number_column, place, positive, read_csv, real, warn
from .dubins import SPEED, check_states, wrap_angle
from .value_function import ValueFunction

REQUIRED_COLUMNS = ("participant", "trial", "time", "x", "y", "theta")
OPTIONAL_COLUMNS = ("obstacle_x", "obstacle_y")


_wrap = wrap_angle


def _check_rng(rng):
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got {rng!r}")
    return rng


# ---------------------------------------------------------------------------- Sec. 4.3: the supervisor

@dataclass(frozen=True, eq=False, repr=False)
class NoisySupervisor:
    """Intervenes when ``V_S(x) + w <= mu``, ``w ~ N(0, sigma^2)`` per safety judgement (Sec. 4.3).

    States outside the value function's grid are judged safe (far from the obstacle).
    """
    value_fn: ValueFunction
    mu: float
    sigma: float

    def __post_init__(self):
        if not isinstance(self.value_fn, ValueFunction):
            raise ValueError("value_fn must be a mutual.supervision.ValueFunction")
        mu, sigma = real(self.mu), real(self.sigma)
        if mu is None or not np.isfinite(mu):
            raise ValueError(f"mu must be a finite number, got {self.mu!r}")
        if sigma is None or not np.isfinite(sigma) or sigma < 0:
            raise ValueError(f"sigma must be a non-negative finite number, got {self.sigma!r}")
        object.__setattr__(self, "mu", mu)
        object.__setattr__(self, "sigma", sigma)

    def __repr__(self):
        vf = self.value_fn
        return (f"NoisySupervisor(w_max={vf.w_max:.4g}, mu={self.mu:.4g}, sigma={self.sigma:.4g}; value function: "
                f"{vf.method}, obstacle_radius={vf.obstacle_radius:.4g}, grid {vf.grid_spec.describe()})")

    def thresholds(self, n, rng):
        """``n`` judgement levels ``mu - w`` (intervene when ``V_S(x) <= level``)."""
        n = count("n", n, low=0)
        return self.mu - self.sigma * _check_rng(rng).standard_normal(n)

    def intervenes(self, states, rng=None, thresholds=None):
        """Whether the supervisor intervenes at each state (n, 3) -> bool (n,).

        With ``thresholds`` (one per state, e.g. one draw per robot-obstacle encounter) those levels
        are used; otherwise a fresh ``w`` is drawn per state from ``rng``.
        """
        s = check_states(states)
        if thresholds is None:
            if rng is None:
                raise ValueError("intervenes needs rng (fresh noise per judgement) or thresholds")
            thresholds = self.thresholds(len(s), rng)
        try:
            thresholds = np.broadcast_to(np.asarray(thresholds, dtype=float), (len(s),))
        except (TypeError, ValueError):
            raise ValueError(f"thresholds must be one number or one per state ({len(s)}), got "
                             f"shape {np.shape(thresholds)}") from None
        if np.isnan(thresholds).any():
            raise ValueError("thresholds contain NaN")
        return self.value_fn.interp(s, fill_value=np.inf) <= thresholds

    def first_interventions(self, trajectories, rng):
        """Where the supervisor first intervenes on each trajectory (k, T, 3), one judgement per scene.

        Draws one level ``mu - w`` per scene and returns ``(states (m, 3), scene index (m,))`` for the
        scenes whose value crosses it; the state is interpolated linearly between time steps at the
        crossing, so that ``V_S`` at it equals the level up to interpolation error.
        """
        traj = np.asarray(trajectories, dtype=float)
        if traj.ndim != 3 or traj.shape[2] != 3 or traj.shape[1] < 2:
            raise ValueError(f"trajectories must have shape (k, T >= 2, 3), got {traj.shape}")
        if not np.all(np.isfinite(traj)):
            raise ValueError("trajectories contain NaN or infinite entries")
        _check_rng(rng)
        k, t_len, _ = traj.shape
        values = self.value_fn.interp(traj.reshape(-1, 3), fill_value=np.inf).reshape(k, t_len)
        levels = self.thresholds(k, rng)
        below = values <= levels[:, None]
        hit = below.any(axis=1) & ~below[:, 0]
        scenes = np.flatnonzero(hit)
        j = below[scenes].argmax(axis=1)
        v0, v1 = values[scenes, j - 1], values[scenes, j]
        frac = ((v0 - levels[scenes]) / (v0 - v1))[:, None]
        a, b = traj[scenes, j - 1], traj[scenes, j]
        dtheta = _wrap(b[:, 2] - a[:, 2])
        states = a + frac * np.concatenate([b[:, :2] - a[:, :2], dtheta[:, None]], axis=1)
        states[:, 2] = _wrap(states[:, 2])
        return states, scenes


def collect_interventions(supervisor, n, rng, start_distance, dt=0.02, batch=None, max_scenes=None):
    """The first ``n`` intervention states (n, 3) of ``supervisor`` watching Phase II ``approach_scenes``.

    Scenes are drawn in batches of ``batch`` (default ``2 n``) until ``n`` interventions are collected;
    raises a ValueError (rather than looping forever) if ``max_scenes`` (default ``50 n``) scenes give fewer.
    """
    if not isinstance(supervisor, NoisySupervisor):
        raise ValueError("supervisor must be a mutual.supervision.NoisySupervisor")
    n = count("n", n)
    batch = 2 * n if batch is None else count("batch", batch)
    max_scenes = 50 * n if max_scenes is None else count("max_scenes", max_scenes)
    states, watched = np.empty((0, 3)), 0
    while len(states) < n:
        if watched >= max_scenes:
            raise ValueError(f"the supervisor intervened only {len(states)} times in {watched} scenes (need n={n}): "
                             f"with mu={supervisor.mu:g}, sigma={supervisor.sigma:g} it rarely judges an approach "
                             "unsafe")
        size = min(batch, max_scenes - watched)
        more, _ = supervisor.first_interventions(
            approach_scenes(size, rng, supervisor.value_fn.obstacle_radius, start_distance, dt=dt), rng)
        states, watched = np.vstack([states, more]), watched + size
    return states[:n]


def approach_scenes(n, rng, obstacle_radius, start_distance, speed=SPEED, dt=0.02):
    """``n`` Phase II scenes (Sec. 5.2.1): a car drives straight at the obstacle and would crash.

    Each starts ``start_distance`` from the obstacle centre at a uniform bearing, aimed at a point
    uniformly within 0.9 of the obstacle radius sideways of the centre; returns (n, T, 3) states
    sampled every ``dt`` until the car would reach the centre's distance.
    """
    n = count("n", n)
    _check_rng(rng)
    positive("obstacle_radius", obstacle_radius)
    positive("start_distance", start_distance)
    positive("speed", speed)
    positive("dt", dt)
    if start_distance <= obstacle_radius:
        raise ValueError(f"start_distance={start_distance} must exceed obstacle_radius={obstacle_radius}")
    bearing = rng.uniform(-np.pi, np.pi, n)
    start = start_distance * np.stack([np.cos(bearing), np.sin(bearing)], axis=1)
    offset = 0.9 * obstacle_radius * rng.uniform(-1, 1, n)
    aim = offset[:, None] * np.stack([-np.sin(bearing), np.cos(bearing)], axis=1)
    heading = np.arctan2(aim[:, 1] - start[:, 1], aim[:, 0] - start[:, 0])
    steps = int(np.ceil(start_distance / (speed * dt)))
    t = dt * np.arange(steps + 1)
    xy = start[:, None, :] + speed * t[None, :, None] * np.stack([np.cos(heading), np.sin(heading)], 1)[:, None]
    return np.concatenate([xy, np.broadcast_to(heading[:, None, None], (n, steps + 1, 1))], axis=2)


# ---------------------------------------------------------------------------- the interventions CSV

def _named(frame, source):
    """``frame`` named for :func:`mutual.inputs.place`: by its file and lines if read from a file, else ``source``."""
    if frame.attrs.get("source") is None:
        frame = frame.copy()
        frame.attrs["name"] = str(source) if source is not None else "interventions"
    return frame


def validate_interventions(frame, source=None):
    """Check an interventions table (module docstring) and return a clean copy (types, wrapped theta).

    Errors name the table -- its file and line for a table read by :func:`read_interventions`, else
    ``source`` (default "interventions") and the row label -- and the column. Headings that look like
    degrees (values far beyond a turn) are warned about (:func:`mutual.inputs.angle_unit_warning`).
    """
    if not isinstance(frame, pd.DataFrame):
        raise ValueError(f"{source or 'interventions'}: interventions must be a pandas DataFrame, got "
                         f"{type(frame).__name__}")
    frame = _named(frame.set_axis([str(c) for c in frame.columns], axis=1), source)
    columns = list(frame.columns)
    where = place(frame)
    missing = [c for c in REQUIRED_COLUMNS if c not in columns]
    if missing:
        raise ValueError(f"{where}: missing column{'s' if len(missing) > 1 else ''} {', '.join(map(repr, missing))} "
                         f"(required: {', '.join(REQUIRED_COLUMNS)}; optional: {', '.join(OPTIONAL_COLUMNS)})")
    extra = [c for c in columns if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    if extra:
        raise ValueError(f"{where}: unknown column{'s' if len(extra) > 1 else ''} {', '.join(map(repr, extra))} "
                         f"(allowed: {', '.join(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)})")
    if len(set(columns)) != len(columns):
        raise ValueError(f"{where}: repeated column names {columns}")
    if len(frame) == 0:
        raise ValueError(f"{where}: holds no interventions (a header but no rows)")
    out = pd.DataFrame({"participant": name_column(frame, "participant")}, index=frame.index)
    out["trial"] = number_column(frame, "trial", whole=True, low=0, what="a non-negative integer").astype(int)
    out["time"] = number_column(frame, "time", low=0, what="a non-negative number of seconds (since the scene "
                                                            "started)")
    for col in ("x", "y", "theta") + OPTIONAL_COLUMNS:
        out[col] = number_column(frame, col) if col in frame else 0.0
    unit = angle_unit_warning(out["theta"].to_numpy(), f"{where}, column 'theta' (the heading, radians)")
    if unit:
        warn(unit)
    out["theta"] = _wrap(out["theta"])
    out.attrs.update({k: frame.attrs[k] for k in ("source", "lines", "name") if k in frame.attrs})
    return out


def check_inside(frame, half_width, source=None):
    """Refuse an interventions table (as :func:`validate_interventions` returns it) with a row outside
    the value functions' grid, ``|x - obstacle_x|, |y - obstacle_y| <= half_width``: the error names
    the first such row, its line of the file and its position as the file writes it."""
    dx, dy = (frame["x"] - frame["obstacle_x"]).to_numpy(), (frame["y"] - frame["obstacle_y"]).to_numpy()
    outside = np.flatnonzero(np.maximum(np.abs(dx), np.abs(dy)) > half_width)
    if len(outside):
        i = outside[0]
        row = frame.iloc[i]
        at = f"x = {row['x']:g}, y = {row['y']:g}"
        centre = f" around the obstacle at ({row['obstacle_x']:g}, {row['obstacle_y']:g})" if (
            row["obstacle_x"] or row["obstacle_y"]) else ""
        more = f" ({len(outside) - 1} more rows like it)" if len(outside) > 1 else ""
        raise ValueError(f"{place(_named(frame, source), frame.index[i])}: the intervention at {at} lies outside the "
                         f"value functions' grid, |x - obstacle_x|, |y - obstacle_y| <= {half_width:g}{centre}{more}")


def read_interventions(path):
    """Read and validate an interventions CSV (module docstring; :func:`mutual.inputs.read_csv`); errors name
    the file, the line and the column."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such interventions file")
    return validate_interventions(read_csv(path))


def write_interventions(frame, path):
    """Validate and atomically write an interventions CSV."""
    clean = validate_interventions(frame)
    with atomic_path(path) as tmp:
        clean.to_csv(tmp, index=False, float_format="%.6g")
    return path


def intervention_states(frame):
    """The (n, 3) states of an interventions table, relative to each row's obstacle centre."""
    clean = validate_interventions(frame)
    return np.stack([clean["x"] - clean["obstacle_x"], clean["y"] - clean["obstacle_y"], clean["theta"]], axis=1)
