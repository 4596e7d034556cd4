"""How far the recordings pin an obstacle down: the moves of the true obstacle that the demonstrated
states cannot rule out.

A demonstration says where the demonstrator went, not why it went round. Moved by ``d``, the true disk
or box may still hold no demonstrated point: it is then exactly as consistent with where the
demonstrators went as the truth. A method that reads the obstacle from that alone (the largest empty
obstacle, the tightest consistent bound's analogue) can be off by up to the farthest such move,
:func:`centre_slack`, without the data saying so; a method can place it closer only by trusting a
model of how the demonstrator steers (the inference's maximum-entropy demonstrator, KKT's local
optimality), which hand-written demonstrators need not follow. Moves are tried on a lattice of ``STEP``
within ``REACH`` of the truth along each axis of the obstacle's plane.
"""

import math

import numpy as np
from scipy.spatial import cKDTree

from ..regions import Box, Disk
from .cases import case_recording, cases

REACH = 1.0   # moves up to this far along each axis of the plane are tried (the plane's units)
STEP = 0.01   # the lattice of moves (the plane's units)
_CHUNK = 2048  # moves per block of the box test


def _lattice(reach, step):
    axis = step * np.arange(-round(reach / step), round(reach / step) + 1)
    dx, dy = np.meshgrid(axis, axis, indexing="ij")
    return np.c_[dx.ravel(), dy.ravel()]


def indistinguishable_moves(truth, points, reach=REACH, step=STEP):
    """The moves (K, 2) of the obstacle ``truth`` (a :class:`~..regions.Disk` or :class:`~..regions.Box`)
    in its plane, on a lattice of ``step`` in [-reach, reach]^2, after which it holds none of the
    ``points`` (N, d) strictly inside, as :meth:`inside` counts them."""
    if not isinstance(truth, (Disk, Box)):
        raise ValueError(f"truth: must be a Disk or a Box, got {type(truth).__name__}")
    moves = _lattice(reach, step)
    p = np.asarray(points, dtype=float)[:, list(truth.dims)]
    if isinstance(truth, Disk):
        distance, _ = cKDTree(p).query(np.asarray(truth.center) + moves)
        return moves[distance >= truth.radius]
    low, high = np.asarray(truth.low, dtype=float), np.asarray(truth.high, dtype=float)
    p = p[np.all((p > low - reach) & (p < high + reach), axis=1)]  # only these can fall inside a moved box
    free = np.ones(len(moves), dtype=bool)
    for start in range(0, len(moves), _CHUNK):
        m = moves[start:start + _CHUNK, None, :]
        free[start:start + _CHUNK] = ~np.any(np.all((p > low + m) & (p < high + m), axis=2), axis=1)
    return moves[free]


def centre_slack(truth, points, reach=REACH, step=STEP):
    """``(farthest, spans, at_reach)``: the length of the farthest indistinguishable move (nan when even the
    truth holds a point), the extent of those moves along each axis of the plane (2,), and whether they
    reach the lattice's edge (then the slack is at least ``reach``)."""
    moves = indistinguishable_moves(truth, points, reach, step)
    if not len(moves):
        return math.nan, np.full(2, np.nan), False
    farthest = float(np.max(np.hypot(moves[:, 0], moves[:, 1])))
    spans = moves.max(axis=0) - moves.min(axis=0)
    return farthest, spans, bool(np.any(np.abs(moves) >= reach - 1e-9))


def slack_table(split="all", systems=None, reach=REACH, step=STEP):
    """Per obstacle case of ``split``: how far the true obstacle can move with no demonstrated point inside
    (:func:`centre_slack`; "at least" where the moves reach the lattice's edge)."""
    import pandas as pd
    rows = []
    for case in cases(split, systems):
        truth = case.regions()
        if not truth or not isinstance(truth[0], (Disk, Box)):
            continue
        farthest, spans, at_reach = centre_slack(truth[0], np.concatenate(case_recording(case).states), reach, step)
        rows.append({"case": case.id, "split": case.split, "truth": case.truth_text,
                     "farthest indistinguishable move (m)": farthest, "at least (lattice edge)": at_reach,
                     "span along x (m)": spans[0], "span along y (m)": spans[1]})
    return pd.DataFrame(rows)


def recorded_ranges(split="all", systems=None):
    """Per case of ``split`` (``systems``: some of them): the smallest and largest recorded value of each
    state coordinate, the truth and its kind: where the demonstrators went, truth by truth."""
    import pandas as pd
    rows = []
    for case in cases(split, systems):
        states = np.concatenate(case_recording(case).states)
        names = case.setup.system_file().problem.grid.names
        row = {"case": case.id, "split": case.split, "truth": case.truth_text}
        for i, name in enumerate(names):
            row[f"{name} min"], row[f"{name} max"] = float(states[:, i].min()), float(states[:, i].max())
        rows.append(row)
    return pd.DataFrame(rows)
