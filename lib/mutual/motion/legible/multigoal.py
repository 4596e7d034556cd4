"""Figure 6.3: five reach targets, each evidenced against the other four by the receding-horizon QP of
section 6.5 (``min J1 s.t. J1 - J0_i <= eta(t)`` for every distractor, :mod:`.qp`), and the measures of
its caption (line 1268): the far ends "exaggerate motion out in their respective direction", the interior
goals "have their exaggeration hemmed in, instead anticipating via a sharp juke early and then straight
shooting to the goal after alignment" (:func:`mutual.motion.legible.path_measures.juke`).

Set-up: goals at ``(x_i, height)``, a start ``(start_x, 0)``, x' = u and eq. (6.17) with unit weights over
``horizon``; the bound loosens linearly from ``eta0`` to 0 (``eta(s) = eta0 (1 - s)``), replanned every
``every`` steps. For eq. (6.17) ``J1 - J0_i`` is the log likelihood ratio of distractor ``i`` against the
truth, so ``eta`` is in nats.
"""

import numpy as np
import pandas as pd

from .path_measures import juke, outward_excursion
from .problem import reaching_cost, single_integrator, solve
from .qp import receding_horizon_qp

GOAL_XS = (-4.0, -2.0, 0.0, 2.0, 4.0)


def figure_63_paths(goal_xs=GOAL_XS, height=4.0, start_x=0.0, horizon=20.0, N=100, eta0=-3.0, every=10,
                    eta0_exterior=None):
    """Each goal's anticipative path (the receding-horizon QP against the others) and its plain optimum.
    ``eta0_exterior``: a bound of its own for the two far ends (the thesis's ``eta_i`` may differ by pair;
    default ``eta0``). Returns ``(goals (G, 2), anticipative [(N+1, 2)], plain [(N+1, 2)])``."""
    eta0_exterior = eta0 if eta0_exterior is None else eta0_exterior
    for name, value in (("eta0", eta0), ("eta0_exterior", eta0_exterior)):
        if not (np.isfinite(value) and value < 0):
            raise ValueError(f"{name} must be a negative finite number (a strict bound that loosens to 0), got {value!r}")
    dt = horizon / N
    dyn = single_integrator(2, dt)
    goals = np.array([[x, height] for x in goal_xs], dtype=float)
    x0 = np.array([start_x, 0.0])
    costs = [reaching_cost(g, dt) for g in goals]
    paths, plain = [], []
    for i, J in enumerate(costs):
        others = [c for j, c in enumerate(costs) if j != i]
        start = eta0_exterior if i in (0, len(costs) - 1) else eta0
        paths.append(receding_horizon_qp(dyn, J, others, x0, N, lambda s, e=start: e * (1.0 - s), every=every)[0])
        plain.append(solve(dyn, J, x0, N).xs)
    return goals, paths, plain


def figure_63_measures(goals, paths):
    """Per goal: its outward excursion (outward: away from the row's centre, Figure 6.3's exaggeration) and
    the juke measures (:func:`mutual.motion.legible.path_measures.juke`). A DataFrame, one row per goal."""
    centre = goals[:, 0].mean()
    rows = []
    for i, (g, xs) in enumerate(zip(goals, paths)):
        side = np.sign(g[0] - centre) or 1.0
        rows.append({"goal": f"Lambda_{i + 1}", "goal x": g[0],
                     "exterior": bool(i in (0, len(goals) - 1)),
                     "outward excursion": outward_excursion(xs, g, side), **juke(xs, g)})
    return pd.DataFrame(rows)


def figure_63_verdicts(measures, exaggeration=0.1):
    """The caption's three statements on one cell's measures: ``exterior`` (both far ends stray outwards by
    at least ``exaggeration`` of their goal's distance), ``interior`` (the two off-centre interior goals juke
    and stray outwards less than either far end), ``centre`` (the centre goal jukes)."""
    ext = measures[measures["exterior"]]
    inner = measures[~measures["exterior"]]
    off_centre = inner.iloc[[0, -1]]
    centre = inner.iloc[len(inner) // 2]
    return {"exterior": bool((ext["outward excursion"] >= exaggeration).all()),
            "interior": bool(off_centre["juke"].all()
                             and (off_centre["outward excursion"].max() < ext["outward excursion"].min())),
            "centre": bool(centre["juke"])}


def figure_63_scan(eta0s, heights, start_xs, horizon=20.0, N=100, every=10, goal_xs=GOAL_XS):
    """:func:`figure_63_verdicts` in every cell of the scan over the bound's start ``eta0``, the goals' height
    and the start's x (none of which the thesis gives). Returns ``(cells, measures)``: one row per cell with the
    three verdicts, and every goal's measures with the cell's settings."""
    cells, frames = [], []
    for eta0 in eta0s:
        for height in heights:
            for start_x in start_xs:
                goals, paths, _ = figure_63_paths(goal_xs, height, start_x, horizon, N, eta0, every)
                m = figure_63_measures(goals, paths)
                frames.append(m.assign(eta0=eta0, height=height, start_x=start_x))
                cells.append({"eta0": eta0, "height": height, "start_x": start_x, **figure_63_verdicts(m)})
    return pd.DataFrame(cells), pd.concat(frames, ignore_index=True)


def figure_63_variants(variants, goal_xs=GOAL_XS):
    """:func:`figure_63_verdicts` for each of ``variants`` (``{label: keyword arguments of
    :func:`figure_63_paths`}``), e.g. finer replanning, other horizons or per-pair bounds: one row per variant."""
    rows = []
    for label, kwargs in variants.items():
        goals, paths, _ = figure_63_paths(goal_xs, **kwargs)
        m = figure_63_measures(goals, paths)
        rows.append({"variant": label, **figure_63_verdicts(m),
                     "largest outward excursion": float(m["outward excursion"].max()), "largest turn (deg)": float(m["turn"].max())})
    return pd.DataFrame(rows)
