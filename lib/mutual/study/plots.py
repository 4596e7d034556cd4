"""Drawing the chapter 5 study: reachable sets on a heading slice (Figs. 5.2, 5.5, 5.6), a frame
of a teaming trial (Fig. 5.3), condition means with their error bars (Fig. 5.4) and the
misaligned-expectations illustration (Fig. 5.1). Positions are in units of the obstacle radius
(the thesis's robots move at 3 units/s, eq. 5.1)."""

import numpy as np
from matplotlib.patches import Circle

from .design import OBSTACLE_RADIUS
from .stats import RMAnova, significance_stars

POSITION_LABEL = "{} (obstacle radii)"


def label_position_axes(ax, x=True, y=True):
    """Axis labels of a position plot (units: obstacle radii)."""
    if x:
        ax.set_xlabel(POSITION_LABEL.format("x"))
    if y:
        ax.set_ylabel(POSITION_LABEL.format("y"))


def heading_frame(states):
    """Rotate states so every heading is 0 (V of a disk obstacle is invariant under rotations)."""
    s = np.asarray(states, dtype=float)
    if s.ndim != 2 or s.shape[1] != 3 or not np.isfinite(s).all():
        raise ValueError(f"states must be a finite (n, 3) array of (x, y, theta), got shape {s.shape}")
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
    ax.add_patch(Circle(centre, radius, color=kw.pop("color", "black"), zorder=3, **kw))


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
    label_position_axes(ax)
    return times[k]


#: subjects drawn as thin lines at most: more make one grey band (200 000 lines took minutes to draw)
MAX_SUBJECT_LINES = 200


def plot_condition_means(ax, anova, tukey=None, colors=None, show_subjects=True):
    """Fig. 5.4: each level's mean with standard-error bars (SE = sd / sqrt(n) over subjects), the
    subjects' own values as thin lines (up to :data:`MAX_SUBJECT_LINES` subjects; more are not drawn),
    and Tukey significance brackets (``tukey``, optional)."""
    if not isinstance(anova, RMAnova):
        raise ValueError(f"anova must be an RMAnova, got {type(anova).__name__}")
    levels = list(anova.levels)
    cells = anova.cells[levels]
    errors = anova.standard_errors()
    means, se = np.array([anova.means[lv] for lv in levels]), np.array([errors[lv] for lv in levels])
    x = np.arange(len(levels))
    if show_subjects and len(cells) <= MAX_SUBJECT_LINES:
        for row in cells.to_numpy():
            ax.plot(x, row, color="0.75", lw=0.6, zorder=1)
    ax.bar(x, means, yerr=se, capsize=4, color=colors or None, alpha=0.85, zorder=2,
           error_kw={"zorder": 3, "label": f"mean ± SE (n = {anova.n_subjects})"})
    ax.set_xticks(x, [_short(level) for level in levels])
    with np.errstate(over="ignore"):
        top = float(max((means + se).max(), cells.to_numpy().max()))
        step = 0.09 * top if top > 0 else 0.1
    rows = [] if tukey is None else list(tukey.itertuples())
    for i, row in enumerate(rows):
        a, b = levels.index(row.A), levels.index(row.B)
        y = top + step * (i + 1)
        ax.plot([a, a, b, b], [y - step * 0.3, y, y, y - step * 0.3], color="black", lw=0.8)
        ax.text((a + b) / 2, y, f"{significance_stars(row.p)} (p={row.p:.3g})", ha="center", va="bottom", fontsize=7)
    high = top + step * (len(rows) + 1.2)
    if np.isfinite(high):                 # data near the largest double: leave matplotlib's limits
        ax.set_ylim(0, high)
    ax.set_xlabel(str(anova.within))
    return ax


def _short(name, width=24):
    """A level name for a tick label: at most ``width`` characters, cut with an ellipsis."""
    name = str(name)
    return name if len(name) <= width else name[:width - 1] + "\u2026"


def plot_misalignment(ax, approaches, supervisor, title=None, color="#0072B2", n_paths=12):
    """Fig. 5.1, one panel: robots that detected the obstacle avoiding it on their own safe set
    (``approaches`` from :func:`mutual.study.misalignment.supervised_approaches`), over the
    supervisor's unsafe set ``{V_S < mu}`` (shaded) and the states where the supervisor intervened
    (crosses: false positives, since every robot had detected the obstacle)."""
    plot_reachable(ax, supervisor.value_fn, supervisor.mu, color="#D55E00", fill=True)
    ax.plot([], [], color="#D55E00", lw=6, alpha=0.35, label="supervisor's unsafe set $V_S < \\mu$ (heading-right slice)")
    paths = approaches["paths"]
    for path in paths[:n_paths]:
        ax.plot(path[:, 0], path[:, 1], color=color, lw=0.8, alpha=0.8)
    ax.plot([], [], color=color, lw=0.8, label="robot paths (obstacle detected)")
    points = approaches["interventions"]
    share = approaches["intervened"].mean()
    if len(points):
        ax.scatter(points[:, 0], points[:, 1], marker="x", s=18, color="black", zorder=5,
                   label=f"supervisor interventions ({share:.0%} of {len(paths)} approaches)")
    else:
        ax.plot([], [], " ", label=f"no interventions in {len(paths)} approaches")
    if title:
        ax.set_title(title, fontsize=9)
    label_position_axes(ax)
    return ax
