"""Interactive views of the cycle for the notebook's Explore section: plain functions that return a
``matplotlib.figure.Figure`` (slow parts cached, so a redraw takes about a second on 2 cores)."""

from functools import lru_cache

import numpy as np
from matplotlib.figure import Figure

from ..constraints import GRID_ACTIONS, gridworld, plot_states, sample_demonstrations, state_action_visitation
from ..style import PALETTE
from ..supervision import NoisySupervisor, fit_supervisor
from .discrete import legible_robots
from .learning import ConstraintSet, pooled_inference
from .observer import expected_log_odds, step_log_ratio
from .plots import ROBOT_COLOURS, _mark_constraints, _supervisor_panel
from .supervision import closed_form_library, closed_form_value_function, collect_interventions, false_positive_study

# the world of notebook 07 (chapter 3's ground truth, Sec. 3.3)
TRUTH_CELLS = ((4, 0), (2, 6), (4, 7), (6, 6))
TRUTH_ACTIONS = ("NW", "SW")
TASKS = (((0, 0), (8, 0)), ((0, 6), (8, 6)))


@lru_cache(maxsize=4)
def _world(width=9, slip=0.1, psi=0.25):
    grids = [gridworld(width, width, start=s, goal=g, slip=slip, sparse=True) for s, g in TASKS]
    truth = ConstraintSet([grids[0].state(*c) for c in TRUTH_CELLS], psi, [GRID_ACTIONS.index(a) for a in TRUTH_ACTIONS])
    return grids, truth


@lru_cache(maxsize=64)
def _inferred(n_demos, seed):
    grids, truth = _world()
    tasks = [(g.mdp, sample_demonstrations(g.mdp, n_demos, truth.mask(g.mdp), rng=np.random.default_rng([seed, 10 * (i + 1)])))
             for i, g in enumerate(grids)]
    return pooled_inference(tasks)


def discrete_view(n_demos=50, alpha=1.0, seed=0):
    """Infer from ``n_demos`` simulated demonstrations of each task (pooled, stopping rule), then show the
    robot's expected visits in task 2 and the observer's exact expected log-odds for the plain and the
    legible robot (task weight ``alpha``, anticipatory)."""
    if not (isinstance(n_demos, (int, np.integer)) and n_demos >= 1):
        raise ValueError(f"n_demos: must be a positive integer, got {n_demos!r}")
    if not (np.isfinite(alpha) and alpha > 0):
        raise ValueError(f"alpha: must be positive, got {alpha!r}")
    grids, truth = _world()
    run = _inferred(int(n_demos), int(seed))
    mdp = grids[1].mdp
    fig = Figure(figsize=(8.5, 3.3))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"wspace": 0.3})
    visits = state_action_visitation(mdp, run.mask).sum(axis=(0, 2))
    plot_states(ax, grids[1], np.log10(visits + 1e-3), vmin=-3, vmax=1,
                title=f"task 2 with constraints learned from {n_demos} + {n_demos} demos")
    _mark_constraints(ax, grids[1], truth, run.labels)
    observer = step_log_ratio(mdp, truth.mask(mdp))
    for name, policy in legible_robots(mdp, run.mask, float(alpha)).items():
        mean, refuted = expected_log_odds(mdp, policy, observer)
        bx.plot(np.arange(len(mean)), mean, color=ROBOT_COLOURS[name],
                label=f"{name} (H1 refuted w.p. {refuted[-1]:.2f})")
    bx.axhline(np.log(19), color=PALETTE["vermillion"], ls="--", lw=0.8, label="95% from a 50% prior")
    bx.set(xlabel="step t", ylabel="expected log-odds of H1 (exact)", title=f"the observer, alpha = {alpha:g} (simulated)")
    bx.legend(fontsize=7)
    return fig


@lru_cache(maxsize=1)
def _library():
    return (closed_form_library(0.25 * np.arange(1, 13), 1.0), closed_form_value_function(1.0, 1.0),
            closed_form_value_function(1.0, 2.0))


def continuous_view(n_interventions=40, k=2.0, seed=0, n_robots=60):
    """Fit notebook 07's simulated supervisor (w_max 0.75, mu 0.5, sigma 0.1) from ``n_interventions`` and
    compare false positives of robots avoiding at ``mu + k sigma`` of the fit with the standard and
    conservative sets (``n_robots`` scenes)."""
    if not (isinstance(n_interventions, (int, np.integer)) and n_interventions >= 2):
        raise ValueError(f"n_interventions: need at least 2, got {n_interventions!r}")
    library, standard, conservative = _library()
    supervisor = NoisySupervisor(library[library.index_of(0.75)], 0.5, 0.1)
    states = collect_interventions(supervisor, int(n_interventions), np.random.default_rng([seed, 40]), 7.5)
    fit = fit_supervisor(library, states, values="grid")  # the supervisor above judges on the grid's values
    fp = false_positive_study(supervisor, {"learned": (fit.value_fn, fit.level(k)), "standard": (standard, 0.0),
                                           "conservative": (conservative, 0.0)}, n_robots, np.random.default_rng(seed), 7.5)
    fig = Figure(figsize=(8.5, 3.3))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"wspace": 0.3})
    _supervisor_panel(ax, states, fit, supervisor, k)
    ax.set_title(f"fit from {n_interventions} interventions (simulated)", fontsize=9)
    bx.bar(np.arange(len(fp)), fp["p_false_positive"], color=PALETTE["sky"])
    bx.set_xticks(np.arange(len(fp)), fp["controller"])
    bx.set(ylim=(0, 1.05), ylabel="P(false-positive intervention)", title=f"learned set at mu + {k:g} sigma")
    return fig
