"""Live views for chapter 7's Explore section: move the legibility weight ``alpha`` and the hazard
of Fig. 7.2 and see the H0, H1 and legible paths and the observer's belief over time.

Plain functions returning a ``matplotlib.figure.Figure`` (no pyplot), so notebooks wrap them in
``ipywidgets.interact`` and tests call them directly. Every solve reuses one compiled iLQR, so a
new setting costs milliseconds of optimisation; the belief (:mod:`mutual.motion.belief`) is
computed at a few instants only.
"""

from functools import lru_cache

import numpy as np
from matplotlib.figure import Figure

from ...style import PALETTE
from ..trajopt import ILQRError
from . import safety as es
from .plots import STYLE, plot_paths
from .task_belief import belief_over_time

BELIEF_POINTS = 9  # instants at which the belief is computed in the live view


@lru_cache(maxsize=64)
def _solve(alpha, hazard, steps):
    task, w0, w1 = es.figure_scenario("7.2", steps=steps)
    task = es.EvidentSafetyTask(x0=task.x0, goal=task.goal, hazard=np.array(hazard), horizon=task.horizon,
                                steps=steps)
    results, errors = {}, {}
    for name, w in es.hypothesis_set(w0, w1, alpha).items():
        try:
            results[name] = es.solve(task, w)
        except ILQRError as err:
            errors[name] = str(err)
    beliefs = {}
    if "H0" in results and "H1" in results:
        times = np.unique(np.linspace(0, steps, BELIEF_POINTS).round().astype(int))
        for name, r in results.items():
            try:
                beliefs[name] = (times, belief_over_time(task, w0, w1, r.us, results, times=times))
            except ValueError as err:
                errors[f"belief of {name}"] = str(err)
    return task, results, beliefs, errors


def evident_view(alpha=0.5, hazard_x=-2.0, hazard_y=2.0, steps=40):
    """Fig. 7.2's three optima (Dubins car, eq. (7.5)) with the hazard at ``(hazard_x, hazard_y)`` and
    legibility weight ``alpha`` (eq. (6.15)), beside ``P(H1 | motion so far)`` for each path.

    A legible objective that is unbounded for this ``alpha`` is reported in the figure instead
    of a path. Returns a ``matplotlib.figure.Figure`` (simulated paths).
    """
    for name, value in (("alpha", alpha), ("hazard_x", hazard_x), ("hazard_y", hazard_y)):
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, float, np.integer, np.floating)) \
                or not np.isfinite(value):
            raise ValueError(f"{name} must be a finite number, got {value!r}")
    if alpha <= 0:
        raise ValueError(f"alpha must be positive (alpha <= 0 makes (1 + alpha) J1 - J0 unbounded), got {alpha!r}")
    task, results, beliefs, errors = _solve(round(float(alpha), 3), (round(float(hazard_x), 3),
                                                                      round(float(hazard_y), 3)), int(steps))
    fig = Figure(figsize=(8.0, 3.6))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.2, 1]})
    plot_paths(ax, results, task, point_label="hazard h",
               title=f"Dubins car, \u03b1 = {alpha:g}, h = ({hazard_x:g}, {hazard_y:g}) (simulated)")
    ax.legend(loc="upper center", bbox_to_anchor=(1.1, -0.26), ncol=3, fontsize=7)
    for name, (times, b) in beliefs.items():
        color, label = STYLE.get(name, (None, name))
        bx.plot(times * task.dt, b, "o-", color=color, ms=3, label=label)
    bx.axhline(0.5, color="0.8", lw=0.8, ls=":")
    bx.set(xlim=(0, task.horizon), ylim=(-0.02, 1.02), xlabel="time t (s)", ylabel="P(H1 | motion so far)",
           title="observer's belief (Laplace, simulated)")
    if errors:
        ax.text(0.02, 0.02, "\n".join(f"{k}: {v[:70]}..." for k, v in errors.items()), transform=ax.transAxes,
                fontsize=6, color=PALETTE["vermillion"], va="bottom")
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.34, top=0.9, wspace=0.3)
    return fig
