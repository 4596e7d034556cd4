"""Drawing gridworld constraint inference (Figures 3.1-3.3): values on the grid's states and on
the compass of actions, constraints marked by a red X. Figures are built as
``matplotlib.figure.Figure`` (no pyplot state), so the notebooks, the Explore functions and the
animation share them."""

import matplotlib
import numpy as np
from matplotlib.animation import FuncAnimation
from matplotlib.colors import LogNorm, Normalize
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from ..style import PALETTE
from .gridworld import GRID_ACTIONS, GRID_DELTAS

_COMPASS = {a: (1 + dy, 1 + dx) for a, (dx, dy) in zip(range(len(GRID_ACTIONS)), GRID_DELTAS)}  # (row, col) in 3x3
_SHORT = {"loiter": "Lo"}
GAIN_FLOOR = 1e-4   # the smallest gain -log F the log colour scale shows apart (F = 1 - 1e-4)


def _cmap(cmap):
    return matplotlib.colormaps[cmap].with_extremes(bad="0.85")


def _cross(ax, col, row, size=10):
    ax.plot(col, row, marker="x", color=PALETTE["vermillion"], markersize=size, mew=2.5, linestyle="none")


def plot_states(ax, grid, values, vmin=0.0, vmax=1.0, cmap="viridis", crosses=(), title=None, labels=True, norm=None):
    """Shade each state of ``grid`` by ``values`` (nan: grey) on [``vmin``, ``vmax``] or by ``norm`` (e.g. a
    ``LogNorm``), mark ``crosses`` (state ids) with a red X, S and G at the start and goal; axes in grid
    columns and rows (row 0 at the bottom)."""
    image = np.ma.masked_invalid(np.asarray(values, dtype=float).reshape(grid.height, grid.width))
    im = ax.imshow(image, origin="lower", cmap=_cmap(cmap), norm=norm or Normalize(vmin, vmax))
    for name, (c, r) in (("S", grid.start), ("G", grid.goal)):
        ax.text(c, r, name, ha="center", va="center", color="white", fontsize=8, fontweight="bold")
    for s in crosses:
        _cross(ax, *grid.coords(s))
    step = 2 if max(grid.width, grid.height) > 6 else 1
    ax.set_xticks(range(0, grid.width, step))
    ax.set_yticks(range(0, grid.height, step))
    ax.tick_params(labelsize=6, length=2)
    if labels:
        ax.set_xlabel("column", fontsize=7)
        ax.set_ylabel("row", fontsize=7)
    if title:
        ax.set_title(title, fontsize=8)
    return im


def plot_actions(ax, values, vmin=0.0, vmax=1.0, cmap="viridis", crosses=(), title=None, norm=None):
    """Shade the eight compass moves and loiter (centre, "Lo") by ``values`` (nan: grey; ``norm`` as in
    :func:`plot_states`), each cell labelled with its action in a colour that reads on its shade; mark
    ``crosses`` with a red X."""
    image = np.full((3, 3), np.nan)
    for a, v in enumerate(values):
        image[_COMPASS[a]] = v
    colormap, norm = _cmap(cmap), norm or Normalize(vmin, vmax)
    im = ax.imshow(np.ma.masked_invalid(image), origin="lower", cmap=colormap, norm=norm)
    for a, name in enumerate(GRID_ACTIONS):
        r, c = _COMPASS[a]
        v = image[r, c]
        shade = colormap(norm(v)) if np.isfinite(v) else (0.85, 0.85, 0.85, 1)
        ink = "black" if 0.299 * shade[0] + 0.587 * shade[1] + 0.114 * shade[2] > 0.5 else "white"
        ax.text(c, r + 0.28, _SHORT.get(name, name), ha="center", va="center", fontsize=7, color=ink,
                fontweight="bold")
    for a in crosses:
        r, c = _COMPASS[a]
        _cross(ax, c, r - 0.1, size=8)
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=8)
    return im


def candidate_name(grid, candidates, k):
    """'state (col, row)' or 'action NE' for candidate ``k`` on ``grid``."""
    return grid.label(candidates.kind[k], candidates.index[k])


def round_values(result, i, scale="F"):
    """Every candidate's value in round ``i``: F, or with ``scale="gain"`` its gain -log F clipped below at
    :data:`GAIN_FLOOR` (nan where infeasible or already chosen)."""
    if scale not in ("F", "gain"):
        raise ValueError(f"scale: must be 'F' or 'gain', got {scale!r}")
    log_f = np.asarray(result.log_f[i], dtype=float)
    return np.exp(log_f) if scale == "F" else np.maximum(-log_f, GAIN_FLOOR)


def gain_norm(result, rounds):
    """One logarithmic colour scale for the gains -log F of ``rounds``: from :data:`GAIN_FLOOR` to the largest."""
    top = max(float(np.nanmax(round_values(result, i, "gain"))) for i in rounds)
    return LogNorm(GAIN_FLOOR, max(top, 10 * GAIN_FLOOR))


def draw_round(ax_states, ax_actions, grid, candidates, result, i, truth_states=(), truth_actions=(), scale="F",
               norm=None):
    """Round ``i`` of greedy inference on two axes: states and actions shaded by F (or, with ``scale="gain"``,
    by -log F on ``norm``, a log scale that tells apart candidates whose F all lie near 1), earlier choices
    marked with a red X, the round's choice outlined in orange, the ground truth circled."""
    states, actions = candidates.kind == "state", candidates.kind == "action"
    F, values = np.exp(result.log_f[i]), round_values(result, i, scale)
    norm = norm if scale == "gain" else None
    before, chosen = result.chosen[:i], result.chosen[i]
    title = f"round {i + 1}: {candidate_name(grid, candidates, chosen)}\nF = {F[chosen]:.3f}"
    if scale == "gain":
        title += f", -log F = {-np.log(F[chosen]):.2g}"
    im = plot_states(ax_states, grid, values[states], crosses=[candidates.index[k] for k in before if states[k]],
                     title=title, norm=norm)
    plot_actions(ax_actions, values[actions], crosses=[candidates.index[k] for k in before if actions[k]], norm=norm)
    target, pos = ((ax_states, grid.coords(candidates.index[chosen])) if states[chosen] else
                   (ax_actions, _COMPASS[candidates.index[chosen]][::-1]))
    target.add_patch(Rectangle((pos[0] - 0.5, pos[1] - 0.5), 1, 1, fill=False, edgecolor=PALETTE["orange"],
                               linewidth=2))
    for s in truth_states:
        c, r = grid.coords(s)
        ax_states.plot(c, r, marker="o", mfc="none", mec="white", markersize=12, mew=1)
    for a in truth_actions:
        r, c = _COMPASS[a]
        ax_actions.plot(c, r, marker="o", mfc="none", mec="white", markersize=10, mew=1)
    return im


def gain_panel(ax, result, truth=(), thesis_F=0.96):
    """The likelihood gain -log F of each round's choice on a log axis (Figure 3.3's "the continued scaling
    shrinks by an order of magnitude and then effectively halts as F retracts"), each point labelled with its
    F to three decimals; ground-truth choices in red; the thesis's F = ``thesis_F`` as a dashed line."""
    gains = -np.log(result.F)
    rounds = np.arange(1, len(gains) + 1)
    true = np.array([k in truth for k in result.chosen])
    ax.semilogy(rounds, gains, color="0.5", lw=1)
    ax.semilogy(rounds[true], gains[true], "o", color=PALETTE["vermillion"], label="ground truth")
    ax.semilogy(rounds[~true], gains[~true], "s", color=PALETTE["blue"], label="untrue")
    for r, g, F in zip(rounds, gains, result.F):
        ax.annotate(f"F = {F:.3f}", (r, g), textcoords="offset points", xytext=(4, 4), fontsize=6)
    ax.axhline(-np.log(thesis_F), color="0.4", ls="--", lw=0.8)
    ax.text(rounds[0], -np.log(thesis_F) * 1.15, f"thesis: F = {thesis_F:g}", fontsize=6, color="0.3")
    ax.set(xlabel="round", ylabel="gain -log F (nats per demonstration)", xticks=rounds)
    ax.legend(fontsize=6, loc="upper right")
    return ax


def inference_panels(grid, candidates, result, rounds, truth_states=(), truth_actions=(), title=None, truth=None,
                     scale="F"):
    """One column per round in ``rounds``: states (top) and actions (bottom) shaded by F or, with
    ``scale="gain"``, by -log F on one log scale (:func:`draw_round`). With ``truth`` (the ground truth's
    candidate ids) a last column shows every round's gain -log F (:func:`gain_panel`). Returns a ``Figure``."""
    rounds = list(rounds)
    if truth is not None:
        fig = Figure(figsize=(2.2 * max(len(rounds), 1) + 3.6, 4.0), layout="constrained")
        panels, side = fig.subfigures(1, 2, width_ratios=[2.2 * max(len(rounds), 1) + 0.8, 2.8])
        gain_panel(side.subplots(), result, truth)
        inference_panels_into(panels, grid, candidates, result, rounds, truth_states, truth_actions, scale)
    else:
        fig = Figure(figsize=(2.2 * max(len(rounds), 1) + 0.8, 4.0), layout="constrained")
        inference_panels_into(fig, grid, candidates, result, rounds, truth_states, truth_actions, scale)
    if title:
        fig.suptitle(title, fontsize=9)
    return fig


def inference_panels_into(fig, grid, candidates, result, rounds, truth_states=(), truth_actions=(), scale="F"):
    """The panels of :func:`inference_panels` drawn into ``fig`` (a Figure or SubFigure)."""
    axes = fig.subplots(2, max(len(rounds), 1), gridspec_kw={"height_ratios": [3, 1.3]}, squeeze=False)
    norm = gain_norm(result, rounds) if scale == "gain" and rounds else None
    im = None
    for j, i in enumerate(rounds):
        im = draw_round(axes[0, j], axes[1, j], grid, candidates, result, i, truth_states, truth_actions, scale, norm)
        if j:
            axes[0, j].set_ylabel("")
    if im is not None:
        label = "F = Z$_{C+}$/Z$_{C0}$" if scale == "F" else "-log F"
        fig.colorbar(im, ax=axes[0, :].tolist(), shrink=0.8, label=label + "; grey: infeasible or chosen")
    return fig


def inference_animation(grid, candidates, result, truth_states=(), truth_actions=(), hold=2,
                        title="greedy inference, round by round (simulated demonstrations)"):
    """The rounds of Figure 3.2 as a ``FuncAnimation`` (each round shown for ``hold`` frames)."""
    fig = Figure(figsize=(4.2, 4.4), layout="constrained")
    ax_s, ax_a = fig.subplots(2, 1, gridspec_kw={"height_ratios": [3, 1.2]})
    fig.suptitle(title, fontsize=8)
    frames = [i for i in range(len(result.chosen)) for _ in range(hold)]
    im = draw_round(ax_s, ax_a, grid, candidates, result, 0, truth_states, truth_actions)
    fig.colorbar(im, ax=[ax_s], shrink=0.8, label="F")

    def show(i):
        ax_s.clear()
        ax_a.clear()
        draw_round(ax_s, ax_a, grid, candidates, result, i, truth_states, truth_actions)
        return []

    return FuncAnimation(fig, show, frames=frames, blit=False)
