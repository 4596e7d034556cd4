"""Vehicle models for chapter 7 and Figure 6.1, written in JAX for iLQR.

* The Dubins car of eq. (7.5): ``(x, y, theta)' = (v cos theta, v sin theta, u)`` with constant
  speed ``v``, integrated exactly for a turn rate held constant over a step (:func:`dubins_step`).
* The kinematic bicycle of Figure 6.1 ("robot motions with bicycle dynamics"; the thesis gives no
  equations, so we take the standard rear-axle kinematic bicycle, e.g. Rajamani, *Vehicle
  Dynamics and Control*, sec. 2.2, with the reference point on the rear axle)::

      x' = v cos(theta),   y' = v sin(theta),   theta' = v tan(delta) / L,   v' = a

  state ``(x, y, theta, v)``, controls ``u = (delta, a)``: the steering angle (rad) and the
  acceleration (m/s^2), wheelbase ``L``; integrated by one classical Runge-Kutta (RK4) step per
  control interval with the controls held constant (:func:`bicycle_step`).
"""

import jax
import jax.numpy as jnp

SPEED = 3.0  # v of eq. (7.5)
WHEELBASE = 1.0  # L of the bicycle (m); the thesis gives none: a small robot car


@jax.custom_jvp
def sin_ratio(a):
    """``sin(a) / a``, smooth to every derivative order.

    The value is ``jnp.sinc``; its derivative ``(a cos a - sin a) / a^2`` is given explicitly, by its
    Taylor series for ``|a| < 1e-2``. Differentiating ``jnp.sinc`` twice by autodiff cancels terms of
    size ``1/a^3`` at tiny nonzero ``a`` and gives noise (e.g. -0.25 instead of 0.02 in a DDP or Laplace
    Hessian for a turn rate of 1e-7); a Taylor branch in the value itself (a ``where``) would make every
    gradient pass about 5x slower on XLA:CPU.
    """
    return jnp.sinc(a / jnp.pi)


def _sin_ratio_slope(a):
    """``d/da sin(a)/a = (a cos a - sin a) / a^2``: -a/3 + a^3/30 - a^5/840 + a^7/45360 near 0."""
    small = jnp.abs(a) < 1e-2
    safe = jnp.where(small, 1.0, a)
    a2 = a * a
    series = -a / 3 * (1 - a2 / 10 * (1 - a2 / 28 * (1 - a2 / 54)))
    return jnp.where(small, series, (safe * jnp.cos(safe) - jnp.sin(safe)) / (safe * safe))


@sin_ratio.defjvp
def _sin_ratio_jvp(primals, tangents):
    (a,), (da,) = primals, tangents
    return sin_ratio(a), _sin_ratio_slope(a) * da


def dubins_step(x, u, dt, speed=SPEED):
    """Eq. (7.5) integrated exactly over ``dt`` with the turn rate ``u`` (shape (1,)) held constant.

    The car turns by ``u dt`` along an arc whose chord has length ``v dt sin(u dt / 2) / (u dt / 2)``
    (:func:`sin_ratio`) and points at the mean heading ``theta + u dt / 2`` (smooth as u -> 0).
    The same integrator as :func:`mutual.supervision.dubins.dubins_step`, written in JAX.
    """
    turn = u[0] * dt
    chord = speed * dt * sin_ratio(turn / 2)
    mid = x[2] + turn / 2
    return jnp.stack([x[0] + chord * jnp.cos(mid), x[1] + chord * jnp.sin(mid), x[2] + turn])


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
