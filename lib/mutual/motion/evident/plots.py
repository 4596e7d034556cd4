"""Static figures of chapter 7 and Figure 6.1: the planar paths of H0, H1 and the legible optimum."""

from ...style import PALETTE

STYLE = {"H0": (PALETTE["black"], "H0 (ignorant)"), "H1": ("#8c8c8c", "H1 (avoidant)"),
         "legible": (PALETTE["green"], "legible: min (1+\u03b1) J1 - J0")}


def plot_paths(ax, results, task, point_label="h", title=None):
    """Draw the planar paths of H0 (black), H1 (grey) and legible (green) with start, goal and hazard.

    ``results`` maps a name to anything with ``xs`` (N+1, n) (e.g. an ILQRResult). Axes are in
    metres; the thesis's figures are simulations, and so are these.
    """
    for name, r in results.items():
        color, label = STYLE.get(name, (None, name))
        ax.plot(r.xs[:, 0], r.xs[:, 1], color=color, label=label)
    ax.plot(*task.x0[:2], "o", color=PALETTE["black"], ms=4, label="start")
    ax.plot(*task.goal, "*", color=PALETTE["blue"], ms=10, label="goal g")
    if len(task.keep_out):
        ax.plot(*task.keep_out.T, ".", color=PALETTE["vermillion"], label="keep-out states")
    else:
        ax.plot(*task.hazard, "X", color=PALETTE["vermillion"], ms=8, label=point_label)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if title:
        ax.set_title(title)
    return ax
