"""The noisy idealized supervisor (Sec. 4.3), its maximum-likelihood safe set (Sec. 4.4) and the
minimally invasive safety controller on a learned safe set (Sec. 4.5).

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

import functools
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .atomic import atomic_path
from .dubins import SPEED, TRUE_W_MAX, _check_positive, check_states, dubins_step
from .reachability import ValueFunction, ValueLibrary, unsafe_set_contains

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
            raise ValueError("value_fn must be a mutual.reachability.ValueFunction")
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


# ---------------------------------------------------------------------------- Sec. 4.4: the estimator

@dataclass(frozen=True, eq=False)
class SupervisorFit:
    """The fitted supervisor: the chosen member (eq. 4.12) with its ``mu*``, ``sigma*`` (eq. 4.8).

    Per-member arrays: ``mus``, ``sigmas`` and ``logliks`` (log of eq. 4.9; ``-inf`` where the
    prior excludes the member), ``admissible`` (the prior's support).
    """
    library: ValueLibrary
    index: int
    mus: np.ndarray
    sigmas: np.ndarray
    logliks: np.ndarray
    admissible: np.ndarray
    n: int
    prior: str

    @property
    def w_max(self):
        return float(self.library.w_maxes[self.index])

    @property
    def mu(self):
        return float(self.mus[self.index])

    @property
    def sigma(self):
        return float(self.sigmas[self.index])

    @property
    def loglik(self):
        return float(self.logliks[self.index])

    @property
    def value_fn(self):
        return self.library[self.index]

    def level(self, k=2.0):
        """The control level ``alpha = mu + k sigma`` of Sec. 4.5."""
        return self.mu + k * self.sigma

    def coverage(self, states, k=2.0):
        """Fraction of intervention ``states`` at or below ``alpha = mu + k sigma`` of the fitted member:
        the interventions a robot avoiding at ``alpha`` keeps clear of (Sec. 4.5; ~Phi(k) in expectation)."""
        return float(np.mean(self.value_fn.interp(states) <= self.level(k)))


def gaussian_mle(values):
    """Eq. (4.8)-(4.9) per row of ``values`` (b, p): ``mu*``, ``sigma*`` and ``log L*``."""
    v = np.asarray(values, dtype=float)
    mu = v.mean(axis=-1)
    var = v.var(axis=-1)
    return mu, np.sqrt(var), _max_loglik(var, v.shape[-1])


def _max_loglik(var, p):
    """``log L*`` of eq. (4.9): with ``sigma^2`` the mean squared deviation, the exponent is ``-p/2``."""
    return -0.5 * p * (np.log(2 * np.pi * var) + 1)


@functools.lru_cache(maxsize=32)
def _conservative_members(library, reference):
    return np.array([unsafe_set_contains(member, reference) for member in library])


def fit_supervisor(library, states, prior="mle", reference=None):
    """Fit the supervisor's safe set to intervention ``states`` (n, 3): eq. (4.8), (4.9), (4.12).

    ``prior="mle"``: the argmax of the maximised likelihood over the library. ``prior="map"``: the MAP
    estimate of Sec. 4.4 -- only members whose unsafe sets contain the ``reference`` (true dynamics;
    default the library member with ``w_max = 1``) unsafe set, and ``mu* = max(mu*, 0)`` with
    ``sigma*^2`` the mean squared deviation about it. Raises ValueError for fewer than two
    interventions, NaN, states outside the grid, or zero variance (an unbounded likelihood).
    """
    if not isinstance(library, ValueLibrary):
        raise ValueError("library must be a mutual.reachability.ValueLibrary")
    if prior not in ("mle", "map"):
        raise ValueError(f"prior must be 'mle' or 'map', got {prior!r}")
    s = check_states(states)
    if len(s) < 2:
        raise ValueError(f"states must hold at least two interventions to estimate mu and sigma, got {len(s)}")
    values = library.interp_all(s)
    outside = np.isnan(values[0])
    if outside.any():
        raise ValueError(f"{outside.sum()} intervention states lie outside the library's grid "
                         f"(|x|, |y| <= {library.grid_spec.half_width}), e.g. {s[outside][0].tolist()}")
    mus = values.mean(axis=1)
    if prior == "map":
        reference = library[library.index_of(TRUE_W_MAX)] if reference is None else reference
        admissible = _conservative_members(library, reference)
        if not admissible.any():
            raise ValueError("no library member's unsafe set contains the reference unsafe set (MAP prior empty)")
        mus = np.maximum(mus, 0.0)
    else:
        admissible = np.ones(len(library), dtype=bool)
    var = np.mean((values - mus[:, None]) ** 2, axis=1)
    if np.any(var[admissible] <= 0):
        bad = library.w_maxes[admissible & (var <= 0)]
        raise ValueError(f"interventions have zero variance under w_max={bad.tolist()}: the likelihood is "
                         "unbounded; states must be distinct")
    with np.errstate(divide="ignore"):
        logliks = np.where(admissible, _max_loglik(var, len(s)), -np.inf)
    return SupervisorFit(library, int(np.argmax(logliks)), mus, np.sqrt(var), logliks, admissible, len(s), prior)


# ---------------------------------------------------------------------------- Sec. 4.5: the controller

def _obstacle_frame(value_fn, states, obstacles):
    """Per robot: the state relative to its most dangerous obstacle, and V there."""
    s = check_states(states)
    if obstacles is None:
        return s, value_fn.interp(s, fill_value=np.inf)
    centres = np.asarray(obstacles, dtype=float).reshape(-1, 2)
    if len(centres) == 0:
        return s, np.full(len(s), np.inf)
    if not np.all(np.isfinite(centres)):
        raise ValueError("obstacles contains NaN or infinite entries")
    rel = np.repeat(s[:, None, :], len(centres), axis=1)
    rel[:, :, :2] -= centres[None]
    v = value_fn.interp(rel.reshape(-1, 3), fill_value=np.inf).reshape(len(s), len(centres))
    j = np.argmin(v, axis=1)
    rows = np.arange(len(s))
    return rel[rows, j], v[rows, j]


def _check_alpha(alpha, n):
    a = np.broadcast_to(np.asarray(alpha, dtype=float), (n,))
    if not np.all(np.isfinite(a)):
        raise ValueError(f"alpha must be finite, got {alpha!r}")
    return a


def needs_override(value_fn, states, alpha, obstacles=None):
    """Whether each robot is at or below the ``alpha`` level of ``value_fn`` (bool (n,))."""
    _, v = _obstacle_frame(value_fn, states, obstacles)
    return v <= _check_alpha(alpha, len(v))


def filter_control(value_fn, states, nominal_u, alpha, u_max=None, obstacles=None, lookahead=0.0, speed=SPEED):
    """The minimally invasive control at level ``alpha`` (Sec. 4.2, 4.5), vectorised over robots.

    Each robot keeps its ``nominal_u`` while ``V(x) > alpha`` and applies the optimal safe control
    ``u_max sign(dV/dtheta)`` otherwise (``u_max`` defaults to ``value_fn.w_max``; pass the robot's
    own turn-rate bound when it differs). ``alpha`` may differ per robot. With ``lookahead > 0``
    (a control period, s) a robot also overrides when its nominal control would take it to
    ``V <= alpha`` within that time: the discrete-time version of acting *on* the boundary. With
    ``obstacles`` (k, 2) centres the states are world coordinates and each robot avoids its
    lowest-value obstacle; states off every obstacle's grid keep their nominal control.
    """
    rel, v = _obstacle_frame(value_fn, states, obstacles)
    a = _check_alpha(alpha, len(rel))
    nominal = np.broadcast_to(np.asarray(nominal_u, dtype=float), (len(rel),))
    if not np.all(np.isfinite(nominal)):
        raise ValueError("nominal_u contains NaN or infinite entries")
    if not np.isfinite(lookahead) or lookahead < 0:
        raise ValueError(f"lookahead must be a non-negative finite number of seconds, got {lookahead!r}")
    override = v <= a
    if lookahead > 0:
        ahead = dubins_step(rel, nominal, lookahead, speed)
        override |= value_fn.interp(ahead, fill_value=np.inf) <= a
    return np.where(override, value_fn.safe_control(rel, u_max), nominal)


@dataclass(frozen=True, eq=False)
class SafetyController:
    """A minimally invasive controller at level ``alpha`` of ``value_fn`` (see ``filter_control``)."""
    value_fn: ValueFunction
    alpha: float
    u_max: float = None
    lookahead: float = 0.0

    def __call__(self, states, nominal_u, obstacles=None):
        return filter_control(self.value_fn, states, nominal_u, self.alpha, self.u_max, obstacles, self.lookahead)


def safety_controller(value_fn, alpha, u_max=None, lookahead=0.0):
    """The minimally invasive safety controller at level ``alpha`` (e.g. ``mu + 2 sigma``, Sec. 4.5)."""
    if not isinstance(value_fn, ValueFunction):
        raise ValueError("value_fn must be a mutual.reachability.ValueFunction")
    _check_alpha(alpha, 1)
    if u_max is not None:
        _check_positive("u_max", u_max)
    return SafetyController(value_fn, alpha, u_max, lookahead)


def simulate_filtered(controller, states, nominal_u, duration, dt=0.02, speed=SPEED, obstacles=None):
    """Roll robots forward under ``controller`` with constant ``nominal_u``: states (T+1, n, 3)."""
    _check_positive("duration", duration)
    _check_positive("dt", dt)
    s = check_states(states)
    path = [s]
    for _ in range(int(np.ceil(duration / dt))):
        s = dubins_step(s, controller(s, nominal_u, obstacles), dt, speed)
        path.append(s)
    return np.stack(path)


# ---------------------------------------------------------------------------- studies (simulated)

def recovery_study(library, generators, n_values, seeds, start_distance, prior="mle"):
    """How often the estimator recovers simulated noisy supervisors (Sec. 4.3-4.4).

    ``generators``: ``(w_max, mu, sigma)`` triples (``w_max`` a library member). For each generator
    and seed, a supervisor watches Phase II ``approach_scenes`` until it has intervened
    ``max(n_values)`` times; the fit uses its first ``n`` interventions. One row per
    (generator, seed, n): the estimates and whether ``w_max`` was recovered exactly.
    """
    n_values = sorted(int(n) for n in n_values)
    if not n_values or n_values[0] < 2:
        raise ValueError(f"n_values must be integers >= 2, got {n_values!r}")
    rows = []
    for w_max, mu, sigma in generators:
        sup = NoisySupervisor(library[library.index_of(w_max)], mu, sigma)
        for seed in seeds:
            rng = np.random.default_rng(seed)
            states = np.empty((0, 3))
            while len(states) < n_values[-1]:
                more, _ = sup.first_interventions(
                    approach_scenes(2 * n_values[-1], rng, library.obstacle_radius, start_distance), rng)
                states = np.vstack([states, more])
            for n in n_values:
                fit = fit_supervisor(library, states[:n], prior=prior)
                rows.append({"w_max": w_max, "mu": mu, "sigma": sigma, "seed": seed, "n": n, "w_max_hat": fit.w_max,
                             "mu_hat": fit.mu, "sigma_hat": fit.sigma, "recovered": fit.w_max == w_max})
    return pd.DataFrame(rows)


def false_positive_rates(supervisor, value_fn, alphas, n_robots, rng, start_distance, u_max=TRUE_W_MAX, dt=0.02):
    """Fraction of encounters in which ``supervisor`` intervenes on robots that *did* detect the obstacle.

    Each robot drives straight at the obstacle (``approach_scenes``) under the minimally invasive
    controller at level ``alpha`` of ``value_fn`` (lookahead one step, turn rate ``u_max``) until it
    has passed; the supervisor judges each encounter once (one level ``mu - w``) and intervenes if
    the robot reaches it: every such intervention is a false positive (Sec. 4.5). The same robots and
    judgement levels serve every ``alpha`` (common random numbers). Returns
    ``(rates (len(alphas),), closest margin to K over all robots)``.
    """
    alphas = np.asarray(alphas, dtype=float).reshape(-1)
    radius = value_fn.obstacle_radius
    starts = approach_scenes(n_robots, rng, radius, start_distance, dt=dt)[:, 0]
    states = np.tile(starts, (len(alphas), 1))
    level = np.repeat(alphas, n_robots)
    lowest = supervisor.value_fn.interp(states, fill_value=np.inf)
    closest = np.inf
    for _ in range(int(np.ceil(2 * start_distance / (SPEED * dt)))):
        u = filter_control(value_fn, states, 0.0, level, u_max=u_max, lookahead=dt)
        states = dubins_step(states, u, dt)
        lowest = np.minimum(lowest, supervisor.value_fn.interp(states, fill_value=np.inf))
        closest = min(closest, float(np.min(np.hypot(states[:, 0], states[:, 1]) - radius)))
    judged = lowest.reshape(len(alphas), n_robots) <= supervisor.thresholds(n_robots, rng)
    return judged.mean(axis=1), closest


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
