"""Control on a learned safe set (Sec. 4.5): the minimally invasive safety filter that keeps a
robot in ``{V >= alpha}``, and the false-positive rate a supervisor raises against it.

States are ``(x, y, theta)`` relative to the obstacle centre unless ``obstacles`` are given."""

from dataclasses import dataclass

import numpy as np

from .dubins import SPEED, TRUE_W_MAX, _check_positive, check_states, dubins_step
from .reachability import ValueFunction
from .supervisor import approach_scenes


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
        raise ValueError("value_fn must be a mutual.supervision.reachability.ValueFunction")
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
