"""Explore chapters 2-3 (the notebooks' ``## Explore`` sections): plain functions of the
experiment's key parameters that return a ``matplotlib.figure.Figure``, for ipywidgets to call.

Each function reruns the chapter 3 experiment (:mod:`.experiment`, the chosen layout "four", the
thesis's set-up) on simulated demonstrations with the given number of demonstrations and slip; runs are
cached, so moving a control back answers at once, and :func:`precompute` fills the cache for the
notebook's slider values.
"""

from functools import lru_cache

import numpy as np
from matplotlib.figure import Figure

from ..style import PALETTE
from .candidates import constraint_candidates
from .demonstrations import sample_demonstrations
from .experiment import SEED, chapter3
from .inference import greedy_inference
from .plots import candidate_name, inference_panels, plot_actions, plot_states

N_DEMOS_OPTIONS = (10, 25, 50, 100, 200)
SLIP_OPTIONS = (0.0, 0.05, 0.1, 0.2, 0.3)
ROUNDS = 8


@lru_cache(maxsize=64)
def inference_run(n_demos=100, slip=0.1, rounds=ROUNDS, layout="four", seed=SEED):
    """(set-up, demonstrations, candidates, greedy result ranked by F) of the chapter 3
    experiment with ``n_demos`` simulated demonstrations and ``slip`` (cached)."""
    if isinstance(n_demos, bool) or not isinstance(n_demos, (int, np.integer)) or n_demos < 1:
        raise ValueError(f"n_demos: must be a positive integer, got {n_demos!r}")
    setup = chapter3(layout, slip=float(slip))
    demos = sample_demonstrations(setup.grid.mdp, int(n_demos), setup.truth, rng=seed)
    cand = constraint_candidates(setup.grid.mdp, demos)
    return setup, demos, cand, greedy_inference(setup.grid.mdp, demos, cand, rounds)


def precompute(n_demos_options=N_DEMOS_OPTIONS, slip_options=SLIP_OPTIONS):
    """Run (and cache) every combination of the sliders' values; returns how many."""
    for n in n_demos_options:
        for slip in slip_options:
            inference_run(int(n), float(slip))
    return len(n_demos_options) * len(slip_options)


def demonstrations_view(n_demos=100, slip=0.1):
    """F of every candidate in round 1 (states on the grid, actions on the compass), the
    constraints greedy inference chose (red X, in order) against the ground truth (white rings),
    and the F of each round's choice, true or not."""
    setup, demos, cand, result = inference_run(int(n_demos), float(slip))
    relevant, upper, truth = setup.candidate_ids(cand)
    F = np.exp(result.log_f[0]) if result.log_f else np.full(len(cand), np.nan)
    states, actions = cand.kind == "state", cand.kind == "action"
    fig = Figure(figsize=(9.0, 3.4), layout="constrained")
    grid_spec = fig.add_gridspec(2, 3, width_ratios=[3, 1.4, 2.6], height_ratios=[1, 1])
    ax_s, ax_a, ax_f = fig.add_subplot(grid_spec[:, 0]), fig.add_subplot(grid_spec[0, 1]), fig.add_subplot(grid_spec[:, 2])
    chosen_states = [cand.index[k] for k in result.chosen if states[k]]
    im = plot_states(ax_s, setup.grid, F[states], crosses=chosen_states,
                     title=f"round-1 F, chosen constraints (X)\n{n_demos} simulated demos, slip {slip:g}")
    for s in setup.states:
        c, r = setup.grid.coords(s)
        ax_s.plot(c, r, marker="o", mfc="none", mec="white", markersize=12, mew=1)
    plot_actions(ax_a, F[actions], crosses=[cand.index[k] for k in result.chosen if actions[k]], title="actions")
    fig.colorbar(im, ax=[ax_s, ax_a], shrink=0.7, label="F (grey: infeasible)")
    rounds = np.arange(1, len(result.chosen) + 1)
    colours = [PALETTE["blue"] if k in truth else PALETTE["vermillion"] for k in result.chosen]
    ax_f.bar(rounds, result.F, color=colours)
    for r, k in zip(rounds, result.chosen):
        ax_f.text(r, 0.02, candidate_name(setup.grid, cand, k).replace("state ", "").replace("action ", ""),
                  rotation=90, ha="center", va="bottom", fontsize=6, color="white")
    ax_f.set(xlabel="round", ylabel="F of the chosen constraint", ylim=(0, 1.05), xticks=rounds,
             title="blue: ground truth, red: untrue (simulated)")
    ax_f.title.set_fontsize(8)
    return fig


def inference_round_view(round=1, n_demos=100, slip=0.1):
    """Figure 3.2's panel for one ``round`` (1-based) of greedy inference."""
    setup, _, cand, result = inference_run(int(n_demos), float(slip))
    if not 1 <= round <= len(result.chosen):
        raise ValueError(f"round: must lie in 1..{len(result.chosen)}, got {round!r}")
    return inference_panels(setup.grid, cand, result, [round - 1], setup.states, setup.actions,
                            title=f"simulated: {n_demos} demos, slip {slip:g}")
