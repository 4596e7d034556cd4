"""Figures of continuous constraint inference: demonstrations in a plane of two coordinates with the
true and inferred regions, the discretized transitions of a cell, and error curves."""

import numpy as np

from ...style import CYCLE, PALETTE
from .regions import Box, Bound, Disk

TRUE, INFERRED = PALETTE["vermillion"], PALETTE["blue"]


def _broken(points, grid, dims):
    """(N, 2) points of one trajectory, with nan rows where a periodic coordinate wraps (no lines across)."""
    xy = points[:, list(dims)].astype(float)
    jumps = np.zeros(len(xy) - 1, dtype=bool)
    for n, i in enumerate(dims):
        if grid.periodic[i]:
            jumps |= np.abs(np.diff(xy[:, n])) > 0.5 * (grid.high[i] - grid.low[i])
    if not jumps.any():
        return xy
    return np.insert(xy, np.flatnonzero(jumps) + 1, np.nan, axis=0)


def draw_trajectories(ax, grid, states, dims=(0, 1), color="0.35", alpha=0.5, lw=0.7):
    """Demonstrations (N, L+1, d) projected onto the coordinates ``dims``; starts as dots."""
    for trajectory in states:
        xy = _broken(np.asarray(trajectory), grid, dims)
        ax.plot(xy[:, 0], xy[:, 1], color=color, alpha=alpha, lw=lw)
    starts = np.asarray([t[0] for t in states])
    ax.plot(starts[:, dims[0]], starts[:, dims[1]], "o", color="k", ms=2.5)


def draw_region(ax, region, dims, color, label=None, fill=True):
    """A region in the plane of ``dims``: a bound on either coordinate as a line with its forbidden
    side shaded, a disk or box in that plane as its outline. Returns whether it was drawn."""
    i, j = dims
    if isinstance(region, Bound) and region.dim in dims:
        line = ax.axvline if region.dim == i else ax.axhline
        line(region.value, color=color, lw=1.4, label=label)
        if fill:
            lo, hi = (ax.get_xlim() if region.dim == i else ax.get_ylim())
            span = (region.value, hi) if region.side == "upper" else (lo, region.value)
            (ax.axvspan if region.dim == i else ax.axhspan)(*span, color=color, alpha=0.12, lw=0)
        return True
    if isinstance(region, Disk) and tuple(region.dims) == (i, j):
        ax.add_patch(_patch("Circle", region.center, region.radius, color, fill, label))
        return True
    if isinstance(region, Box) and tuple(region.dims) == (i, j):
        ax.add_patch(_patch("Rectangle", region.low, (region.high[0] - region.low[0], region.high[1] - region.low[1]),
                            color, fill, label))
        return True
    return False


def _patch(kind, anchor, size, color, fill, label):
    import matplotlib.patches as mp
    style = dict(facecolor=color if fill else "none", alpha=0.3 if fill else 1.0, edgecolor=color, lw=1.4, label=label)
    return mp.Circle(anchor, size, **style) if kind == "Circle" else mp.Rectangle(anchor, *size, **style)


def phase_panel(ax, grid, states, dims=(0, 1), truth=(), inferred=(), title=None):
    """Demonstrations in the plane of ``dims`` with the true (red, filled) and inferred (blue) regions,
    each inferred region labelled with its round (1, 2, ...); equal aspect when both coordinates share a
    unit (a disk is drawn as a disk)."""
    ax.set_xlim(grid.low[dims[0]], grid.high[dims[0]])
    ax.set_ylim(grid.low[dims[1]], grid.high[dims[1]])
    if grid.units[dims[0]] == grid.units[dims[1]]:
        ax.set_aspect("equal", adjustable="box")
    draw_trajectories(ax, grid, states, dims)
    for n, region in enumerate(truth):
        draw_region(ax, region, dims, TRUE, "true constraint" if n == 0 else None)
    drawn = []
    for number, region in enumerate(inferred, start=1):
        if region is None:
            continue
        shown = draw_region(ax, region, dims, INFERRED, "inferred (round)" if not drawn else None, fill=False)
        if shown:
            label_round(ax, region, dims, number)
        drawn.append(shown)
    ax.set_xlabel(_axis(grid, dims[0]))
    ax.set_ylabel(_axis(grid, dims[1]))
    if title:
        ax.set_title(title, fontsize=9)
    return any(drawn)


def label_round(ax, region, dims, number):
    """The round number beside an inferred region: at a bound's line, at an obstacle's centre."""
    style = dict(color=INFERRED, fontsize=8, fontweight="bold", ha="center", va="center",
                 bbox=dict(boxstyle="circle,pad=0.15", fc="white", ec=INFERRED, lw=0.8))
    if isinstance(region, Bound):
        lo, hi = (ax.get_ylim() if region.dim == dims[0] else ax.get_xlim())
        at = lo + (0.92 - 0.1 * ((number - 1) % 8)) * (hi - lo)
        xy = (region.value, at) if region.dim == dims[0] else (at, region.value)
    else:
        xy = tuple(region.center) if isinstance(region, Disk) else \
            (0.5 * (region.low[0] + region.high[0]), 0.5 * (region.low[1] + region.high[1]))
    ax.annotate(str(number), xy, **style)


def _axis(grid, i):
    return f"{grid.names[i]}" + (f" [{grid.units[i]}]" if grid.units[i] else "")


def panels(grid):
    """Pairs of coordinates to draw: (0, 1), (2, 3), ... (an odd last one paired with its neighbour)."""
    dims = list(range(grid.ndim))
    pairs = [tuple(dims[k:k + 2]) for k in range(0, len(dims) - 1, 2)]
    if len(dims) % 2:
        pairs.append((dims[-2], dims[-1]))
    return pairs


def inference_figure(inference, truth=(), title=None, width=110):
    """A figure of an inference (:class:`~.inference.ContinuousInference` or :class:`~.cells.CellInference`):
    the demonstrations in every pair of coordinates with the inferred regions labelled by round (and, if
    given, the true ones); chosen cells shaded; the title lists the rounds, wrapped at ``width`` characters."""
    import textwrap

    import matplotlib.pyplot as plt
    grid, states = inference.problem.grid, inference.states
    pairs = panels(grid)
    fig, axes = plt.subplots(1, len(pairs), figsize=(3.8 * len(pairs) + 0.6, 3.8), squeeze=False)
    regions = inference.chosen_regions()
    for ax, dims in zip(axes[0], pairs):
        phase_panel(ax, grid, states, dims, truth, regions)
        if grid.ndim == 2 and hasattr(inference, "candidates"):
            shade_cells(ax, grid, [int(inference.candidates.candidates.index[k]) for k in inference.result.chosen
                                   if inference.candidates.regions[k] is None])
    if axes[0][0].get_legend_handles_labels()[0]:
        axes[0][0].legend(fontsize=7, loc="best")
    chosen = "; ".join(f"{n}: {label}" for n, label in enumerate(inference.labels(), 1))
    text = title or f"inferred, by round: {chosen or 'none'}"
    fig.suptitle("\n".join(textwrap.wrap(text, width)), fontsize=8)
    fig.tight_layout()
    return fig


def shade_cells(ax, grid, cells, color=INFERRED):
    """Shade 2-D cells (flat numbers)."""
    import matplotlib.patches as mp
    if not len(cells):
        return
    low, width = grid.cell_boxes(np.asarray(cells))
    for (x, y), (w, h) in zip(low, width):
        ax.add_patch(mp.Rectangle((x, y), w, h, facecolor=color, alpha=0.35, edgecolor="none"))


def transition_panel(ax, problem, S, cell, action, title=None):
    """S(cell, action, .) of a 2-D grid as shaded cells, the cell outlined, the true successor of its
    centre marked and (for the sampling scheme) the images of a dense sample of the cell drawn."""
    import matplotlib.patches as mp
    g = problem.grid
    row = S[cell * problem.n_actions + action]
    low, width = g.cell_boxes(row.indices)
    for (x, y), (w, h), p in zip(low, width, row.data):
        ax.add_patch(mp.Rectangle((x, y), w, h, facecolor=PALETTE["blue"], alpha=0.15 + 0.85 * p, edgecolor="none"))
    (x, y), (w, h) = g.cell_boxes([cell])[0][0], g.cell_boxes([cell])[1][0]
    ax.add_patch(mp.Rectangle((x, y), w, h, facecolor="none", edgecolor="k", lw=1.0))
    u = problem.controls[action][None]
    grid_points = np.stack(np.meshgrid(np.linspace(x, x + w, 12), np.linspace(y, y + h, 12)), -1).reshape(-1, 2)
    image = problem.step(grid_points, np.repeat(u, len(grid_points), axis=0))
    ax.plot(image[:, 0], image[:, 1], ".", color=PALETTE["orange"], ms=1.5, label="image of the cell")
    nxt = problem.step(g.centers([cell]), u)
    ax.plot(nxt[0, 0], nxt[0, 1], "x", color=TRUE, ms=6, label="successor of the centre")
    pad = 2.5 * np.asarray([w, h])
    ax.set_xlim(min(x, nxt[0, 0]) - pad[0], max(x + w, nxt[0, 0]) + pad[0])
    ax.set_ylim(min(y, nxt[0, 1]) - pad[1], max(y + h, nxt[0, 1]) + pad[1])
    ax.set_xlabel(_axis(g, 0))
    ax.set_ylabel(_axis(g, 1))
    if title:
        ax.set_title(title, fontsize=9)


def error_panel(ax, table, x, y, by, title=None, logx=False, marker="o"):
    """``y`` against ``x`` for each value of ``by`` in a table (mean over repeated rows, with the range)."""
    colours = CYCLE
    for n, (label, rows) in enumerate(table.groupby(by, sort=False)):
        stats = rows.groupby(x)[y].agg(["mean", "min", "max"]).reset_index()
        c = colours[n % len(colours)]
        ax.plot(stats[x], stats["mean"], marker=marker, color=c, label=str(label), lw=1.2, ms=4)
        if (stats["max"] > stats["min"]).any():
            ax.fill_between(stats[x], stats["min"], stats["max"], color=c, alpha=0.15, lw=0)
    if logx:
        from matplotlib.ticker import NullFormatter, ScalarFormatter
        ax.set_xscale("log")
        ax.set_xticks(sorted(table[x].unique()))
        ax.xaxis.set_major_formatter(ScalarFormatter())
        ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    if title:
        ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)


def cell_values_panel(ax, grid, values, label, cmap="viridis", vmin=0.0, vmax=1.0):
    """A 2-D grid's cells shaded by ``values`` (X,) (nan: grey), on the grid's own edges."""
    image = np.ma.masked_invalid(np.asarray(values, dtype=float).reshape(grid.shape).T)
    mesh = ax.pcolormesh(grid.edges[0], grid.edges[1], image, cmap=cmap, vmin=vmin, vmax=vmax, shading="flat")
    ax.set_facecolor("0.85")
    ax.figure.colorbar(mesh, ax=ax, shrink=0.85, label=label)
    ax.set_xlabel(_axis(grid, 0))
    ax.set_ylabel(_axis(grid, 1))
    return mesh
