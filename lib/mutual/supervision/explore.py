"""Interactive views for the Explore section of notebook 03: plain functions that
return a :class:`matplotlib.figure.Figure`, so the notebook's widgets stay thin and tests can
call them without a browser.

:func:`safe_set_view` simulates a noisy idealized supervisor (Sec. 4.3) with internal turn rate
``w_max``, margin ``mu`` and noise ``sigma``, fits the library by maximum likelihood (eq. 4.12),
and shows the learned safe set at the robots' avoidance level ``alpha`` (Sec. 4.5) with the
interventions it avoids. To answer within about a second on 2 cores it uses the exact
closed-form value functions (``method="closed-form"``, no disturbance) on a medium grid, built
once per session; the thesis's figures use the HJ solver (notebook 03).
"""

import functools
import warnings

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Circle
from scipy import stats

from ..style import PALETTE
from ..inputs import check_number
from .dubins import rotate_to_heading
from .fit import LibraryEdgeWarning, fit_supervisor
from .reachability import avoid_value_function, value_library
from .supervisor import NoisySupervisor, collect_interventions
from .value_function import GridSpec

EXPLORE_GRID = GridSpec(8.0, (81, 81, 48))
EXPLORE_W_MAXES = tuple(0.25 * np.arange(1, 13))
RADIUS = 1.0
START_DISTANCE = 7.5


@functools.lru_cache(maxsize=1)
def explore_library():
    """The closed-form library over ``w_max`` = 0.25, 0.5, ..., 3 on ``EXPLORE_GRID`` (built once)."""
    return value_library(EXPLORE_W_MAXES, RADIUS, EXPLORE_GRID, method="closed-form")


@functools.lru_cache(maxsize=64)
def _supervisor_value(w_max):
    return avoid_value_function(w_max, RADIUS, EXPLORE_GRID, method="closed-form")


def safe_set_summary(w_max=0.75, mu=0.5, sigma=0.1, alpha=0.7, n_interventions=40, seed=0):
    """The numbers :func:`safe_set_view` draws: the simulated interventions, the fit and what ``alpha`` avoids.

    Returns a dict with ``states`` (n, 3), ``fit`` (:class:`~mutual.supervision.fit.SupervisorFit`),
    ``values`` (the learned V at the interventions), ``avoided`` (bool per intervention: at or below
    ``alpha``, so robots avoiding at ``alpha`` keep clear of it) and ``expected`` (``Phi((alpha - mu*) / sigma*)``).
    """
    w_max = round(check_number("w_max", w_max, 0.25, 3.0), 6)
    mu = check_number("mu", mu, -1.0, 3.0)
    sigma = check_number("sigma", sigma, 0.0, 2.0)
    alpha = check_number("alpha", alpha, -1.0, 5.0)
    n = int(check_number("n_interventions", n_interventions, 2, 2000))
    if n != n_interventions:
        raise ValueError(f"n_interventions must be an integer, got {n_interventions!r}")
    supervisor = NoisySupervisor(_supervisor_value(w_max), mu, sigma)
    states = collect_interventions(supervisor, n, np.random.default_rng(seed), START_DISTANCE)
    library = explore_library()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LibraryEdgeWarning)  # shown in the figure's text instead
        fit = fit_supervisor(library, states, values="grid")  # the supervisor judges on the grid's values
    values = fit.value_fn.interp(states)
    expected = float(stats.norm.cdf((alpha - fit.mu) / fit.sigma))
    return {"states": states, "fit": fit, "values": values, "avoided": values <= alpha, "expected": expected,
            "w_max": w_max, "mu": mu, "sigma": sigma, "alpha": alpha}


def safe_set_view(w_max=0.75, mu=0.5, sigma=0.1, alpha=0.7, n_interventions=40, seed=0):
    """Figure: a simulated supervisor's interventions, the learned safe set at level ``alpha``, and
    which interventions robots avoiding at ``alpha`` keep clear of (Sec. 4.3-4.5).

    Left: the ``theta = 0`` slice (robot heading right, every intervention rotated about the obstacle
    to that heading; V is invariant under the rotation): the region ``{V_hat < alpha}`` robots keep
    out of, the supervisor's own ``mu`` level set, and the interventions (filled: avoided; open: inside
    the robots' safe set, where this supervisor would raise a false positive). Right: the learned
    values at the interventions, the fitted Gaussian ``N(mu*, sigma*^2)`` (eq. 4.8) and ``alpha``.
    """
    d = safe_set_summary(w_max, mu, sigma, alpha, n_interventions, seed)
    fit, avoided, values = d["fit"], d["avoided"], d["values"]
    fig = Figure(figsize=(9.6, 4.0), layout="constrained")
    left, right = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.25, 1]})

    xs, ys, v_hat = fit.value_fn.theta_slice(0.0, resolution=161)
    _, _, v_true = _supervisor_value(d["w_max"]).theta_slice(0.0, resolution=161)
    left.contourf(xs, ys, v_hat, levels=[-10, d["alpha"]], colors=[PALETTE["orange"]], alpha=0.35)
    left.contour(xs, ys, v_hat, levels=[d["alpha"]], colors=[PALETTE["vermillion"]], linewidths=1.6)
    left.contour(xs, ys, v_true, levels=[d["mu"]], colors=[PALETTE["blue"]], linewidths=1.6, linestyles="--",
                 zorder=4)
    left.add_patch(Circle((0, 0), RADIUS, color=PALETTE["black"]))
    canon = rotate_to_heading(d["states"], 0.0)
    left.scatter(canon[avoided, 0], canon[avoided, 1], s=22, color=PALETTE["vermillion"],
                 label=f"avoided ({avoided.sum()})")
    left.scatter(canon[~avoided, 0], canon[~avoided, 1], s=22, facecolors="none", edgecolors=PALETTE["blue"],
                 label=f"not avoided ({(~avoided).sum()})")
    left.plot([], [], color=PALETTE["vermillion"], label=rf"learned level $\alpha$ ($\hat\omega = {fit.w_max:g}$)")
    left.plot([], [], color=PALETTE["blue"], ls="--", label=rf"supervisor's $\mu$ level ($\omega = {d['w_max']:g}$)")
    left.set(xlim=(-7.5, 3.5), ylim=(-4.5, 4.5), aspect="equal", xlabel="x (m)", ylabel="y (m)",
             title=r"Simulated supervisor, heading $\theta = 0$ slice")
    left.legend(loc="lower right", fontsize=7)

    lo, hi = min(values.min(), d["alpha"]) - 0.3, max(values.max(), d["alpha"]) + 0.3
    right.hist(values, bins=np.linspace(lo, hi, 25), density=True, color=PALETTE["sky"], alpha=0.7,
               label=f"learned V at {fit.n} interventions")
    grid = np.linspace(lo, hi, 200)
    right.plot(grid, stats.norm.pdf(grid, fit.mu, fit.sigma), color=PALETTE["black"],
               label=rf"fit: $\hat\mu = {fit.mu:.2f}$, $\hat\sigma = {fit.sigma:.2f}$")
    right.axvline(d["alpha"], color=PALETTE["vermillion"], label=rf"$\alpha = {d['alpha']:.2f}$")
    edge = f"\nfit on the library's {fit.boundary} member" if fit.boundary else ""
    right.set(xlabel=r"learned value $\hat V(x)$ at the intervention (m)", ylabel="density (1/m)",
              title="Learned values at the interventions")
    right.set_ylim(0, 1.7 * right.get_ylim()[1])
    right.legend(loc="upper right", fontsize=7, title_fontsize=8, alignment="left",
                 title=f"avoids {avoided.mean():.0%} of interventions (model: {d['expected']:.0%}){edge}")
    fig.suptitle(rf"Simulated noisy supervisor $\omega = {d['w_max']:g}$, $\mu = {d['mu']:g}$, "
                 rf"$\sigma = {d['sigma']:g}$ (closed-form value functions)", fontsize=10)
    return fig
