"""The Dubins car, the vehicle of chapters 4, 5, 7 and 8, in one place: its NumPy, JAX and
hj-reachability faces side by side.

State ``(x, y, theta)``, constant speed ``v``, turn rate ``u`` (eq. (5.1), ``v = 3`` and ``|u| <= w_max``;
the car of chapter 7, eq. (7.5), is the same)::

    x' = v cos(theta),   y' = v sin(theta),   theta' = u

==========================================  ===========================  ========================  ==============
                                            NumPy (vectorised over cars)  JAX (one car, smooth)     hj-reachability
==========================================  ===========================  ========================  ==============
``dx/dt``                                   :func:`derivative`                                      ``DubinsCar``
the exact step over ``dt``, ``u`` held      :func:`arc`                  :func:`step_jax`
the avoid value of a disk (closed form)     :func:`avoid_value`          :func:`avoid_value_jax`   what HJ solves
==========================================  ===========================  ========================  ==============

**The exact step.** Holding the turn rate ``u`` for ``dt``, the car turns by ``u dt`` along a circular arc
whose chord has length ``v dt sin(u dt / 2) / (u dt / 2)`` and points at the mean heading ``theta + u dt / 2``
(smooth as ``u -> 0``).

**The avoid value** ``V(x)`` of eq. (4.3) for the disk ``K = {|p| <= r}`` at the origin, without disturbance
(our derivation; the oracle of the HJ solver's tests)::

    R = v / w_max, p = (x, y), h = (cos theta, sin theta),
    c+- = p +- R (-sin theta, cos theta)         (left / right turning-circle centres)
    V(x) = |p| - r                                if p . h >= 0   (not approaching)
    V(x) = max_+- ( | |c+-| - R | - r )            otherwise

An approaching car does best by turning hard one way until it stops approaching (then driving straight):
along a turning circle the closest point to the obstacle centre lies at distance ``| |c| - R |``, and it is
reached before the car starts to move away.

Importing this module loads NumPy alone: the JAX faces import JAX when first called, and ``DubinsCar``
loads hj-reachability when first read.
"""

import functools

import numpy as np

SPEED = 3.0  # v of eqs. (5.1) and (7.5)
TRUE_W_MAX = 1.0  # the true robots' turn-rate bound, eq. (5.1)
_EPS = np.finfo(float).eps


def derivative(x, u, speed=SPEED):
    """``dx/dt`` at states ``x`` (N, 3) under turn rates ``u`` (N, 1), NumPy: ``(v cos theta, v sin theta, u)``."""
    heading = x[:, 2]
    return np.stack([speed * np.cos(heading), speed * np.sin(heading), u[:, 0]], axis=1)


def wrap_angle(angle):
    """``angle`` wrapped to ``[-pi, pi)`` by exact modular arithmetic (no arctan2: its last bit depends
    on the CPU numpy dispatches to, which moved the chapter 5 figures between machines)."""
    return np.remainder(np.asarray(angle, dtype=float) + np.pi, 2 * np.pi) - np.pi


def arc(x, y, theta, u, dt, speed=SPEED):
    """The exact step (module docstring) on coordinate arrays, NumPy, unchecked (for simulation loops): the
    new ``(x, y, theta)``, ``theta`` wrapped to ``[-pi, pi)``."""
    turn = u * dt
    # the chord of the arc: length v * 2 sin(u dt / 2) / u (finite as u -> 0), direction theta + u dt / 2;
    # sinc as np.sinc computes it (without its per-call dtype look-up)
    half = np.pi * (turn / (2 * np.pi))
    half = np.where(half, half, _EPS)
    chord = speed * dt * (np.sin(half) / half)
    mid = theta + turn / 2
    return x + chord * np.cos(mid), y + chord * np.sin(mid), wrap_angle(theta + turn)


def step_jax(x, u, dt, speed=SPEED):
    """The exact step (module docstring) of one state ``x`` (3,) with the turn rate ``u`` (shape (1,)) held
    over ``dt``, in JAX and smooth to every derivative order (:func:`sin_ratio`; ``theta`` is not wrapped,
    so that iLQR sees a smooth map)."""
    import jax.numpy as jnp
    turn = u[0] * dt
    chord = speed * dt * sin_ratio(turn / 2)
    mid = x[2] + turn / 2
    return jnp.stack([x[0] + chord * jnp.cos(mid), x[1] + chord * jnp.sin(mid), x[2] + turn])


def avoid_value(x, y, theta, turn_radius, radius, tol=1e-9):
    """The closed-form avoid value (module docstring) on broadcastable NumPy arrays: positions, headings,
    turning radius ``v / w_max`` and obstacle radius (per state, or broadcast over a grid's axes)."""
    distance = np.hypot(x, y)
    c, s = np.cos(theta), np.sin(theta)
    turning = [np.abs(np.hypot(x - sign * turn_radius * s, y + sign * turn_radius * c) - turn_radius)
               for sign in (1, -1)]
    approaching = x * c + y * s < -tol
    return np.where(approaching, np.maximum(*turning), distance) - radius


def avoid_value_jax(x, w_max, radius, speed=SPEED, smoothing=0.0):
    """The closed-form avoid value of one state ``x`` (3,) in JAX, so that iLQR can differentiate it.

    ``smoothing`` > 0 rounds its three kinks at that width (the max by a log-sum-exp, |.| by
    sqrt(z^2 + s^2), the switch at p . h = 0 by a logistic blend of the branches, which agree there), so
    that iLQR's Newton steps see a twice-differentiable cost; 0 gives the exact closed form.
    """
    import jax
    import jax.numpy as jnp
    p = x[:2]
    heading = jnp.stack([jnp.cos(x[2]), jnp.sin(x[2])])
    normal = jnp.stack([-jnp.sin(x[2]), jnp.cos(x[2])])
    big_r = speed / w_max

    def norm(v):
        return jnp.sqrt(jnp.sum(v ** 2) + 1e-12)

    gaps = [norm(p + big_r * normal) - big_r, norm(p - big_r * normal) - big_r]
    if isinstance(smoothing, (int, float)) and smoothing == 0:
        turning = jnp.maximum(jnp.abs(gaps[0]), jnp.abs(gaps[1]))
        return jnp.where(p @ heading < 0, turning, norm(p)) - radius
    s = smoothing
    a, b = (jnp.sqrt(g ** 2 + s ** 2) for g in gaps)
    turning = s * jnp.logaddexp(a / s, b / s)
    weight = jax.nn.sigmoid(-(p @ heading) / s)
    return weight * turning + (1 - weight) * norm(p) - radius


def sin_ratio(a):
    """``sin(a) / a`` in JAX, smooth to every derivative order.

    The value is ``jnp.sinc``; its derivative ``(a cos a - sin a) / a^2`` is given explicitly, by its
    Taylor series for ``|a| < 1e-2``. Differentiating ``jnp.sinc`` twice by autodiff cancels terms of
    size ``1/a^3`` at tiny nonzero ``a`` and gives noise (e.g. -0.25 instead of 0.02 in a DDP or Laplace
    Hessian for a turn rate of 1e-7); a Taylor branch in the value itself (a ``where``) would make every
    gradient pass about 5x slower on XLA:CPU.
    """
    return _jax_face()(a)


@functools.cache
def _jax_face():
    """:func:`sin_ratio` with its explicit derivative (``jax.custom_jvp``), made when JAX is first needed."""
    import jax
    import jax.numpy as jnp

    @jax.custom_jvp
    def ratio(a):
        return jnp.sinc(a / jnp.pi)

    def slope(a):
        """``d/da sin(a)/a = (a cos a - sin a) / a^2``: -a/3 + a^3/30 - a^5/840 + a^7/45360 near 0."""
        small = jnp.abs(a) < 1e-2
        safe = jnp.where(small, 1.0, a)
        a2 = a * a
        series = -a / 3 * (1 - a2 / 10 * (1 - a2 / 28 * (1 - a2 / 54)))
        return jnp.where(small, series, (safe * jnp.cos(safe) - jnp.sin(safe)) / (safe * safe))

    @ratio.defjvp
    def _jvp(primals, tangents):
        (a,), (da,) = primals, tangents
        return ratio(a), slope(a) * da

    return ratio


@functools.cache
def _hj_face():
    """``DubinsCar``, made when first read (it loads hj-reachability and JAX)."""
    import jax.numpy as jnp
    from hj_reachability import dynamics, sets

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

    return DubinsCar


def __getattr__(name):
    """``DubinsCar`` (the hj-reachability face) is made on first use; see :func:`_hj_face`."""
    if name == "DubinsCar":
        return _hj_face()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
