"""Explore chapter 6 (legible motion as hypothesis testing) with live controls.

:func:`legibility_view` draws, for a row of reach targets, the predictable path (the optimum of the
true goal's cost alone) and the legible one (eq. (6.15), or anticipative by receding horizon,
eq. (6.16)), beside the observer's belief in the true goal while it watches each motion unfold
(the Boltzmann observer of eq. (6.8), :func:`mutual.motion.observer.posterior_over_time`).
With two goals the legible path minimises ``(1 + alpha) J_true - J_other`` (eq. (6.15)); with more,
it is the QP of section 6.5, ``min J_true s.t. J_true - J_i <= eta`` for every other goal ``i``
(evidencing the truth against each distractor; an equal-weight mixture of the distractors would
push an interior goal's path towards its outer neighbour). For eq. (6.17) ``J_true - J_i`` is the
log likelihood ratio of goal ``i`` against the truth (the partition functions are equal), and it is
at least ``-spacing^2`` for an interior goal (reached exactly), so the bound is set as
``eta = -strictness * spacing^2`` with ``strictness`` in [0, 1). It returns a ``matplotlib.figure.Figure``
built without pyplot; the notebook's Explore cell wraps it in ``ipywidgets.interact``.
"""

import numpy as np
from matplotlib.figure import Figure

from ...style import CYCLE, PALETTE, STYLE
from ..observer import posterior_over_time
from .objective import legible_trajectory, linear_alpha_schedule, receding_horizon
from .problem import reaching_cost, single_integrator, solve
from .qp import multi_distractor_qp, receding_horizon_qp

DT, N = 0.01, 100


def _check(alpha, n_goals, true_goal, spread, goal_height, strictness):
    if not (isinstance(strictness, (int, float, np.integer, np.floating)) and 0 <= strictness < 1):
        raise ValueError(f"strictness must be a number in [0, 1), got {strictness!r}")
    if not (isinstance(alpha, (int, float, np.integer, np.floating)) and np.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha must be a positive finite number (alpha <= 0 is unbounded), got {alpha!r}")
    if not isinstance(n_goals, (int, np.integer)) or isinstance(n_goals, bool) or not 2 <= n_goals <= 8:
        raise ValueError(f"n_goals must be an integer from 2 to 8, got {n_goals!r}")
    if not isinstance(true_goal, (int, np.integer)) or isinstance(true_goal, bool) or not 0 <= true_goal < n_goals:
        raise ValueError(f"true_goal must index the goals (0 .. {n_goals - 1}), got {true_goal!r}")
    for name, v in (("spread", spread), ("goal_height", goal_height)):
        if not (isinstance(v, (int, float, np.integer, np.floating)) and np.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a positive finite number, got {v!r}")


def goal_row(n_goals, spread, goal_height):
    """``n_goals`` targets evenly spaced over ``x`` in ``[-spread/2, spread/2]`` at height ``goal_height``."""
    return np.column_stack([np.linspace(-spread / 2, spread / 2, n_goals), np.full(n_goals, goal_height)])


def legibility_paths(alpha=1.0, n_goals=2, true_goal=1, spread=2.0, goal_height=1.0, anticipative=False,
                     strictness=0.5):
    """The data behind :func:`legibility_view`: a dict with ``goals``, the ``predictable`` and ``legible``
    state paths (N+1, 2) and the observer's belief in the true goal along each (N+1,); ``legible`` is
    None (and ``message`` says why) when the QP's bound ``eta`` cannot be met."""
    _check(alpha, n_goals, true_goal, spread, goal_height, strictness)
    dyn, x0 = single_integrator(2, DT), np.zeros(2)
    goals = goal_row(n_goals, spread, goal_height)
    eta = -strictness * (spread / (n_goals - 1)) ** 2
    costs = [reaching_cost(g, DT) for g in goals]
    truth, others = costs[true_goal], [c for i, c in enumerate(costs) if i != true_goal]
    plain = solve(dyn, truth, x0, N)
    out = {"goals": goals, "predictable": plain.xs, "legible": None, "message": "", "eta": eta,
           "belief_predictable": posterior_over_time(dyn, costs, x0, plain.us)[:, true_goal], "belief_legible": None}
    try:
        if n_goals == 2 and anticipative:
            xs, us, _ = receding_horizon(dyn, truth, others, x0, N, linear_alpha_schedule(alpha / 4, 4 * alpha))
        elif n_goals == 2:
            sol = legible_trajectory(dyn, truth, others, x0, N, alpha)
            xs, us = sol.xs, sol.us
        elif anticipative:
            xs, us = receding_horizon_qp(dyn, truth, others, x0, N, lambda s: eta * (1 - s), every=10)
        else:
            xs, us, _ = multi_distractor_qp(dyn, truth, others, x0, N, eta)
    except ValueError as err:
        out["message"] = f"no legible path: {err}"
        return out
    out["legible"], out["belief_legible"] = xs, posterior_over_time(dyn, costs, x0, us)[:, true_goal]
    return out


def legibility_view(alpha=1.0, n_goals=2, true_goal=1, spread=2.0, goal_height=1.0, anticipative=False,
                    strictness=0.5):
    """Figure: paths to a row of ``n_goals`` targets (left) and the observer's belief in the true one
    over time (right). Two goals: ``alpha`` weighs the task against being legible (eq. (6.15)),
    ``anticipative`` replans at every step with alpha rising linearly from ``alpha / 4`` to ``4 alpha``
    (eq. (6.16)). More goals: each distractor's log likelihood ratio is bounded by
    ``eta = -strictness * spacing^2`` (nats, section 6.5's QP), ``anticipative`` replans every 10 steps
    with the bound loosening to 0 at T."""
    d = legibility_paths(alpha, n_goals, true_goal, spread, goal_height, anticipative, strictness)
    fig = Figure(figsize=(8.4, 3.8), dpi=STYLE["figure.dpi"], layout="constrained")
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.3, 1]})
    goals = d["goals"]
    for i, g in enumerate(goals):
        true = i == true_goal
        ax.scatter(*g, marker="*", s=160 if true else 90, color=PALETTE["green"] if true else "0.55", zorder=3,
                   label="true goal" if true else ("other goals" if i == (1 if true_goal == 0 else 0) else None))
    ax.plot(*d["predictable"].T, color="0.45", ls="--", label="predictable (true goal's optimum)")
    weight = f"alpha = {alpha:g}" if n_goals == 2 else f"eta = {d['eta']:.3g} nats"
    kind = f"anticipative legible ({weight} at t = 0)" if anticipative else f"legible ({weight})"
    if d["legible"] is not None:
        ax.plot(*d["legible"].T, color=CYCLE[0], label=kind)
    else:
        ax.text(0.5, 0.5, "no feasible legible path:\nlower the strictness", transform=ax.transAxes,
                ha="center", va="center", color=PALETTE["vermillion"])
    ax.plot(0, 0, "ko", ms=4)
    ax.set(xlabel="x position (arbitrary units)", ylabel="y position (arbitrary units)", aspect="equal")
    ax.set_title(f"{n_goals} goals, the true one is goal {true_goal + 1}", pad=4)
    fig.legend(*ax.get_legend_handles_labels(), loc="outside lower left", ncol=2, fontsize=7)
    t = np.linspace(0.0, 1.0, N + 1)
    bx.plot(t, d["belief_predictable"], color="0.45", ls="--", label="watching the predictable path")
    if d["belief_legible"] is not None:
        bx.plot(t, d["belief_legible"], color=CYCLE[0], label="watching the legible path")
    bx.axhline(1.0 / n_goals, color="0.8", lw=0.8, ls=":", label="prior")
    bx.set(xlabel="time watched, t / T", ylabel="P(true goal | motion so far)", ylim=(0, 1.02),
           title="observer's belief (Boltzmann, eq. 6.8)")
    bx.legend(fontsize=7, loc="lower right")
    return fig
