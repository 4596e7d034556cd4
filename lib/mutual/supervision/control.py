"""Control on a learned safe set (Sec. 4.5): the minimally invasive safety filter that keeps a
robot in ``{V >= alpha}``, and the false-positive rate a supervisor raises against it.

States are ``(x, y, theta)`` relative to the obstacle centre unless ``obstacles`` are given."""

from dataclasses import dataclass

import numpy as np

from ..inputs import count, positive, real
from .dubins import SPEED, TRUE_W_MAX, check_states, dubins_step
from .supervisor import NoisySupervisor, _check_rng, approach_scenes
from .value_function import ValueFunction


def _check_value_fn(value_fn, name="value_fn"):
    if not isinstance(value_fn, ValueFunction):
        raise ValueError(f"{name} must be a mutual.supervision.ValueFunction, got {type(value_fn).__name__}")
    return value_fn


def _check_lookahead(lookahead):
    x = real(lookahead)
    if x is None or not np.isfinite(x) or x < 0:
        raise ValueError(f"lookahead must be a non-negative finite number of seconds, got {lookahead!r}")
    return x


def _obstacle_frame(value_fn, states, obstacles):
    """Per robot: the state relative to its most dangerous obstacle, and V there."""
    _check_value_fn(value_fn)
    s = check_states(states)
    if obstacles is None:
        return s, value_fn.interp(s, fill_value=np.inf)
    try:
        centres = np.asarray(obstacles, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"obstacles must be a (k, 2) array of centres, got {obstacles!r}") from None
    if centres.size and (centres.ndim > 2 or centres.shape[-1] != 2):
        raise ValueError(f"obstacles must be a (k, 2) array of centres, got shape {centres.shape}")
    centres = centres.reshape(-1, 2)
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
    try:
        a = np.broadcast_to(np.asarray(alpha, dtype=float), (n,))
    except (TypeError, ValueError):
        raise ValueError(f"alpha must be one finite number or one per robot ({n}), got {alpha!r}") from None
    if not np.all(np.isfinite(a)):
        raise ValueError(f"alpha must be finite, got {alpha!r}")
    return a


def wilson_interval(rates, n, confidence=0.95):
    """Wilson score interval ``(low, high)`` for observed rates (fractions of ``n`` trials, e.g. the
    false-positive rates of ``n`` robots): the error bars of the chapter 4 figures."""
    from scipy import stats

    n = count("n", n)
    try:
        r = np.atleast_1d(np.asarray(rates, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"rates must be fractions in [0, 1], got {rates!r}") from None
    if not np.all((r >= 0) & (r <= 1)):
        raise ValueError(f"rates must be fractions in [0, 1], got {r.tolist()}")
    c = real(confidence)
    if c is None or not 0 < c < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence!r}")
    ci = [stats.binomtest(int(round(x * n)), n).proportion_ci(confidence_level=c, method="wilson") for x in r]
    return np.array([i.low for i in ci]), np.array([i.high for i in ci])


def binomial_consistent(rates, n, expected, level=1e-4):
    """Whether each observed rate (a fraction of ``n`` independent trials) is consistent with its
    ``expected`` probability: a two-sided exact binomial test does not reject at ``level`` (bool array).
    The check of a simulation against the noise model it simulates (a wrong result fails; a right one
    fails with probability ``level`` per rate)."""
    from scipy import stats

    n = count("n", n)
    r, p = np.broadcast_arrays(np.atleast_1d(np.asarray(rates, dtype=float)),
                               np.atleast_1d(np.asarray(expected, dtype=float)))
    if not np.all((r >= 0) & (r <= 1) & (p >= 0) & (p <= 1)):
        raise ValueError(f"rates and expected must be fractions in [0, 1], got {r.tolist()} and {p.tolist()}")
    return np.array([stats.binomtest(int(round(x * n)), n, q).pvalue >= level for x, q in zip(r, p)])


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
    try:
        nominal = np.broadcast_to(np.asarray(nominal_u, dtype=float), (len(rel),))
    except (TypeError, ValueError):
        raise ValueError(f"nominal_u must be one turn rate or one per robot ({len(rel)}), got {nominal_u!r}") from None
    if not np.all(np.isfinite(nominal)):
        raise ValueError("nominal_u contains NaN or infinite entries")
    lookahead = _check_lookahead(lookahead)
    positive("speed", speed)
    if u_max is not None:
        positive("u_max", u_max)
    override = v <= a
    if lookahead > 0:
        ahead = dubins_step(rel, nominal, lookahead, speed)
        override |= value_fn.interp(ahead, fill_value=np.inf) <= a
    return np.where(override, value_fn.safe_control(rel, u_max), nominal)


@dataclass(frozen=True, eq=False, repr=False)
class SafetyController:
    """A minimally invasive controller at level ``alpha`` of ``value_fn`` (see ``filter_control``)."""
    value_fn: ValueFunction
    alpha: float
    u_max: float = None
    lookahead: float = 0.0

    def __repr__(self):
        u_max = "the model's" if self.u_max is None else f"{self.u_max:.4g}"
        return (f"SafetyController(alpha={self.alpha:.4g}, u_max={u_max}, lookahead={self.lookahead:.4g} s, "
                f"value_fn: w_max={self.value_fn.w_max:.4g}, {self.value_fn.method})")

    def __call__(self, states, nominal_u, obstacles=None):
        return filter_control(self.value_fn, states, nominal_u, self.alpha, self.u_max, obstacles, self.lookahead)


def safety_controller(value_fn, alpha, u_max=None, lookahead=0.0):
    """The minimally invasive safety controller at level ``alpha`` (e.g. ``mu + 2 sigma``, Sec. 4.5)."""
    _check_value_fn(value_fn)
    if np.ndim(alpha) != 0:
        raise ValueError(f"alpha must be one finite number, got {alpha!r}")
    alpha = float(_check_alpha(alpha, 1)[0])
    if u_max is not None:
        u_max = positive("u_max", u_max)
    return SafetyController(value_fn, alpha, u_max, _check_lookahead(lookahead))


def simulate_filtered(controller, states, nominal_u, duration, dt=0.02, speed=SPEED, obstacles=None):
    """Roll robots forward under ``controller`` with constant ``nominal_u``: states (T+1, n, 3)."""
    if not callable(controller):
        raise ValueError(f"controller must be callable as controller(states, nominal_u, obstacles), got {controller!r}")
    positive("duration", duration)
    positive("dt", dt)
    positive("speed", speed)
    s = check_states(states)
    path = [s]
    for _ in range(int(np.ceil(duration / dt))):
        s = dubins_step(s, controller(s, nominal_u, obstacles), dt, speed)
        path.append(s)
    return np.stack(path)


def false_positive_rates(supervisor, value_fn, alphas, n_robots, rng, start_distance, u_max=TRUE_W_MAX, dt=0.02,
                         lowest_values=False):
    """Fraction of encounters in which ``supervisor`` intervenes on robots that *did* detect the obstacle.

    Each robot drives straight at the obstacle (``approach_scenes``) under the minimally invasive
    controller at level ``alpha`` of ``value_fn`` (lookahead one step, turn rate ``u_max``) until it
    has passed; the supervisor judges each encounter once (one level ``mu - w``) and intervenes if
    the robot reaches it: every such intervention is a false positive (Sec. 4.5). The same robots and
    judgement levels serve every ``alpha`` (common random numbers). Returns
    ``(rates (len(alphas),), closest margin to K over all robots)``, and with ``lowest_values=True`` also
    the lowest ``V_S`` each robot reached, ``(len(alphas), n_robots)`` (how far robots dip below a level).
    """
    if not isinstance(supervisor, NoisySupervisor):
        raise ValueError(f"supervisor must be a mutual.supervision.NoisySupervisor, got {type(supervisor).__name__}")
    _check_value_fn(value_fn)
    try:
        alphas = np.asarray(alphas, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"alphas must be a sequence of finite levels, got {alphas!r}") from None
    if len(alphas) == 0 or not np.all(np.isfinite(alphas)):
        raise ValueError(f"alphas must be a non-empty sequence of finite levels, got {alphas.tolist()}")
    n_robots = count("n_robots", n_robots)
    _check_rng(rng)
    positive("u_max", u_max)
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
    lowest = lowest.reshape(len(alphas), n_robots)
    judged = lowest <= supervisor.thresholds(n_robots, rng)
    if lowest_values:
        return judged.mean(axis=1), closest, lowest
    return judged.mean(axis=1), closest
