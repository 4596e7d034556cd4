"""Learn and act in the continuous loop: a simulated noisy idealized supervisor (Sec. 4.3) with a
turn rate w_max the robot does not know intervenes on robots driving at an obstacle; the robot fits
w_max, mu and sigma (eqs. 4.8-4.12) and then avoids obstacles at alpha = mu + 2 sigma of the fitted
safe set (Sec. 4.5), against robots using the Standard or the Conservative safe set (Sec. 5.2.2).

Value functions here are the exact avoid values of the Dubins car around a disk (the closed form
:func:`mutual.supervision.dubins.avoid_value_closed_form`, no disturbance) sampled on the library's
grid (``method="closed-form"`` of :mod:`mutual.supervision.reachability`), so that no Hamilton-Jacobi
solve is needed; chapter 4's notebook checks that closed form against the HJI solver.
"""

import numpy as np
import pandas as pd
from scipy import stats

from ..supervision import (FULL_GRID, SPEED, TRUE_W_MAX, GridSpec, approach_scenes, avoid_value_function, dubins_step,
                           filter_control, fit_supervisor, value_library)
from .intervals import mean_interval


def closed_form_value_function(w_max, obstacle_radius, grid_spec=FULL_GRID, speed=SPEED):
    """The avoid value function of eq. (4.3) for one Dubins car and a disk, from its closed form at the
    grid's nodes (:func:`mutual.supervision.reachability.avoid_value_function`, ``method="closed-form"``)."""
    if not isinstance(grid_spec, GridSpec):
        raise ValueError("grid_spec: must be a mutual.supervision.reachability.GridSpec")
    return avoid_value_function(w_max, obstacle_radius, grid_spec, speed=speed, progress=False, method="closed-form")


def closed_form_library(w_maxes, obstacle_radius, grid_spec=FULL_GRID, speed=SPEED):
    """The library {V_i} of eq. (4.12) over ``w_maxes`` from the closed form (Fig. 4.2;
    :func:`mutual.supervision.reachability.value_library`, ``method="closed-form"``)."""
    w = np.asarray(w_maxes, dtype=float)
    if w.ndim != 1 or w.size == 0 or np.any(~np.isfinite(w)) or np.any(w <= 0) or np.unique(w).size != w.size:
        raise ValueError(f"w_maxes: need distinct positive turn rates, got {w_maxes!r}")
    return value_library(w, obstacle_radius, grid_spec, speed=speed, progress=False, method="closed-form")


def collect_interventions(supervisor, n, rng, start_distance):
    """The first ``n`` interventions of ``supervisor`` on Phase II approach scenes (Sec. 5.2.1): (n, 3)."""
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"n: must be a positive integer, got {n!r}")
    radius = supervisor.value_fn.obstacle_radius
    states = np.empty((0, 3))
    while len(states) < n:
        more, _ = supervisor.first_interventions(approach_scenes(2 * n, rng, radius, start_distance), rng)
        states = np.vstack([states, more])
    return states[:n]


def drive_past(value_fn, alpha, starts, start_distance, u_max=TRUE_W_MAX, dt=0.02, speed=SPEED):
    """Robots that detected the obstacle drive straight at it from ``starts`` (n, 3) under the minimally
    invasive controller at level ``alpha`` of ``value_fn`` (lookahead one step, Sec. 4.5) until they
    have passed it. Returns the states (steps+1, n, 3) in the obstacle's frame."""
    s = np.asarray(starts, dtype=float)
    path = [s]
    for _ in range(int(np.ceil(2 * start_distance / (speed * dt)))):
        u = filter_control(value_fn, s, 0.0, alpha, u_max=u_max, lookahead=dt)
        s = dubins_step(s, u, dt, speed)
        path.append(s)
    return np.stack(path)


def false_positive_study(supervisor, controllers, n_robots, rng, start_distance, dt=0.02, level=0.95):
    """False-positive interventions of ``supervisor`` (a NoisySupervisor) on robots that detected the
    obstacle, for each controller ``{name: (value_fn, alpha)}`` on the same robots (common scenes).

    The supervisor judges each encounter once and intervenes if the robot reaches its level mu - w,
    w ~ N(0, sigma^2) (Sec. 4.3): given the robot's path the probability is exactly
    Phi((mu - min_t V_S(x_t)) / sigma) (a step function for sigma = 0), averaged here over the scenes;
    the same judgement is also drawn once per robot (``sampled``), as the check. Returns a DataFrame
    with the mean probability and its ``level`` bootstrap interval over robots, the sampled fraction,
    the closest approach to the obstacle's edge over all robots (negative: a collision) and the mean
    closest distance to the obstacle's centre (how wide a berth the robots give).
    """
    radius = supervisor.value_fn.obstacle_radius
    starts = approach_scenes(n_robots, rng, radius, start_distance, dt=dt)[:, 0]
    levels = supervisor.thresholds(n_robots, rng)
    rows = []
    for name, (value_fn, alpha) in controllers.items():
        path = drive_past(value_fn, alpha, starts, start_distance, dt=dt)
        lowest = supervisor.value_fn.interp(path.reshape(-1, 3), fill_value=np.inf).reshape(path.shape[:2]).min(axis=0)
        if supervisor.sigma > 0:
            p = stats.norm.cdf((supervisor.mu - lowest) / supervisor.sigma)
        else:
            p = (lowest <= supervisor.mu).astype(float)
        mean, low, high = mean_interval(p, level)
        distance = np.hypot(path[..., 0], path[..., 1]).min(axis=0)
        rows.append({"controller": name, "alpha": float(alpha), "p_false_positive": mean, "low": low, "high": high,
                     "sampled": float(np.mean(lowest <= levels)), "closest_edge": float(distance.min() - radius),
                     "mean_closest_centre": float(distance.mean())})
    return pd.DataFrame(rows)


def learned_false_positives(library, supervisor, n_interventions, seeds, n_robots, start_distance, k=2.0,
                            scene_seed=0, dt=0.02):
    """For each seed: fit the supervisor from ``n_interventions`` fresh interventions (MLE, eq. 4.12) and
    measure the false-positive probability of robots avoiding at ``alpha = mu + k sigma`` of the fit
    (the same ``n_robots`` scenes, from generator ``scene_seed``, for every seed). One row per seed:
    the fitted ``w_max``, ``mu``, ``sigma``, whether ``w_max`` was recovered, and the probability."""
    rows = []
    for seed in seeds:
        states = collect_interventions(supervisor, n_interventions, np.random.default_rng([seed, 40]), start_distance)
        fit = fit_supervisor(library, states, values="grid")  # the simulated supervisor judges on the grid's values
        fp = false_positive_study(supervisor, {"learned": (fit.value_fn, fit.level(k))}, n_robots,
                                  np.random.default_rng(scene_seed), start_distance, dt)
        rows.append({"seed": seed, "w_max_hat": fit.w_max, "mu_hat": fit.mu, "sigma_hat": fit.sigma,
                     "recovered": bool(np.isclose(fit.w_max, supervisor.value_fn.w_max)),
                     "p_false_positive": float(fp["p_false_positive"].iloc[0])})
    return pd.DataFrame(rows)
