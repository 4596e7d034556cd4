"""Chapter 7's figures over what the thesis leaves open (CLAIMS.md rule 2): the legibility weight
``alpha`` (never given), the hazard of Fig. 7.2 (the caption's ``[2, -2]`` and the text's ``[-2, 2]``),
the weights of Fig. 6.1 (none given; ours were carried over from the Dubins car) and the schedule of the
receding horizon. Each scan solves every cell with the same solver as the notebook's chosen set-up, so
the chosen cell is one of the scan's cells.
"""

from dataclasses import replace

import numpy as np
import pandas as pd

from ..legible.objective import geometric_alpha_schedule, linear_alpha_schedule
from ..trajopt import ILQRError
from . import safety as es
from .evidence import anticipates, close_but_clear, distance_to_point, obvious_avoidance
from .task_belief import belief_over_time

H1_ONLY_SLIGHTLY = 0.05   # Fig. 7.2: H1 "only slightly" farther: integral distance gain in (0, 5%)


def hazard_feature(xs, hazard, dt):
    """``dt sum_{k<N} |P x_k - h|^2``: the feature eq. (7.4) rewards (with weight ``a3``), a left Riemann sum
    as in :mod:`.safety`. The optimum of ``J1 = J0 - a3 (.)`` can only raise it over the optimum of ``J0``
    (compare both optima under both costs), so its order across H0, H1 and the legible optimum holds by
    construction at global optima."""
    p = np.asarray(xs, float)[:-1, :2]
    return float(dt * np.sum((p - np.asarray(hazard, float)) ** 2))


def keep_out_feature(xs, task):
    """``dt sum_{k<N} sum_s 1 / (1 + |P x_k - s|^2 / r^2)``: the keep-out feature of :mod:`.safety` (weight
    ``a4``), which a higher keep-out weight can only lower at global optima (as :func:`hazard_feature`)."""
    p = np.asarray(xs, float)[:-1, :2]
    d2 = ((p[:, None, :] - task.keep_out[None]) ** 2).sum(-1)
    return float(task.dt * np.sum(1.0 / (1.0 + d2 / task.radius ** 2)))


def _solved(task, weights):
    """iLQR from rest; if it does not converge, again with ten times the iterations, then the best of the
    multi-start runs (:func:`.safety.best_of_starts`): a solver that stops early is our numerics, not a
    finding (CLAIMS.md rule 3). Returns ``(result or None, error message or "")``."""
    try:
        return es.solve(task, weights), ""
    except ILQRError:
        pass
    try:
        return es.solve(task, weights, max_iter=2000), ""
    except ILQRError:
        pass
    try:
        return es.best_of_starts(task, weights).best, ""
    except (ILQRError, ValueError) as err:
        return None, str(err)


def _better(task, weights, result):
    """The lower-cost of ``result`` and the best multi-start run (:func:`.safety.best_of_starts`)."""
    try:
        alternative = es.best_of_starts(task, weights).best
    except (ILQRError, ValueError):
        return result
    return alternative if alternative.cost < result.cost else result


def figure_72_scan(alphas, hazards, steps=100):
    """Fig. 7.2 for every ``alpha`` and hazard: ``(table, paths)``. ``table`` has one row per (hazard, alpha)
    with H1's integral-distance gain over H0, whether it is "only slightly" farther, the legible path's
    obvious-avoidance test (:func:`.evidence.obvious_avoidance`) and anticipation test
    (:func:`.evidence.anticipates`), the hazard feature of the three optima and any solver error;
    ``paths[hazard][name]`` the solutions (``name``: H0, H1 or the alpha). A legible optimum whose hazard
    feature falls below H1's cannot be the global optimum (:func:`hazard_feature`); it is replaced by the best
    multi-start run when that costs less."""
    base, w0, w1 = es.figure_scenario("7.2", steps=steps)
    rows, paths = [], {}
    for hazard in hazards:
        task = replace(base, hazard=np.asarray(hazard, float))
        h0, h1 = es.solve(task, w0), es.solve(task, w1)
        d0, d1 = (distance_to_point(r.xs, task.hazard, task.dt) for r in (h0, h1))
        key = tuple(float(v) for v in hazard)
        paths[key] = {"H0": h0, "H1": h1}
        gain = d1["integral"] / d0["integral"] - 1
        f1 = hazard_feature(h1.xs, task.hazard, task.dt)
        for alpha in alphas:
            weights = es.legible_weights(w1, w0, alpha)
            legible, error = _solved(task, weights)
            if legible is not None and hazard_feature(legible.xs, task.hazard, task.dt) < f1:
                legible = _better(task, weights, legible)     # a certificate that it is not the global optimum
            paths[key][alpha] = legible
            row = {"hazard": str(list(key)), "alpha": float(alpha), "H1 integral gain": gain,
                   "H1 only slightly": bool(0 < gain < H1_ONLY_SLIGHTLY), "error": error,
                   "feature H0": hazard_feature(h0.xs, task.hazard, task.dt),
                   "feature H1": hazard_feature(h1.xs, task.hazard, task.dt)}
            if legible is None:
                rows.append({**row, "obvious": False, "anticipates": False})
                continue
            obvious, lg_gain, ratio = obvious_avoidance(legible.xs, h0.xs, h1.xs, task.hazard, task.dt)
            ahead, lead, _ = anticipates(legible.xs, h0.xs, h1.xs, task.hazard, task.dt)
            rows.append({**row, "legible integral gain": lg_gain, "legible min ratio": ratio, "obvious": obvious,
                         "legible separates at (s)": lead["t_separate"], "H0 closest at (s)": lead["t_close"],
                         "anticipates": ahead, "feature legible": hazard_feature(legible.xs, task.hazard, task.dt)})
    return pd.DataFrame(rows), paths


def figure_61_scan(effort_weights, keep_out_weights, alphas, steps=100):
    """Fig. 6.1 (the kinematic bicycle passing a person) for every effort weight ``a2``, keep-out weight ``a4``
    and ``alpha`` (the goal weight stays ``a1 = 100``). One row per cell: the closest approach of H0, H1 and
    the legible path to the person, whether H1 "comes concerningly close" (:func:`.evidence.close_but_clear`)
    and whether the legible path passes "clearly farther" (at least 1.5 times H1's closest approach, H1 clear
    of the person; the first version of this rule, ``legible > H1 > radius``, is kept beside it: comparing
    optima under both costs all but forces it, so it cannot test the thesis), and any solver error. A path whose keep-out feature exceeds that of the less averse
    hypothesis (:func:`keep_out_feature`) is not a global optimum and is replaced by the best multi-start run
    when that costs less."""
    base, w0, w1 = es.figure_scenario("6.1", steps=steps)
    goal_weight = float(w0[0])
    rows = []
    for a2 in effort_weights:
        h0 = es.solve(base, es.hypothesis_weights(goal_weight, a2))
        d0 = distance_to_point(h0.xs, base.hazard, base.dt)["min"]
        for a4 in keep_out_weights:
            v0 = es.hypothesis_weights(goal_weight, a2)
            v1 = es.hypothesis_weights(goal_weight, a2, keep_out=a4)
            h1, err1 = _solved(base, v1)
            if h1 is not None and keep_out_feature(h1.xs, base) > keep_out_feature(h0.xs, base):
                h1 = _better(base, v1, h1)                     # a certificate that it is not the global optimum
            d1 = np.nan if h1 is None else distance_to_point(h1.xs, base.hazard, base.dt)["min"]
            for alpha in alphas:
                wl = es.legible_weights(v1, v0, alpha)
                legible, err = _solved(base, wl)
                if legible is not None and h1 is not None and keep_out_feature(legible.xs, base) > keep_out_feature(h1.xs, base):
                    legible = _better(base, wl, legible)
                dl = np.nan if legible is None else distance_to_point(legible.xs, base.hazard, base.dt)["min"]
                rows.append({"a2": float(a2), "a4": float(a4), "alpha": float(alpha), "H0 closest": d0,
                             "H1 closest": d1, "legible closest": dl,
                             "H0 collides": bool(d0 <= base.radius),
                             "H1 close but clear": bool(h1 is not None and close_but_clear(d1, base.radius)),
                             "legible clearly farther": bool(legible is not None and h1 is not None
                                                             and d1 > base.radius and dl >= 1.5 * d1),
                             "legible farther (first rule)": bool(legible is not None and h1 is not None
                                                                  and dl > d1 > base.radius),
                             "error": err1 or err})
    return pd.DataFrame(rows)


def ring_starts(hazard, goal, radii=(2.0, 4.5), bearings=tuple(range(0, 360, 45)), turns=(0.0, np.pi / 2, -np.pi / 2),
                min_goal_distance=2.5):
    """Dubins start states around the hazard ``h``: positions ``h + rho (cos b, sin b)`` for each radius and
    bearing (degrees), except those within ``min_goal_distance`` of the goal ``g``, each heading towards ``g``
    turned by each of ``turns`` (radians, counter-clockwise). Returns an (S, 3) array of ``(x, y, theta)``."""
    hazard, goal = np.asarray(hazard, float), np.asarray(goal, float)
    starts = []
    for rho in radii:
        for b in np.radians(np.asarray(bearings, float)):
            p = hazard + rho * np.array([np.cos(b), np.sin(b)])
            if np.linalg.norm(goal - p) < min_goal_distance:
                continue
            towards = np.arctan2(*(goal - p)[::-1])
            starts += [[p[0], p[1], towards + turn] for turn in turns]
    return np.array(starts)


def _best_from_rates(task, weights, turn_rates):
    """The lowest-cost iLQR optimum over starts from constant turn rates (single solves: each compiles once)."""
    best = None
    for rate in turn_rates:
        try:
            r = es.solve(task, weights, us0=np.full((task.steps, task.controls), rate))
        except ILQRError:
            continue
        best = r if best is None or r.cost < best.cost else best
    return best


def figure_72_start_scan(starts, kappas, steps=100, turn_rates=(0.0, 1.5, -1.5)):
    """Fig. 7.2's H0 and H1 from each start state (x, y, theta) and horizon ``T = kappa |g - p0| / v`` (the
    text's hazard): the best of iLQR runs from constant turn rates for each, H1's integral-distance gain over
    H0 and whether H1 is "only slightly" farther (0 < gain < 5%). One row per (start, kappa)."""
    base, w0, w1 = es.figure_scenario("7.2", steps=steps)
    rows = []
    for start in np.asarray(starts, float):
        for kappa in kappas:
            horizon = kappa * np.linalg.norm(base.goal - start[:2]) / base.speed
            task = replace(base, x0=start, horizon=horizon)
            h0, h1 = (_best_from_rates(task, w, turn_rates) for w in (w0, w1))
            row = {"start x": start[0], "start y": start[1], "heading (deg)": float(np.degrees(start[2])),
                   "kappa": float(kappa), "T (s)": horizon}
            if h0 is None or h1 is None:
                rows.append({**row, "H1 integral gain": np.nan, "H1 only slightly": False, "error": "iLQR did not converge"})
                continue
            d0, d1 = (distance_to_point(r.xs, task.hazard, task.dt) for r in (h0, h1))
            gain = d1["integral"] / d0["integral"] - 1
            rows.append({**row, "H0 closest": d0["min"], "H1 closest": d1["min"], "H1 integral gain": gain,
                         "H1 only slightly": bool(0 < gain < H1_ONLY_SLIGHTLY), "error": ""})
    return pd.DataFrame(rows)


def belief_start_scan(figure, starts, horizons, alpha=0.5, steps=100):
    """``P(H1 | motion to T/2)`` of the eq. (6.8) observer watching the legible path against watching H1's
    optimum, for Fig. ``"7.1"`` or ``"7.2"`` from each start state and horizon (exact for Fig. 7.1, Laplace
    around the optimal continuations for the car, :func:`.task_belief.belief_over_time`). One row per cell,
    with whether the legible path shows the correction (a higher belief) and any solver error."""
    base, w0, w1 = es.figure_scenario(figure, steps=steps)
    times = np.array([0, steps // 2])
    rows = []
    for start in np.asarray(starts, float):
        for horizon in horizons:
            task = replace(base, x0=start, horizon=float(horizon))
            row = {"figure": figure, "start": str(np.round(start, 2).tolist()), "T (s)": float(horizon)}
            try:
                paths = es.solve_hypotheses(task, w0, w1, alpha)
                legible, h1 = (belief_over_time(task, w0, w1, paths[k].us, paths, times=times)[-1] for k in ("legible", "H1"))
            except (ILQRError, ValueError) as err:
                rows.append({**row, "shows the correction": False, "error": str(err)[:120]})
                continue
            rows.append({**row, "P(H1 | legible to T/2)": float(legible), "P(H1 | H1 optimum to T/2)": float(h1),
                         "shows the correction": bool(legible > h1), "error": ""})
    return pd.DataFrame(rows)


MPC_SCHEDULES = {"linear 1/4 -> 4": lambda: linear_alpha_schedule(0.25, 4.0),
                 "linear 1/2 -> 4": lambda: linear_alpha_schedule(0.5, 4.0),
                 "geometric 1/4 -> 4": lambda: geometric_alpha_schedule(0.25, 4.0)}
