"""Chapter 7's vehicle models: the Dubins car integrates eq. (7.5) exactly for constant turn rates and agrees
with chapter 5's numpy integrator; the kinematic bicycle; sin(x)/x's derivatives against its series."""

import jax
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mutual.motion.evident import vehicles
from mutual.supervision.dubins import dubins_step as dubins_step_numpy


def test_dubins_step_integrates_eq_7_5_exactly_for_constant_turn_rates():
    rng = np.random.default_rng(0)
    for x0, u in [(rng.normal(size=3), 1.7), (rng.normal(size=3), 0.0), (rng.normal(size=3), -4.0)]:
        ode = solve_ivp(lambda t, x: [3 * np.cos(x[2]), 3 * np.sin(x[2]), u], (0, 0.3), x0, rtol=1e-12, atol=1e-12)
        with jax.enable_x64(True):
            ours = np.asarray(vehicles.dubins_step(x0, np.array([u]), 0.3))
        np.testing.assert_allclose(ours, ode.y[:, -1], atol=1e-9)


def test_dubins_step_agrees_with_chapter_5s_numpy_integrator():
    rng = np.random.default_rng(1)
    states, controls = rng.normal(size=(20, 3)), rng.normal(size=20)
    with jax.enable_x64(True):
        ours = np.array(jax.vmap(vehicles.dubins_step, in_axes=(0, 0, None))(states, controls[:, None], 0.1))
    theirs = dubins_step_numpy(states, controls, 0.1)
    np.testing.assert_allclose(ours[:, :2], theirs[:, :2], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * ours[:, 2])), theirs[:, 2], atol=1e-12)


def test_bicycle_step_integrates_the_kinematic_bicycle():
    """One RK4 step against scipy's adaptive integrator (error O(dt^5) per step)."""
    rng = np.random.default_rng(5)
    for _ in range(3):
        x0 = np.r_[rng.normal(size=3), 2 + rng.random()]
        u = np.array([0.4 * rng.normal(), rng.normal()])
        ode = solve_ivp(lambda t, x: [x[3] * np.cos(x[2]), x[3] * np.sin(x[2]), x[3] * np.tan(u[0]) / 1.0, u[1]],
                        (0, 0.04), x0, rtol=1e-12, atol=1e-12)
        with jax.enable_x64(True):
            ours = np.asarray(vehicles.bicycle_step(x0, u, 0.04, 1.0))
        np.testing.assert_allclose(ours, ode.y[:, -1], atol=1e-8)


def test_sin_ratio_derivatives_match_the_series():
    """sin(a)/a and its first three derivatives by autodiff (what DDP and the Laplace Hessians use)
    against the term-by-term derivatives of its Taylor series, on both sides of the series switch."""
    import math

    from mutual.motion.evident.vehicles import sin_ratio

    def series(a, n):
        return sum((-1) ** k / math.factorial(2 * k + 1) * math.factorial(2 * k) / math.factorial(2 * k - n)
                   * a ** (2 * k - n) for k in range(40) if 2 * k >= n)

    fs = [sin_ratio]
    for _ in range(3):
        fs.append(jax.grad(fs[-1]))
    with jax.enable_x64(True):
        for a in (0.0, 1e-9, 1e-5, 0.0099, 0.0101, 0.1, 1.0, -0.7, 3.0):
            for n, f in enumerate(fs):
                assert float(f(a)) == pytest.approx(series(a, n), abs=1e-9), (a, n)
