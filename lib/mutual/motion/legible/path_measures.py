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


def _direction(steps):
    d = np.asarray(steps, float).sum(axis=0)
    norm = np.linalg.norm(d)
    return d / norm if norm > 0 else d


def heading_turn(xs, early=0.1, late=0.5):
    """Angle (degrees) between the path's overall direction over its first ``early`` fraction of knots and
    over its last ``late`` fraction: 0 for a straight path, 90 for a path that first moves sideways and then
    straight ahead."""
    steps = np.diff(np.asarray(xs, float)[:, :2], axis=0)
    n = len(steps)
    a, b = _direction(steps[:max(1, int(round(early * n)))]), _direction(steps[n - max(1, int(round(late * n))):])
    return float(np.degrees(np.arccos(np.clip(a @ b, -1.0, 1.0))))


def chord_deviation(xs, start):
    """Largest distance of the path from knot ``start`` on from the chord joining ``xs[start]`` and ``xs[-1]``,
    relative to the chord's length (0 for a straight stretch)."""
    part = np.asarray(xs, float)[start:, :2]
    chord = part[-1] - part[0]
    length = np.linalg.norm(chord)
    if length == 0:
        return 0.0
    rel = part - part[0]
    return float(np.abs(rel[:, 0] * chord[1] - rel[:, 1] * chord[0]).max() / length ** 2)


def outward_excursion(xs, goal, outward):
    """How far the path strays from the straight segment start -> ``goal`` towards ``outward`` (+1: larger x,
    -1: smaller x), relative to the segment's length: Figure 6.3's "exaggerate motion out in their respective
    direction" (0 when the path never leaves the segment on that side)."""
    xs = np.asarray(xs, float)[:, :2]
    seg = np.asarray(goal, float) - xs[0]
    length = np.linalg.norm(seg)
    normal = np.array([seg[1], -seg[0]]) / length           # points to larger x for a goal straight ahead
    if outward * normal[0] < 0:
        normal = -normal
    return float(max(0.0, ((xs - xs[0]) @ normal).max()) / length)


# Figure 6.3's "a sharp juke early and then straight shooting to the goal after alignment" (line 1268),
# fixed before any path was measured: over the first 10% of the horizon the path heads at least 20 degrees
# away from its direction over the last half, which is straight (within 2% of its chord's length) and ends
# within 10% of the goal's distance (twice the 4.8% the plain optimum of eq. (6.17) falls short by at T = 20).
JUKE_EARLY, JUKE_LATE, JUKE_TURN_DEG, JUKE_STRAIGHT, JUKE_REACH = 0.1, 0.5, 20.0, 0.02, 0.10


def juke(xs, goal):
    """Figure 6.3's juke (the constants above): a dict with the ``turn`` (degrees), the last half's
    ``deviation`` from its chord, the end's ``gap`` to the goal (relative to the goal's distance from the
    start) and ``juke`` (all three within their bounds)."""
    xs = np.asarray(xs, float)
    goal = np.asarray(goal, float)
    turn = heading_turn(xs, JUKE_EARLY, JUKE_LATE)
    deviation = chord_deviation(xs, len(xs) - 1 - int(round(JUKE_LATE * (len(xs) - 1))))
    gap = float(np.linalg.norm(xs[-1, :2] - goal) / np.linalg.norm(goal - xs[0, :2]))
    return {"turn": turn, "deviation": deviation, "gap": gap,
            "juke": bool(turn >= JUKE_TURN_DEG and deviation <= JUKE_STRAIGHT and gap <= JUKE_REACH)}
