"""How far the model's one-step predictions land from recorded next states, in cell widths (periodic
coordinates the short way round): for the checks of recordings (:mod:`.plausible`, :mod:`.controlcheck`) and
for inferring each step's action (:mod:`.mapping`)."""

import numpy as np


def spread(n, keep):
    """At most ``keep`` (at least 1) indices spread evenly over range(n)."""
    return np.unique(np.linspace(0, n - 1, max(1, min(n, keep))).astype(int))


def recorded_steps(problem, states, controls=None):
    """``(x, next, u)``: the steps states[:, k] -> states[:, k + 1] flattened and wrapped, with their controls
    (N, L, m) where all are recorded (u None: every step)."""
    n = states.shape[2]
    x, nxt = problem.grid.wrap(states[:, :-1].reshape(-1, n)), problem.grid.wrap(states[:, 1:].reshape(-1, n))
    if controls is None:
        return x, nxt, None
    u = controls.reshape(len(x), -1)
    ok = np.isfinite(u).all(axis=1)
    return x[ok], nxt[ok], u[ok]


def squared_misses(problem, states, controls=None):
    """(N, L): each recorded step's squared miss (cell widths) from states[:, k] to states[:, k + 1] under
    ``controls`` (N, L, m) clipped to the set's range (what acted at most), NaN where a control is not recorded;
    controls None: under the best control of the set, step by step."""
    N, L = states.shape[0], states.shape[1] - 1
    x, nxt, _ = recorded_steps(problem, states)
    if controls is None:
        return (step_misses(problem, x, nxt).min(axis=1) ** 2).reshape(N, L)
    u = np.clip(controls.reshape(N * L, -1), problem.controls.min(axis=0), problem.controls.max(axis=0))
    ok, squared = np.isfinite(u).all(axis=1), np.full(N * L, np.nan)
    squared[ok] = distance(problem.grid, problem.step(x[ok], u[ok]), nxt[ok]) ** 2
    return squared.reshape(N, L)


def mean_miss(problem, states, controls=None):
    """The mean of :func:`squared_misses` over the steps with a control (0.0 without one)."""
    squared = squared_misses(problem, states, controls)
    return float(np.nanmean(squared)) if np.isfinite(squared).any() else 0.0


def per_demonstration(problem, states, controls=None):
    """Each demonstration's mean of :func:`squared_misses` (NaN without a step with a control)."""
    squared = squared_misses(problem, states, controls)
    counts = np.isfinite(squared).sum(axis=1)
    return np.where(counts > 0, np.nansum(squared, axis=1) / np.maximum(counts, 1), np.nan)


def narrowest(grid):
    """Each coordinate's narrowest cell width (n,): the unit misses are counted in."""
    return np.array([np.min(grid.widths_1d(i)) for i in range(grid.ndim)])


def difference(grid, a, b, widths=None):
    """a - b in cell widths, periodic coordinates the short way round; ``widths`` the cell widths to count in
    (broadcast against a - b), by default :func:`narrowest`."""
    diff = a - b
    for i in np.flatnonzero(grid.periodic):
        period = grid.high[i] - grid.low[i]
        diff[..., i] = np.mod(diff[..., i] + period / 2, period) - period / 2
    return diff / (narrowest(grid) if widths is None else widths)


def distance(grid, a, b, widths=None):
    """Distances (in cell widths, periodic coordinates the short way round) between states a (..., n) and b."""
    return np.sqrt((difference(grid, a, b, widths) ** 2).sum(axis=-1))


def step_misses(problem, x, nxt, widths=None):
    """(k, A): each control's one-step prediction's distance from the states x (k, n) to nxt (k, n), in cell widths
    (``widths`` as for :func:`difference`)."""
    A = problem.n_actions
    pred = problem.step(np.repeat(x, A, axis=0), np.tile(problem.controls, (len(x), 1))).reshape(len(x), A, -1)
    return distance(problem.grid, pred, nxt[:, None, :], widths)
