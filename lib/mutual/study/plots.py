"""Drawing the chapter 5 study: reachable sets on a heading slice (Figs. 5.2, 5.5, 5.6) and a
frame of a teaming trial (Fig. 5.3)."""

import numpy as np

from .teaming import OBSTACLE_RADIUS


def heading_frame(states):
    """Rotate states so every heading is 0 (V of a disk obstacle is invariant under rotations)."""
    s = np.asarray(states, dtype=float)
    c, si = np.cos(-s[:, 2]), np.sin(-s[:, 2])
    return np.stack([c * s[:, 0] - si * s[:, 1], si * s[:, 0] + c * s[:, 1], np.zeros(len(s))], axis=1)


def plot_reachable(ax, value, level=0.0, color="0.3", fill=True, label=None, theta=0.0, linestyle="-",
                   obstacle=OBSTACLE_RADIUS):
    """The reachable set ``{V < level}`` on the ``theta`` slice (filled) and its boundary, over the
    true obstacle of radius ``obstacle`` (None: not drawn)."""
    xs, ys, v = value.theta_slice(theta)
    if fill:
        ax.contourf(xs, ys, v, levels=[-np.inf, level], colors=[color], alpha=0.35)
    cs = ax.contour(xs, ys, v, levels=[level], colors=[color], linewidths=1.4, linestyles=linestyle)
    if label:
        ax.plot([], [], color=color, linestyle=linestyle, label=label)
    if obstacle is not None:
        _obstacle(ax, obstacle)
    ax.set_aspect("equal")
    return cs


def _obstacle(ax, radius, centre=(0.0, 0.0), **kw):
    import matplotlib.pyplot as plt
    ax.add_patch(plt.Circle(centre, radius, color=kw.pop("color", "black"), zorder=3, **kw))


def plot_frame(ax, record, config, index=-1, trail=3.0):
    """One frame of a recorded Phase III trial (Fig. 5.3): robots, their recent paths, obstacles."""
    times = np.asarray(record.times)
    k = index % len(times)
    robots = np.asarray(record.robots)
    past = (times <= times[k]) & (times >= times[k] - trail)
    for r in range(robots.shape[1]):
        path = robots[past, r]
        jump = np.flatnonzero(np.hypot(*np.diff(path[:, :2], axis=0).T) > 2.0)   # a restart breaks the trail
        for seg in np.split(path, jump + 1):
            ax.plot(seg[:, 0], seg[:, 1], color="0.6", lw=1)
    seen = np.asarray(record.detected)[k].mean(axis=0)
    for o, c in enumerate(np.asarray(record.obstacles)[k]):
        _obstacle(ax, config.obstacle_radius, c, color="black")
        ax.annotate(f"{seen[o]:.0%}", c, xytext=(0, 9), textcoords="offset points", ha="center", fontsize=6)
    x, y, th = robots[k].T
    ax.quiver(x, y, np.cos(th), np.sin(th), color="#0072B2", scale=25, width=0.012, zorder=4)
    for xd in (0.0, config.width):
        ax.axvspan(xd - 1, xd + 1, color="#E69F00", alpha=0.3, lw=0)
    ax.set_xlim(-2, config.width + 2)
    ax.set_ylim(0, config.height)
    ax.set_aspect("equal")
    return times[k]


def avoidance_onset(value, level=0.0, resolution=400):
    """How far ahead of the obstacle centre a car driving straight at it (theta = 0, y = 0) meets
    ``{V < level}``: where an avoidance arc on that safe set begins (nan if never within the grid)."""
    w = value.grid_spec.half_width
    xs = np.linspace(-w, 0.0, resolution)
    v = value.interp(np.stack([xs, np.zeros_like(xs), np.zeros_like(xs)], axis=1))
    inside = np.flatnonzero(v < level)
    return float(-xs[inside[0]]) if len(inside) else float("nan")
