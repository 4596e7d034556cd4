"""Measures of a state path used to read Figures 6.2 and 6.3: when a coordinate reaches a level
(Figure 6.2's "time to move rightwards to x = 2") and how much of a stretch of the path is sideways
(Figure 6.3's "juke")."""

import numpy as np


def time_to_reach(xs, level, dt, axis=0):
    """First time at which coordinate ``axis`` of the trajectory ``xs`` reaches ``level``
    (linear interpolation between knots); ``inf`` if it never does."""
    x = np.asarray(xs, float)
    if x.ndim != 2 or not np.all(np.isfinite(x)) or not 0 <= axis < x.shape[1]:
        raise ValueError(f"xs must be a finite (N+1, n) trajectory with axis < n, got shape {x.shape}, axis {axis!r}")
    if not (np.isfinite(level) and np.isfinite(dt) and dt > 0):
        raise ValueError(f"level must be finite and dt positive, got level={level!r}, dt={dt!r}")
    x = x[:, axis] - level
    side = np.sign(x[0])
    if side == 0:
        return 0.0
    crossed = np.nonzero(side * x <= 0)[0]
    if crossed.size == 0:
        return np.inf
    k = crossed[0]
    return float((k - 1 + x[k - 1] / (x[k - 1] - x[k])) * dt)


def lateral_share(xs, start, stop, axis=0):
    """Fraction of the path length between knots ``start`` and ``stop`` that is lateral
    (along coordinate ``axis``): 1 for sideways motion, 0 for motion straight ahead."""
    steps = np.diff(np.asarray(xs, float), axis=0)[start:stop]
    return float(np.abs(steps[:, axis]).sum() / np.linalg.norm(steps, axis=1).sum())
