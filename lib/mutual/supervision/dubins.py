"""The Dubins car family of eq. (5.1) around a circular keep-out set, with checked inputs.

The car itself (its dynamics, exact step, hj-reachability dynamics and the closed-form avoid value
of a disk) lives in :mod:`mutual.dubins`, with its NumPy, JAX and hj-reachability faces side by side;
this module gives chapter 4 its checked, vectorised entry points: states ``x = (x, y, theta)`` with
position relative to the centre of a disk obstacle ``K = {|p| <= r}``, constant speed ``v`` (3 in
eq. 5.1), turn rate ``u in [-w_max, w_max]`` (``w_max = 1`` for the true robots, a family over
``w_max`` for the supervisor library of Fig. 4.2), and an optional disturbance ``d`` pushing the
position at speed at most ``d_max`` (a Euclidean ball), playing the role of ``d`` in eq. (4.1).
"""


import numpy as np

from ..dubins import SPEED, TRUE_W_MAX, arc as dubins_arc, avoid_value as closed_form_values, wrap_angle
from ..inputs import positive, real

__all__ = ["SPEED", "TRUE_W_MAX", "avoid_value_closed_form", "check_states", "closed_form_dtheta",
           "closed_form_values", "dubins_arc", "dubins_step", "keep_out_margin", "rotate_to_heading", "unsafe_reach",
           "wrap_angle"]


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


def dubins_step(states, controls, dt, speed=SPEED):
    """Integrate eq. (5.1) exactly over ``dt`` with constant turn rates ``controls`` (vectorised over cars;
    :func:`mutual.dubins.arc` on checked inputs)."""
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
