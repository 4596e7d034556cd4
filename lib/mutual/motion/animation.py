"""Animations of legible motion with the observer's belief over time (chapters 6-7): the paths
drawn as they unfold beside ``P(H1 | motion so far)`` (:mod:`mutual.motion.belief`).

Each function returns a ``matplotlib.animation.FuncAnimation`` on a plain
``matplotlib.figure.Figure`` (no pyplot, so nothing is shown twice in a notebook); save it with
``mutual.compendium.figures.save_animation``. Frames are drawn with fixed data and no clock, so a
rerun gives the same GIF bytes.
"""

import numpy as np
from matplotlib.animation import FuncAnimation
from matplotlib.figure import Figure

from ..style import PALETTE
from . import belief as belief_lib
from .evident.plots import STYLE
from .evident.task_belief import belief_over_time

MAX_FRAMES = 60


def _frame_steps(N, frames):
    if isinstance(frames, (bool, np.bool_)) or not (isinstance(frames, (int, np.integer)) and 2 <= frames <= MAX_FRAMES):
        raise ValueError(f"frames must be an integer in [2, {MAX_FRAMES}], got {frames!r}")
    return np.unique(np.linspace(0, N, frames).round().astype(int))


def belief_animation(paths, beliefs, dt, times=None, frames=40, goal=None, hazard=None, keep_out=None,
                     hazard_label="hazard h", title="", styles=None):
    """Animate planar ``paths`` ``{name: xs (N+1, n)}`` unfolding beside their observers' beliefs
    ``{name: P(H1 | u_{0:t})}`` known at steps ``times`` (default ``0..N``), ``dt`` seconds a step.

    Left: the paths so far (x-y, metres) with start, goal, hazard or keep-out states; right:
    ``P(H1 | motion so far)`` against time. ``frames`` (<= 60) evenly spaced steps are drawn.
    """
    if not paths or set(paths) != set(beliefs):
        raise ValueError("paths and beliefs must be non-empty dicts with the same names")
    xs = {k: np.asarray(v, float) for k, v in paths.items()}
    N = next(iter(xs.values())).shape[0] - 1
    if any(x.ndim != 2 or x.shape[0] != N + 1 or x.shape[1] < 2 or not np.all(np.isfinite(x)) for x in xs.values()):
        raise ValueError("every path must be a finite (N+1, n >= 2) array with the same N")
    times = np.arange(N + 1) if times is None else np.asarray(times, int)
    bs = {k: np.asarray(v, float) for k, v in beliefs.items()}
    if any(b.shape != times.shape or not np.all((b >= 0) & (b <= 1)) for b in bs.values()):
        raise ValueError(f"every belief must be {times.shape[0]} probabilities (one per entry of times)")
    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive finite number, got {dt!r}")
    steps = _frame_steps(N, frames)
    styles = {**STYLE, **(styles or {})}

    fig = Figure(figsize=(8.0, 3.8))
    ax, bx = fig.subplots(1, 2, gridspec_kw={"width_ratios": [1.2, 1]})
    goals = None if goal is None else np.atleast_2d(np.asarray(goal, float))
    marks = [x[:, :2] for x in xs.values()] + [a for a in (goals, None if hazard is None else
                                                          np.atleast_2d(hazard)) if a is not None]
    if keep_out is not None and len(keep_out):
        marks.append(np.asarray(keep_out, float))
    every = np.concatenate(marks)
    pad = 0.1 * np.ptp(every[:, :2], axis=0).max() + 0.2
    ax.set_xlim(every[:, 0].min() - pad, every[:, 0].max() + pad)
    ax.set_ylim(every[:, 1].min() - pad, every[:, 1].max() + pad)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    first = next(iter(xs.values()))[0]
    ax.plot(*first[:2], "o", color=PALETTE["black"], ms=4)
    if goals is not None:
        ax.plot(*goals.T, "*", color=PALETTE["blue"], ms=10, label="goal" if len(goals) == 1 else "goals")
    if keep_out is not None and len(keep_out):
        ax.plot(*np.asarray(keep_out).T, ".", color=PALETTE["vermillion"], label="keep-out")
    elif hazard is not None:
        ax.plot(*hazard, "X", color=PALETTE["vermillion"], ms=8, label=hazard_label)
    bx.set_xlim(0, N * dt)
    bx.set_ylim(-0.02, 1.02)
    bx.axhline(0.5, color="0.8", lw=0.8, ls=":")
    bx.set_xlabel("time t (s)")
    bx.set_ylabel("P(H1 | motion so far)")
    lines, dots, curves = {}, {}, {}
    for name in xs:
        color, label = styles.get(name, (None, name))
        lines[name], = ax.plot([], [], color=color, label=label)
        dots[name], = ax.plot([], [], "o", color=color, ms=4)
        curves[name], = bx.plot([], [], color=color, label=label)
    ax.legend(loc="upper center", bbox_to_anchor=(1.1, -0.3), ncol=3, fontsize=7)
    clock = ax.set_title("")
    fig.suptitle(title, fontsize=9)
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.36, top=0.86, wspace=0.3)

    def draw(k):
        for name, x in xs.items():
            lines[name].set_data(x[:k + 1, 0], x[:k + 1, 1])
            dots[name].set_data([x[k, 0]], [x[k, 1]])
            seen = times <= k
            curves[name].set_data(times[seen] * dt, bs[name][seen])
        clock.set_text(f"t = {k * dt:.2f} s (simulated)")
        return [*lines.values(), *dots.values(), *curves.values(), clock]

    return FuncAnimation(fig, draw, frames=list(steps), blit=False, repeat=False)


def task_belief_animation(task, w0, w1, results, times=None, frames=40, title=""):
    """:func:`belief_animation` for an :class:`mutual.motion.evident.safety.EvidentSafetyTask` and its
    solved hypotheses ``results = {"H0": ..., "H1": ..., "legible": ...}`` (ILQRResults): every
    path's belief is :func:`mutual.motion.evident.task_belief.belief_over_time` (exact for ``x' = u``,
    Laplace around the optimal continuation otherwise) at ``times`` (default: the frame steps)."""
    times = _frame_steps(task.steps, frames) if times is None else np.asarray(times, int)
    beliefs = {k: belief_over_time(task, w0, w1, r.us, results, times=times) for k, r in results.items()}
    return belief_animation({k: r.xs for k, r in results.items()}, beliefs, task.dt, times=times, frames=frames,
                            goal=task.goal, hazard=task.hazard, keep_out=task.keep_out, title=title)


def lq_belief_animation(dynamics, J0, J1, x0, controls, dt, frames=40, goals=None, title="", styles=None):
    """:func:`belief_animation` for a linear-quadratic problem of chapter 6 (e.g. Fig. 6.2): the
    exact Gaussian observer of eq. (6.8) for ``J0`` and ``J1``
    (:class:`mutual.motion.legible.problem.QuadraticCost`) under ``dynamics``
    (:class:`mutual.motion.legible.problem.LinearDynamics`) from ``x0``, and ``controls``
    ``{name: us (N, m)}`` whose paths are rolled out here. ``goals`` (k, 2) are drawn as stars."""
    if not controls:
        raise ValueError("controls must be a non-empty dict {name: us (N, m)}")
    us = {k: np.asarray(v, float) for k, v in controls.items()}
    N = next(iter(us.values())).shape[0]
    g0, g1 = belief_lib.lq_gaussian(dynamics, J0, x0, N), belief_lib.lq_gaussian(dynamics, J1, x0, N)
    dyn = dynamics.stages(0, N)
    A = np.broadcast_to(dyn.A, (N, dyn.n, dyn.n))
    B = np.broadcast_to(dyn.B, (N, dyn.n, dyn.m))
    paths = {}
    for name, u in us.items():
        xs = [np.asarray(x0, float)]
        for k in range(N):
            xs.append(A[k] @ xs[-1] + B[k] @ u[k])
        paths[name] = np.array(xs)
    beliefs = {k: belief_lib.posterior_over_time(u, g0, g1) for k, u in us.items()}
    return belief_animation(paths, beliefs, dt, frames=frames, goal=goals, title=title, styles=styles)
