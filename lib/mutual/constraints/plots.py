"""Drawing gridworld constraint inference (Figures 3.1-3.3): values on the grid's
states and on the compass of actions, with constraints marked by a red X."""

import matplotlib.pyplot as plt
import numpy as np

from ..style import PALETTE
from .gridworld import GRID_ACTIONS, GRID_DELTAS

_COMPASS = {a: (1 + dy, 1 + dx) for a, (dx, dy) in zip(range(len(GRID_ACTIONS)), GRID_DELTAS)}  # (row, col) in 3x3


def _cross(ax, col, row, **kw):
    ax.plot(col, row, marker="x", color=PALETTE["vermillion"], markersize=kw.pop("size", 10), mew=2.5,
            linestyle="none", **kw)


def plot_states(ax, grid, values, vmin=0.0, vmax=1.0, cmap="viridis", crosses=(), title=None):
    """Shade each state of ``grid`` by ``values`` (nan: grey), mark ``crosses`` (state ids) with a red X."""
    image = np.ma.masked_invalid(np.asarray(values, dtype=float).reshape(grid.height, grid.width))
    colormap = plt.get_cmap(cmap).with_extremes(bad="0.85")
    im = ax.imshow(image, origin="lower", cmap=colormap, vmin=vmin, vmax=vmax)
    for name, (c, r) in (("S", grid.start), ("G", grid.goal)):
        ax.text(c, r, name, ha="center", va="center", color="white", fontsize=8, fontweight="bold")
    for s in crosses:
        _cross(ax, *grid.coords(s))
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=8)
    return im


def plot_actions(ax, values, vmin=0.0, vmax=1.0, cmap="viridis", crosses=(), title=None):
    """Shade the eight compass moves and loiter (centre) by ``values`` (nan: grey); mark ``crosses``."""
    image = np.full((3, 3), np.nan)
    for a, v in enumerate(values):
        image[_COMPASS[a]] = v
    colormap = plt.get_cmap(cmap).with_extremes(bad="0.85")
    im = ax.imshow(np.ma.masked_invalid(image), origin="lower", cmap=colormap, vmin=vmin, vmax=vmax)
    for a, name in enumerate(GRID_ACTIONS):
        r, c = _COMPASS[a]
        ax.text(c, r - 0.32, "L" if name == "loiter" else name, ha="center", va="center", fontsize=6, color="white")
    for a in crosses:
        r, c = _COMPASS[a]
        _cross(ax, c, r, size=8)
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=8)
    return im


def inference_panels(grid, candidates, result, rounds, truth_states=(), truth_actions=()):
    """One column per round in ``rounds``: states (top) and actions (bottom) shaded by F,
    earlier choices marked with a red X and the round's choice outlined. Returns the figure."""
    fig, axes = plt.subplots(2, len(rounds), figsize=(2.1 * len(rounds), 3.4),
                             gridspec_kw={"height_ratios": [3, 1.3]}, squeeze=False)
    states, actions = candidates.kind == "state", candidates.kind == "action"
    for j, i in enumerate(rounds):
        F = np.exp(result.log_f[i])
        before = result.chosen[:i]
        chosen = result.chosen[i]
        done_states = [candidates.index[k] for k in before if states[k]]
        done_actions = [candidates.index[k] for k in before if actions[k]]
        title = f"round {i + 1}: {candidate_name(grid, candidates, chosen)}\nF = {F[chosen]:.2f}"
        im = plot_states(axes[0, j], grid, F[states], crosses=done_states, title=title)
        plot_actions(axes[1, j], F[actions], crosses=done_actions)
        target_ax, pos = ((axes[0, j], grid.coords(candidates.index[chosen])) if states[chosen] else
                          (axes[1, j], _COMPASS[candidates.index[chosen]][::-1]))
        target_ax.add_patch(plt.Rectangle((pos[0] - 0.5, pos[1] - 0.5), 1, 1, fill=False,
                                          edgecolor=PALETTE["orange"], linewidth=2))
        for s in truth_states:
            c, r = grid.coords(s)
            axes[0, j].plot(c, r, marker="o", mfc="none", mec="white", markersize=12, mew=1)
        for a in truth_actions:
            r, c = _COMPASS[a]
            axes[1, j].plot(c, r, marker="o", mfc="none", mec="white", markersize=10, mew=1)
    fig.colorbar(im, ax=axes[0, :].tolist(), shrink=0.8, label="F (grey: infeasible or chosen)")
    return fig


def candidate_name(grid, candidates, k):
    """'state (col, row)' or 'action NE' for candidate ``k`` on ``grid``."""
    return grid.label(candidates.kind[k], candidates.index[k])
