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

import numpy as np
import pandas as pd

from ..atomic import atomic_path
from .dubins import SPEED, _check_positive, check_states
from .reachability import ValueFunction

REQUIRED_COLUMNS = ("participant", "trial", "time", "x", "y", "theta")
OPTIONAL_COLUMNS = ("obstacle_x", "obstacle_y")


def _wrap(theta):
    return (np.asarray(theta, dtype=float) + np.pi) % (2 * np.pi) - np.pi


# ---------------------------------------------------------------------------- Sec. 4.3: the supervisor

@dataclass(frozen=True, eq=False)
class NoisySupervisor:
    """Intervenes when ``V_S(x) + w <= mu``, ``w ~ N(0, sigma^2)`` per safety judgement (Sec. 4.3).

    States outside the value function's grid are judged safe (far from the obstacle).
    """
    value_fn: ValueFunction
    mu: float
    sigma: float

    def __post_init__(self):
        if not isinstance(self.value_fn, ValueFunction):
            raise ValueError("value_fn must be a mutual.supervision.reachability.ValueFunction")
        if not np.isfinite(self.mu):
            raise ValueError(f"mu must be finite, got {self.mu!r}")
        if not np.isfinite(self.sigma) or self.sigma < 0:
            raise ValueError(f"sigma must be a non-negative finite number, got {self.sigma!r}")

    def thresholds(self, n, rng):
        """``n`` judgement levels ``mu - w`` (intervene when ``V_S(x) <= level``)."""
        return self.mu - self.sigma * rng.standard_normal(n)

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
        thresholds = np.broadcast_to(np.asarray(thresholds, dtype=float), (len(s),))
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


def approach_scenes(n, rng, obstacle_radius, start_distance, speed=SPEED, dt=0.02):
    """``n`` Phase II scenes (Sec. 5.2.1): a car drives straight at the obstacle and would crash.

    Each starts ``start_distance`` from the obstacle centre at a uniform bearing, aimed at a point
    uniformly within 0.9 of the obstacle radius sideways of the centre; returns (n, T, 3) states
    sampled every ``dt`` until the car would reach the centre's distance.
    """
    _check_positive("obstacle_radius", obstacle_radius)
    _check_positive("start_distance", start_distance)
    _check_positive("dt", dt)
    if start_distance <= obstacle_radius:
        raise ValueError(f"start_distance={start_distance} must exceed obstacle_radius={obstacle_radius}")
    if int(n) != n or n < 1:
        raise ValueError(f"n must be a positive integer, got {n!r}")
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

def validate_interventions(frame):
    """Check an interventions table (module docstring) and return a clean copy (types, wrapped theta)."""
    if not isinstance(frame, pd.DataFrame):
        raise ValueError("interventions must be a pandas DataFrame")
    missing = [c for c in REQUIRED_COLUMNS if c not in frame.columns]
    if missing:
        raise ValueError(f"interventions lack the columns {missing} (required: {list(REQUIRED_COLUMNS)})")
    extra = [c for c in frame.columns if c not in REQUIRED_COLUMNS + OPTIONAL_COLUMNS]
    if extra:
        raise ValueError(f"interventions have unknown columns {extra}")
    out = pd.DataFrame({"participant": frame["participant"].astype(str)})
    if frame["participant"].isna().any() or (out["participant"].str.len() == 0).any():
        raise ValueError("interventions column 'participant' has empty entries")
    trial = pd.to_numeric(frame["trial"], errors="coerce")
    if trial.isna().any() or (trial < 0).any() or (trial != np.round(trial)).any():
        raise ValueError("interventions column 'trial' must hold non-negative integers")
    out["trial"] = trial.astype(int)
    for col in ("time", "x", "y", "theta") + OPTIONAL_COLUMNS:
        vals = pd.to_numeric(frame[col], errors="coerce") if col in frame else pd.Series(0.0, index=frame.index)
        if not np.all(np.isfinite(vals.to_numpy(dtype=float))):
            raise ValueError(f"interventions column {col!r} must hold finite numbers")
        out[col] = vals.astype(float)
    if (out["time"] < 0).any():
        raise ValueError("interventions column 'time' must be non-negative")
    out["theta"] = _wrap(out["theta"])
    return out.reset_index(drop=True)


def read_interventions(path):
    """Read and validate an interventions CSV."""
    return validate_interventions(pd.read_csv(path, dtype={"participant": str}))


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
