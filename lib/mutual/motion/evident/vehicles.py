"""Vehicle models for chapter 7 and Figure 6.1, written in JAX for iLQR.

* The Dubins car of eq. (7.5): ``(x, y, theta)' = (v cos theta, v sin theta, u)`` with constant
  speed ``v``, integrated exactly for a turn rate held constant over a step (``dubins_step``: the car's
  JAX face :func:`mutual.dubins.step_jax`, its one home with the NumPy and hj-reachability faces).
* The kinematic bicycle of Figure 6.1 ("robot motions with bicycle dynamics"; the thesis gives no
  equations, so we take the standard rear-axle kinematic bicycle, e.g. Rajamani, *Vehicle
  Dynamics and Control*, sec. 2.2, with the reference point on the rear axle)::

      x' = v cos(theta),   y' = v sin(theta),   theta' = v tan(delta) / L,   v' = a

  state ``(x, y, theta, v)``, controls ``u = (delta, a)``: the steering angle (rad) and the
  acceleration (m/s^2), wheelbase ``L``; integrated by one classical Runge-Kutta (RK4) step per
  control interval with the controls held constant (:func:`bicycle_step`).
"""

import jax.numpy as jnp

from ...dubins import SPEED, sin_ratio  # noqa: F401  (the car's speed and sin(a)/a, re-exported for chapter 7)
from ...dubins import step_jax as dubins_step  # noqa: F401  (the Dubins car's exact step, in JAX)

WHEELBASE = 1.0  # L of the bicycle (m); the thesis gives none: a small robot car


def bicycle_derivative(x, u, wheelbase=WHEELBASE):
    """The kinematic bicycle's ``dx/dt`` at state ``(x, y, theta, v)`` under ``u = (delta, a)``."""
    theta, v = x[2], x[3]
    return jnp.stack([v * jnp.cos(theta), v * jnp.sin(theta), v * jnp.tan(u[0]) / wheelbase, u[1]])


def bicycle_step(x, u, dt, wheelbase=WHEELBASE):
    """One RK4 step of :func:`bicycle_derivative` over ``dt`` with the controls held constant."""
    k1 = bicycle_derivative(x, u, wheelbase)
    k2 = bicycle_derivative(x + 0.5 * dt * k1, u, wheelbase)
    k3 = bicycle_derivative(x + 0.5 * dt * k2, u, wheelbase)
    k4 = bicycle_derivative(x + dt * k3, u, wheelbase)
    return x + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)


def single_integrator_step(x, u, dt):
    """``x' = u`` (eq. (6.5)) over ``dt``: exact for a control held constant, ``x + dt u``."""
    return x + dt * u
