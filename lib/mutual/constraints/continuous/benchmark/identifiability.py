"""How far the recordings pin an obstacle down: how far the true obstacle can slide from where it is
without ever covering a demonstrated state.

A demonstration says where the demonstrator went, not why it went round. Slid by ``d`` along a path on which
it never covers a demonstrated point, the true disk or box is exactly as consistent with where the
demonstrators went as the truth: the data alone leave its centre at least ``|d|`` open. (Positions cut off
from the truth by the data, say beyond a lane, are left out: they are other explanations, not slack.) A
method places it closer only with knowledge beyond where the demonstrators went: a model of how they steer
(the inference's maximum-entropy demonstrator, KKT's local optimality), or a prior on where obstacles may be.
Moves are tried on a lattice of ``step`` within ``reach`` of the truth along each axis of its plane; a
slide that reaches the lattice's edge is reported as "at least".
"""

import math

import numpy as np
from scipy import ndimage
from scipy.spatial import cKDTree

from ..regions import Box, Disk
from .cases import case_recording, cases

REACH = 1.0   # moves up to this far along each axis of the plane are tried (the plane's units)
STEP = 0.01   # the lattice of moves (the plane's units)
_CHUNK = 2048  # moves per block of the box test


def _lattice(reach, step):
    """The moves (n, n, 2) ``step * (i, j)`` for |i|, |j| <= reach / step (never past ``reach``)."""
    if not (np.isfinite(step) and step > 0 and np.isfinite(reach) and reach >= step):
        raise ValueError(f"reach, step: need 0 < step <= reach, got reach={reach!r}, step={step!r}")
    k = int(math.floor(reach / step + 1e-9))
    axis = step * np.arange(-k, k + 1)
    return np.stack(np.meshgrid(axis, axis, indexing="ij"), axis=-1)


def _free(truth, points, moves):
    """Booleans (n, n): the moved obstacle holds none of the ``points`` (N, 2) strictly inside."""
    flat = moves.reshape(-1, 2)
    if isinstance(truth, Disk):
        distance, _ = cKDTree(points).query(np.asarray(truth.center) + flat)
        return (distance >= truth.radius).reshape(moves.shape[:2])
    low, high = np.asarray(truth.low, dtype=float), np.asarray(truth.high, dtype=float)
    far = np.abs(flat).max()
    points = points[np.all((points > low - far) & (points < high + far), axis=1)]  # only these can be covered
    free = np.ones(len(flat), dtype=bool)
    for start in range(0, len(flat), _CHUNK):
        m = flat[start:start + _CHUNK, None, :]
        free[start:start + _CHUNK] = ~np.any(np.all((points > low + m) & (points < high + m), axis=2), axis=1)
    return free.reshape(moves.shape[:2])


def indistinguishable_moves(truth, points, reach=REACH, step=STEP):
    """The moves (K, 2) of the obstacle ``truth`` (a :class:`~..regions.Disk` or :class:`~..regions.Box`)
    in its plane, on a lattice of ``step`` within ``reach`` per axis, to which it slides from where it is
    through lattice neighbours without ever holding one of the ``points`` (N, d) strictly inside, as
    :meth:`inside` counts them; none when the truth itself holds a point."""
    if not isinstance(truth, (Disk, Box)):
        raise ValueError(f"truth: must be a Disk or a Box, got {type(truth).__name__}")
    moves = _lattice(reach, step)
    free = _free(truth, np.asarray(points, dtype=float)[:, list(truth.dims)], moves)
    centre = moves.shape[0] // 2
    if not free[centre, centre]:
        return np.zeros((0, 2))
    labels, _ = ndimage.label(free)
    return moves[labels == labels[centre, centre]]


def centre_slack(truth, points, reach=REACH, step=STEP):
    """``(farthest, spans, at_reach)``: the length of the farthest slide of :func:`indistinguishable_moves`
    (nan when the truth itself holds a point), the extent of the slides along each axis of the plane (2,),
    and whether they reach the lattice's edge (then the slack is at least ``farthest``)."""
    moves = indistinguishable_moves(truth, points, reach, step)
    if not len(moves):
        return math.nan, np.full(2, np.nan), False
    farthest = float(np.max(np.hypot(moves[:, 0], moves[:, 1])))
    spans = moves.max(axis=0) - moves.min(axis=0)
    edge = step * math.floor(reach / step + 1e-9)
    return farthest, spans, bool(np.any(np.abs(moves) >= edge - 1e-9))


def slack_table(split="all", systems=None, reach=REACH, step=STEP):
    """Per obstacle case of ``split``: how far the true obstacle slides without covering a demonstrated point
    (:func:`centre_slack`; "at least" where the slides reach the lattice's edge)."""
    import pandas as pd
    rows = []
    for case in cases(split, systems):
        truth = case.regions()
        if not truth or not isinstance(truth[0], (Disk, Box)):
            continue
        farthest, spans, at_reach = centre_slack(truth[0], np.concatenate(case_recording(case).states), reach, step)
        rows.append({"case": case.id, "split": case.split, "truth": case.truth_text,
                     "farthest slide (m)": farthest, "at least (lattice edge)": at_reach,
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
