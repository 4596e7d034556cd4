"""Anticipation (section 6.5): receding-horizon legibility (eq. (6.16)) against Dragan and
Srinivasa's time-weighted evidence, and what Figure 6.2's "three times longer" depends on.

* :func:`weighted_evidence_optimum` minimises the task cost plus the observer's evidence from
  every partial viewing ``u_{0:k}``, weighted by D&S's ``f(t) = T - t``:
  ``J1(u) + beta sum_k f_k log Lambda(u_{0:k})`` (log-likelihood ratios of prefixes, eq. (6.7)
  with the prefix marginals of eq. (6.8); D&S weight probabilities, which need the partition
  functions, section 6.5).
* :func:`receding_alphas` recovers, step by step, the weight ``alpha_k`` for which the
  receding-horizon replan of eq. (6.16) from the current state starts with a given control, and
  how far the best ``alpha_k`` misses it; :func:`receding_equivalence` checks that the
  receding-horizon controller with those weights retraces the weighted optimum, and whether the
  weights increase (the thesis's "equivalent prioritisation").
* :func:`figure_62_scan` measures Figure 6.2's claims (the lead, "three times longer", the arcs of
  Dragan and Srinivasa) over the goal scales and schedules the thesis leaves open.
"""

import numpy as np
import pandas as pd

from ..observer import lifted_cost, lifted_dynamics, weighted_prefix_log_likelihood
from .dragan import legibility_score
from .objective import (geometric_alpha_schedule, inverse_square_alpha_schedule, linear_alpha_schedule,
                        receding_horizon, replan_gains)
from .path_measures import time_to_reach
from .problem import reaching_cost, single_integrator, solve


def ds_time_weights(N):
    """D&S's ``f(t) = T - t`` at the ends of the prefixes ``t_k = k T / N``, ``k = 1 .. N``, normalised
    to sum to one (as D&S divide by ``int f(t) dt``)."""
    if not isinstance(N, (int, np.integer)) or N < 2:
        raise ValueError(f"N must be an integer >= 2, got {N!r}")
    f = (N - np.arange(1, N + 1)) / N
    return f / f.sum()


def weighted_evidence_optimum(dynamics, J1, J0, x0, N, beta=1.0, weights=None):
    """Minimiser (controls (N, m)) of ``J1(u) + beta sum_k w_k log Lambda(u_{0:k})``, default
    ``w = ds_time_weights(N)``; exact (dense lifted solve). Raises ValueError if unbounded."""
    if not (np.isfinite(beta) and beta > 0):
        raise ValueError(f"beta must be a positive finite number, got {beta!r}")
    w = ds_time_weights(N) if weights is None else weights
    H1, h1, _ = lifted_cost(dynamics, J1, x0, N)
    A0, a0, _ = weighted_prefix_log_likelihood(dynamics, J0, x0, N, w)
    A1, a1, _ = weighted_prefix_log_likelihood(dynamics, J1, x0, N, w)
    # log Lambda_k = log P0_k - log P1_k = -(1/2 u'A0 u + a0'u) + (1/2 u'A1 u + a1'u) + const
    H = H1 + beta * (A1 - A0)
    g = h1 + beta * (a1 - a0)
    H = 0.5 * (H + H.T)
    if np.linalg.eigvalsh(H)[0] <= 1e-9 * np.abs(H).max():
        raise ValueError(f"J1 + beta * weighted evidence is unbounded below for beta = {beta!r}")
    return np.linalg.solve(H, -g).reshape(N, -1)


def _rollout(dynamics, x0, us):
    free, G = lifted_dynamics(dynamics, x0, len(us))
    return free + G @ us.reshape(-1)


def receding_alphas(dynamics, J1, J0, xs, us, N):
    """For each step ``k`` the weight ``alpha_k > 0`` whose replan (eq. (6.16)) from ``xs[k]`` on
    ``[k, N)`` starts with ``us[k]``. The replan minimises ``(1 + theta) J1 - theta J0`` with
    ``theta = 1 / alpha``; its first control is computed at ``theta = 0, 1/2, 1`` and ``theta_k`` is
    fitted by least squares along that line. Returns ``(alphas, miss, curvature)``: ``miss[k]`` is
    ``|u_k(theta_k) - us[k]|`` (0 when some alpha reproduces the step), ``curvature[k]`` how far
    ``u_k(1/2)`` lies from the line (0 when the first control is affine in ``theta``)."""
    probe = np.array([0.0, 0.5, 1.0])
    starts = np.repeat(np.arange(N), len(probe))
    theta = np.tile(probe, N)
    K, kff = replan_gains(dynamics, J1, J0, N, 1.0 + theta, theta, starts)
    steps = np.arange(N)
    first = (np.einsum("kpij,kj->kpi", K.reshape(N, 3, *K.shape[1:])[steps, :, steps], xs[:N])
             + kff.reshape(N, 3, *kff.shape[1:])[steps, :, steps])            # (N, 3, m): u_k(theta)
    slope = first[:, 2] - first[:, 0]
    bend = np.linalg.norm(first[:, 1] - 0.5 * (first[:, 0] + first[:, 2]), axis=1)
    thetas = np.einsum("ki,ki->k", us - first[:, 0], slope) / np.einsum("ki,ki->k", slope, slope)
    miss = np.linalg.norm(first[:, 0] + thetas[:, None] * slope - us, axis=1)
    with np.errstate(divide="ignore"):
        alphas = np.where(thetas > 0, 1.0 / thetas, np.inf)
    return alphas, miss, bend


def receding_equivalence(dynamics, J1, J0, x0, N, beta=1.0, weights=None):
    """Does receding-horizon control (eq. (6.16)) reproduce the D&S-weighted optimum (``weights`` of the
    prefixes, default D&S's ``T - t``)? Under eq. (6.17) it always does, for any positive weights: each
    replan's first control is affine in ``1 / alpha`` and every such optimum lies on that line, with
    ``alpha`` increasing; so this holds by construction there.

    Returns a dict: ``us_weighted``, ``xs_weighted`` (the optimum of :func:`weighted_evidence_optimum`),
    ``alphas`` (the recovered schedule), ``miss`` (largest per-step miss), ``curvature``,
    ``gap`` (largest |x| difference between the receding-horizon run with the recovered schedule
    and the weighted optimum), ``positive`` and ``increasing`` (of the schedule).
    """
    us = weighted_evidence_optimum(dynamics, J1, J0, x0, N, beta, weights)
    xs = _rollout(dynamics, np.asarray(x0, float), us)
    alphas, miss, bend = receding_alphas(dynamics, J1, J0, xs, us, N)
    # the last prefix carries no weight (f(T) = 0): the last replan is the plain task, alpha = inf,
    # replayed as alpha = 1e12 (a relative change of 1e-12 in its control)
    positive = bool(np.all(alphas > 0))
    gap = np.inf
    if positive:
        replay = np.minimum(alphas, 1e12)
        rh_xs, _, _ = receding_horizon(dynamics, J1, J0, x0, N, lambda s: replay[int(round(s * N))], every=1)
        gap = float(np.abs(rh_xs - xs).max())
    return {"us_weighted": us, "xs_weighted": xs, "alphas": alphas, "miss": float(miss.max()),
            "curvature": float(bend.max()), "gap": gap, "positive": positive,
            "increasing": bool(positive and np.all(np.diff(1.0 / alphas) <= 1e-9 / alphas[:-1]))}


SCHEDULES = {"linear": linear_alpha_schedule, "geometric": geometric_alpha_schedule,
             "inverse-square": lambda a0, a1=None: inverse_square_alpha_schedule(a0)}


def schedule(kind, alpha_start, alpha_end=None):
    """The alpha schedule of eq. (6.16) named ``kind`` (a key of :data:`SCHEDULES`) from ``alpha_start`` to
    ``alpha_end`` (``None`` for ``"inverse-square"``, which grows without bound)."""
    if kind not in SCHEDULES:
        raise ValueError(f"kind must be one of {sorted(SCHEDULES)}, got {kind!r}")
    return SCHEDULES[kind](alpha_start, alpha_end)


def figure_62_paths(scale, horizon, N, kind, alpha_start, alpha_end=None):
    """Figure 6.2's set-up: goals ``(-s, s)`` (H0) and ``(s, s)`` (H1) from the origin, x' = u and eq. (6.17)
    with unit weights over ``horizon`` in ``N`` steps. Returns ``{"H0", "H1", "anticipative"}`` state paths
    (the anticipative one replans at every step with the named schedule) and the goals."""
    dt = horizon / N
    dyn = single_integrator(2, dt)
    g0, g1 = np.array([-scale, scale]), np.array([scale, scale])
    J0, J1 = reaching_cost(g0, dt), reaching_cost(g1, dt)
    paths = {"H0": solve(dyn, J0, np.zeros(2), N).xs, "H1": solve(dyn, J1, np.zeros(2), N).xs,
             "anticipative": receding_horizon(dyn, J1, J0, np.zeros(2), N, schedule(kind, alpha_start, alpha_end))[0]}
    return paths, np.array([g0, g1])


def figure_62_scan(scales, schedules, horizon=20.0, N=100, level=2.0):
    """Figure 6.2 over what the thesis leaves open: goal scales and alpha schedules (``(kind, start, end)``
    triples, see :func:`schedule`). One row per cell with the times to reach ``x = level`` (the caption's
    "three times longer"), the x-coordinates at ``T / 4`` (does the anticipative path lead early?), how close
    each path ends to its goal (relative to the goal's distance), Dragan and Srinivasa's legibility score of
    the anticipative path and of the straight line to the goal (time normalised to 1), and how far the
    anticipative path at ``T / 2`` lies beyond the midpoint of its chord (relative to ``s``: does it arc?)."""
    rows, dt = [], horizon / N
    for s in scales:
        for kind, a0, a1 in schedules:
            paths, goals = figure_62_paths(s, horizon, N, kind, a0, a1)
            h1, xs = paths["H1"], paths["anticipative"]
            straight = np.linspace(0.0, 1.0, N + 1)[:, None] * goals[1]
            t_h1, t = time_to_reach(h1, level, dt), time_to_reach(xs, level, dt)
            rows.append({"goal scale s": s, "schedule": kind, "alpha_start": a0,
                         "alpha_end": np.inf if a1 is None else a1, "t_H1 (x = 2)": t_h1,
                         "t_anticipative (x = 2)": t, "ratio": t_h1 / t,
                         "x_H1 at T/4": h1[N // 4, 0], "x_anticipative at T/4": xs[N // 4, 0],
                         "H1 end gap / |g1|": np.linalg.norm(h1[-1] - goals[1]) / np.linalg.norm(goals[1]),
                         "anticipative end gap / |g1|": np.linalg.norm(xs[-1] - goals[1]) / np.linalg.norm(goals[1]),
                         "D&S score anticipative": legibility_score(xs, goals, 1),
                         "D&S score straight line": legibility_score(straight, goals, 1),
                         "arc at T/2 / s": (xs[N // 2, 0] - 0.5 * (xs[0, 0] + xs[-1, 0])) / s})
    return pd.DataFrame(rows)
