"""Hand-written nominal controllers of the benchmark's systems, and their backup policies.

None of them is derived from the inference's model (no soft Bellman backup, no Boltzmann choice):

* pendulum -- energy shaping (Astrom and Furuta 2000): u = k (E* - E) theta_dot toward the upright
  energy E* = g, with a PD catch near the top; backup: full torque against the motion (energy never rises);
* double integrator -- a PD controller toward the goal; backup: full braking to rest;
* cart-pole -- LQR about the upright equilibrium (scipy's continuous Riccati solver on the
  linearized dynamics) toward the goal, the position error saturated at 1.2 m so the cart cruises (near 0.8 m/s);
  backup: an LQR that stops the cart (velocity and pole only, the position free);
* car -- heading feedback toward the goal; backups: full turn left or right until driving straight
  on leaves every obstacle behind, then straight on.

``gain`` scales every feedback gain (a demonstrator with wrong gains uses 0.5).
"""

from functools import lru_cache

import numpy as np
import scipy.linalg

from ..regions import Disk
from ..systems import cartpole
from .safety import Backup

GRAVITY = 9.81


def _wrap(angle):
    return np.mod(angle + np.pi, 2 * np.pi) - np.pi


def pendulum(x, goal, gain=1.0, damping=0.1):
    """Energy-shaping swing-up with a PD catch within 0.4 rad and 2.5 rad/s of upright."""
    theta, omega = x[:, 0], x[:, 1]
    error = _wrap(theta - goal[0])
    energy = 0.5 * omega ** 2 - GRAVITY * np.cos(theta)
    swing = gain * 2.0 * (GRAVITY - energy) * omega + damping * omega
    catch = -gain * (20.0 * error + 6.0 * omega)
    near = (np.abs(error) < 0.4) & (np.abs(omega) < 2.5)
    return np.where(near, catch, swing)[:, None]


def double_integrator(x, goal, gain=1.0):
    """PD toward the goal position: u = -(p - goal) - 1.5 v."""
    return (-gain * (1.0 * (x[:, 0] - goal[0]) + 1.5 * x[:, 1]))[:, None]


@lru_cache(maxsize=None)
def cartpole_gains():
    """LQR gains (full state, and velocity-and-pole only) of the cart-pole linearized at upright."""
    eps, x0, u0 = 1e-6, np.zeros((1, 4)), np.zeros((1, 1))
    A = np.stack([(cartpole(x0 + eps * e, u0) - cartpole(x0 - eps * e, u0))[0] / (2 * eps) for e in np.eye(4)], 1)
    B = ((cartpole(x0, u0 + eps) - cartpole(x0, u0 - eps))[0] / (2 * eps))[:, None]
    full = _lqr(A, B, np.diag([2.0, 1.0, 20.0, 1.0]), np.array([[0.1]]))
    keep = [1, 2, 3]
    stop = _lqr(A[np.ix_(keep, keep)], B[keep], np.diag([4.0, 20.0, 1.0]), np.array([[0.1]]))
    return full, np.r_[0.0, stop]


def _lqr(A, B, Q, R):
    P = scipy.linalg.solve_continuous_are(A, B, Q, R)
    return np.linalg.solve(R, B.T @ P)[0]


def cartpole_nominal(x, goal, gain=1.0):
    """u = -K (x - goal), the position error clipped to +-1.2 m."""
    full, _ = cartpole_gains()
    e = x - np.asarray(goal)
    e[:, 0] = np.clip(e[:, 0], -1.2, 1.2)
    return (-gain * e @ full)[:, None]


def cartpole_stop(x):
    """The backup: stop the cart with the pole upright (the position left free)."""
    _, stop = cartpole_gains()
    return (-x @ stop)[:, None]


def car(x, goal, gain=1.0):
    """Turn rate 1.5 times the heading error toward the goal."""
    bearing = np.arctan2(goal[1] - x[:, 1], goal[0] - x[:, 0])
    return (gain * 1.5 * _wrap(bearing - x[:, 2]))[:, None]


def _constant(value):
    return lambda x: np.full((len(x), 1), float(value))


def _brake(limit, dim):
    """Full control against the motion of coordinate ``dim`` (a velocity): u = -limit sign(x_dim)."""
    return lambda x: (-limit * np.sign(x[:, dim]))[:, None]


def _pendulum_braked(x, allowed):
    """Braking never adds energy, and at a given energy the pendulum is fastest hanging down: it stays
    allowed forever if the states hanging down with its energy, swinging either way, are allowed."""
    energy = 0.5 * x[:, 1] ** 2 - GRAVITY * np.cos(x[:, 0])
    speed = np.sqrt(2.0 * np.maximum(energy + GRAVITY, 0.0))
    bottom = np.zeros_like(x)
    return allowed.ok(np.c_[bottom[:, 0], speed]) & allowed.ok(np.c_[bottom[:, 0], -speed])


def _at_rest(dim, speed):
    return lambda x, allowed: np.abs(x[:, dim]) <= speed


def _nearest_points(region, p):
    """The points (N, 2) of a disk or box nearest to the points ``p`` (N, 2)."""
    if isinstance(region, Disk):
        c = np.asarray(region.center)
        d = p - c
        return c + region.radius * d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
    return np.clip(p, region.low, region.high)


def _car_leaving(x, allowed):
    """Driving straight on, the car never comes closer to any obstacle (the distance to a convex set
    along a line is convex, so it stays non-decreasing once it is)."""
    heading = np.c_[np.cos(x[:, 2]), np.sin(x[:, 2])]
    ok = np.ones(len(x), dtype=bool)
    for region in allowed.grown:
        p = x[:, list(region.dims)]
        ok &= np.einsum("ij,ij->i", p - _nearest_points(region, p), heading) >= 0
    return ok


def _car_turn_away(allowed_of, turn):
    """Turn at ``turn`` until driving straight on leaves every obstacle behind, then drive straight."""
    return lambda x: np.where(_car_leaving(x, allowed_of()), 0.0, turn)[:, None]


def pendulum_backup(allowed):
    return Backup((_brake(3.0, 1),), 1.5, _pendulum_braked)


def double_integrator_backup(allowed):
    return Backup((_brake(1.0, 1),), 3.0, _at_rest(1, 0.06))


def cartpole_backup(allowed):
    return Backup((cartpole_stop,), 1.5)


def car_backup(allowed):
    return Backup(tuple(_car_turn_away(lambda: allowed, turn) for turn in (-1.0, 1.0)), 3.5, _car_leaving)


#: system name -> (nominal controller, its backup as a function of the allowed set)
CONTROLLERS = {
    "pendulum": (pendulum, pendulum_backup),
    "double_integrator": (double_integrator, double_integrator_backup),
    "cartpole": (cartpole_nominal, cartpole_backup),
    "car": (car, car_backup),
}
