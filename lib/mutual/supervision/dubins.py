"""The Dubins car family of eq. (5.1), a circular keep-out set, and a closed-form avoid value.

State ``x = (x, y, theta)`` with position relative to the centre of a disk obstacle
``K = {|p| <= r}``; the car moves at constant speed ``v`` (3 in eq. 5.1) and turns at
``u in [-w_max, w_max]`` (``w_max = 1`` for the true robots, a family over ``w_max`` for the
supervisor library of Fig. 4.2). An optional disturbance ``d`` pushes the position at
speed at most ``d_max`` (a Euclidean ball), playing the role of ``d`` in eq. (4.1).

Closed-form avoid value (no disturbance; our derivation, the oracle of the tests)::

    R = v / w_max, p = (x, y), h = (cos theta, sin theta),
    c+- = p +- R (-sin theta, cos theta)         (left / right turning-circle centres)
    V(x) = |p| - r                                if p . h >= 0   (not approaching)
    V(x) = max_+- ( | |c+-| - R | - r )            otherwise

An approaching car does best by turning hard one way until it stops approaching (then
driving straight): along a turning circle the closest point to the obstacle centre lies
at distance ``| |c| - R |``, and it is reached before the car starts to move away.
"""


import jax.numpy as jnp
import numpy as np
from hj_reachability import dynamics, sets

from ..inputs import positive, real

SPEED = 3.0  # eq. (5.1)
TRUE_W_MAX = 1.0  # eq. (5.1)
_EPS = np.finfo(float).eps


def check_states(states, name="states"):
    """Return ``states`` as a float array of shape (n, 3) or raise a ValueError naming ``name``."""
    try:
        arr = np.asarray(states, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be numbers of shape (n, 3) for (x, y, theta), got {states!r}") from None
    if arr.ndim == 1 and arr.shape == (3,):
        arr = arr[None]
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must have shape (n, 3) for (x, y, theta), got {np.shape(states)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or infinite entries")
    return arr


class DubinsCar(dynamics.ControlAndDisturbanceAffineDynamics):
    """Eq. (5.1) as hj-reachability dynamics: the control maximises V (avoid), the disturbance minimises it.

    ``w_max`` may be a JAX tracer, so one compiled solver serves the whole family.
    """

    def __init__(self, w_max=TRUE_W_MAX, speed=SPEED, d_max=0.0):
        self.w_max = w_max
        self.speed = speed
        self.d_max = d_max
        control_space = sets.Box(jnp.array([-1.0]) * w_max, jnp.array([1.0]) * w_max)
        disturbance_space = sets.Ball(jnp.zeros(2), jnp.asarray(d_max, dtype=float))
        super().__init__("max", "min", control_space, disturbance_space)

    def open_loop_dynamics(self, state, time):
        return jnp.array([self.speed * jnp.cos(state[2]), self.speed * jnp.sin(state[2]), 0.0])

    def control_jacobian(self, state, time):
        return jnp.array([[0.0], [0.0], [1.0]])

    def disturbance_jacobian(self, state, time):
        return jnp.array([[1.0, 0.0], [0.0, 1.0], [0.0, 0.0]])


def keep_out_margin(states, radius):
    """The payoff ``l(x) = |p| - r`` of eq. (4.3): negative inside the disk K, positive outside."""
    positive("radius", radius)
    try:
        s = np.asarray(states, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"states must be an array of (x, y, theta) states, got {states!r}") from None
    if s.ndim == 0 or s.shape[-1] != 3:
        raise ValueError(f"states must have a last axis of length 3 for (x, y, theta), got shape {s.shape}")
    if np.isnan(s).any():
        raise ValueError("states contains NaN entries")
    return np.hypot(s[..., 0], s[..., 1]) - radius


def unsafe_reach(w_max, radius, speed=SPEED):
    """How far ahead of the obstacle centre the unsafe set reaches: ``sqrt(2 R r + r^2)``, ``R = v / w_max``."""
    positive("w_max", w_max)
    positive("radius", radius)
    positive("speed", speed)
    if radius < 1e150 and speed / w_max < 1e150:
        return float(np.sqrt(2 * speed / w_max * radius + radius ** 2))
    with np.errstate(over="ignore"):     # sqrt(r) sqrt(2 R + r): no overflow of r^2 (or inf) for huge radii
        return float(np.sqrt(np.float64(radius)) * np.sqrt(2 * (np.float64(speed) / w_max) + radius))


def avoid_value_closed_form(states, w_max, radius, speed=SPEED, tol=1e-9):
    """The exact avoid value ``V(x)`` of eq. (4.3) for a disk and no disturbance (module docstring)."""
    positive("w_max", w_max)
    positive("radius", radius)
    positive("speed", speed)
    s = check_states(states)
    return closed_form_values(s[:, 0], s[:, 1], s[:, 2], speed / w_max, radius, tol)


def closed_form_values(x, y, theta, turn_radius, radius, tol=1e-9):
    """The closed-form avoid value on broadcastable arrays (positions, headings, turning radius
    ``v / w_max`` and obstacle radius per state): the vectorised core of :func:`avoid_value_closed_form`."""
    distance = np.hypot(x, y)
    c, s = np.cos(theta), np.sin(theta)
    turning = [np.abs(np.hypot(x - sign * turn_radius * s, y + sign * turn_radius * c) - turn_radius)
               for sign in (1, -1)]
    approaching = x * c + y * s < -tol
    return np.where(approaching, np.maximum(*turning), distance) - radius


def closed_form_dtheta(x, y, theta, turn_radius, radius, step=1e-6):
    """dV/dtheta of the closed-form value by a central difference (the sign chooses the optimal turn)."""
    return (closed_form_values(x, y, theta + step, turn_radius, radius)
            - closed_form_values(x, y, theta - step, turn_radius, radius)) / (2 * step)


def rotate_to_heading(states, heading=0.0):
    """Rotate states about the obstacle centre so each faces ``heading``; V is invariant (a disk is round)."""
    s = check_states(states)
    angle = real(heading)
    if angle is None or not np.isfinite(angle):
        raise ValueError(f"heading must be a finite angle (rad), got {heading!r}")
    heading = angle
    turn = heading - s[:, 2]
    c, sn = np.cos(turn), np.sin(turn)
    return np.stack([c * s[:, 0] - sn * s[:, 1], sn * s[:, 0] + c * s[:, 1], np.full(len(s), float(heading))], 1)


def wrap_angle(angle):
    """``angle`` wrapped to ``[-pi, pi)`` by exact modular arithmetic (no arctan2: its last bit depends
    on the CPU numpy dispatches to, which moved the chapter 5 figures between machines)."""
    return np.remainder(np.asarray(angle, dtype=float) + np.pi, 2 * np.pi) - np.pi


def dubins_step(states, controls, dt, speed=SPEED):
    """Integrate eq. (5.1) exactly over ``dt`` with constant turn rates ``controls`` (vectorised over cars)."""
    s = check_states(states)
    positive("dt", dt)
    positive("speed", speed)
    try:
        u = np.broadcast_to(np.asarray(controls, dtype=float), (len(s),))
    except (TypeError, ValueError):
        raise ValueError(f"controls must be one turn rate or one per state ({len(s)}), got {controls!r}") from None
    if not np.all(np.isfinite(u)):
        raise ValueError("controls contains NaN or infinite entries")
    return np.stack(dubins_arc(s[:, 0], s[:, 1], s[:, 2], u, dt, speed), axis=1)


def dubins_arc(x, y, theta, u, dt, speed=SPEED):
    """:func:`dubins_step` on coordinate arrays, unchecked (for simulation loops): the new ``(x, y, theta)``."""
    turn = u * dt
    # the chord of the arc: length v * 2 sin(u dt / 2) / u (finite as u -> 0), direction theta + u dt / 2;
    # sinc as np.sinc computes it (without its per-call dtype look-up)
    half = np.pi * (turn / (2 * np.pi))
    half = np.where(half, half, _EPS)
    chord = speed * dt * (np.sin(half) / half)
    mid = theta + turn / 2
    return x + chord * np.cos(mid), y + chord * np.sin(mid), wrap_angle(theta + turn)
