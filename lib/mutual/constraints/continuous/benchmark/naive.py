"""The baselines a user would try before any inference: the tightest constraint the data allow.

* Bounds (:func:`tightest_bound`) -- the largest (or smallest) recorded value of a coordinate: the
  tightest bound consistent with the data. For its *error* the benchmark gives it the true
  coordinate and side (an oracle: the number the issue compares with). Which coordinate and side a
  naive user would pick without being told (:func:`naive_pick`): the coordinate and side against
  whose extreme the trajectories ride -- the most recorded samples within 2 % of the box's width of
  that extreme (angles that wrap around have no extreme and are left out). It always answers, so
  on unconstrained recordings
  it always reports one false positive.
* Disks (:func:`largest_empty_disk`) -- the largest disk in the obstacles' plane that holds no
  recorded point and whose centre lies in the convex hull of the recorded points (the classical
  largest empty circle: its centre is a vertex of the points' Voronoi diagram). No oracle: it
  answers wherever the data leave the largest hole.
* Boxes (:func:`largest_empty_box`) -- the largest-area axis-aligned rectangle holding no recorded
  point, within the recorded points' bounding box, found on a raster of ``RASTER`` x ``RASTER``
  cells (its edges are within one raster cell of the exact one).
The kind (disk or box) is the truth's for the car (a disk on unconstrained recordings).
"""

import numpy as np
from scipy.spatial import Delaunay, Voronoi, cKDTree

from ..regions import Bound, Box, Disk

RASTER = 200
RIDE_SHARE = 0.02


def tightest_bound(states, dim, side):
    """The :class:`Bound` on coordinate ``dim`` and ``side`` at the recorded extreme of ``states`` (N, d)."""
    values = np.asarray(states, dtype=float)[:, dim]
    return Bound(int(dim), side, float(values.max() if side == "upper" else values.min()))


def naive_pick(states, low, high, periodic=None):
    """The tightest bound on the coordinate (not one of the ``periodic`` ones) and side with the most
    samples within RIDE_SHARE of the box's width of their extreme (ties: the first coordinate, upper
    side first)."""
    states = np.asarray(states, dtype=float)
    periodic = np.zeros(states.shape[1], dtype=bool) if periodic is None else np.asarray(periodic, dtype=bool)
    best, count = None, -1
    for dim in np.flatnonzero(~periodic):
        band = RIDE_SHARE * (high[dim] - low[dim])
        for side in ("upper", "lower"):
            bound = tightest_bound(states, dim, side)
            near = int(np.sum(np.abs(states[:, dim] - bound.value) <= band))
            if near > count:
                best, count = bound, near
    return best


def largest_empty_disk(points, dims=(0, 1)):
    """The largest empty :class:`Disk` with its centre in the convex hull of ``points`` (N, 2)."""
    p = np.unique(np.round(np.asarray(points, dtype=float), 9), axis=0)
    vertices = Voronoi(p).vertices
    vertices = vertices[Delaunay(p).find_simplex(vertices) >= 0]          # inside the hull
    radius, _ = cKDTree(p).query(vertices)
    k = int(np.argmax(radius))
    return Disk(tuple(dims), (float(vertices[k, 0]), float(vertices[k, 1])), float(radius[k]))


def largest_empty_box(points, dims=(0, 1), raster=RASTER):
    """The largest-area empty axis-aligned :class:`Box` within the bounding box of ``points`` (N, 2),
    on a ``raster`` x ``raster`` grid (maximal rectangle of empty raster cells, row by row)."""
    p = np.asarray(points, dtype=float)
    lo, hi = p.min(axis=0), p.max(axis=0)
    size = (hi - lo) / raster
    cell = np.minimum(((p - lo) / size).astype(int), raster - 1)
    full = np.zeros((raster, raster), dtype=bool)
    full[cell[:, 0], cell[:, 1]] = True
    heights = np.zeros(raster, dtype=int)
    best = (0, None)
    for i in range(raster):                           # rows along the first coordinate
        heights = np.where(full[i], 0, heights + 1)
        area, j0, j1, h = _largest_in_histogram(heights)
        if area > best[0]:
            best = (area, (i - h + 1, i + 1, j0, j1))
    r0, r1, c0, c1 = best[1]
    return Box(tuple(dims), (float(lo[0] + r0 * size[0]), float(lo[1] + c0 * size[1])),
               (float(lo[0] + r1 * size[0]), float(lo[1] + c1 * size[1])))


def _largest_in_histogram(heights):
    """(area, first column, end column, height) of the largest rectangle under a histogram (stack scan)."""
    stack, best = [], (0, 0, 0, 0)
    for j, h in enumerate(np.append(heights, 0)):
        start = j
        while stack and stack[-1][1] >= h:
            start, top = stack.pop()
            if top * (j - start) > best[0]:
                best = (top * (j - start), start, j, top)
        stack.append((start, h))
    return best
