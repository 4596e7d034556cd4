"""Candidate constraints as continuous parameters: the most likely member of each family.

Lemma 3.2.1 says: among chance thresholds the demonstrations allow, the lowest is the most likely.
The same argument holds for any family of regions ordered by inclusion: a larger forbidden region
removes more trajectories, so Z_{C+} is smaller and every demonstration that stays out of it is more
likely (deterministic dynamics: the gain is -log F, :mod:`.pointwise`). Hence, in the demonstrations'
own units and with no grid in the way:

* **bounds** -- for each coordinate and side the most likely bound is the *tightest consistent* one: the
  demonstrations' largest (``x_i <= max``) or smallest (``x_i >= min``) recorded value;
* **disks** and **boxes** in a plane -- for a given centre, the largest one no demonstration enters
  (radius = the distance from the centre to the demonstrations' path, a square box's half-width = the
  max-norm distance), capped at ``largest``; the centre is then searched: every lattice point of the
  plane, and a finer lattice around the best, twice. An obstacle is only identifiable where the
  demonstrations pass it on more than one side: if every path point that touches it (within
  ``TOUCH`` of its size) lies in one half-plane through its centre, a larger obstacle farther away would be
  consistent too and more likely -- the data say "that side is empty", not where an obstacle is -- so
  such a centre is no candidate (this is where phantom obstacles beside the demonstrations come from).

The demonstrations' path is their recorded samples joined by straight segments, checked at
``PATH_POINTS`` points per segment (the same check :func:`.pointwise.blocked` applies to the model's moves).
"""

import numpy as np

from .regions import Box, Bound, Disk

PATH_POINTS = 4          # points per recorded segment at which obstacles are checked (ends included)
LATTICE = 11             # centres per coordinate of the plane in the first search
REFINE = (5, 2)          # a 5 x 5 lattice around the best centre, this many times, each finer by 2.5
TOUCH = 0.5              # path points within this share of an obstacle's size of its boundary touch it


def path_points(paths):
    """The recorded samples of every demonstration (list of (L_i, d)) with points along each segment."""
    out = []
    for p in paths:
        p = np.asarray(p, dtype=float)
        s = np.linspace(0.0, 1.0, PATH_POINTS + 1)[:-1]
        seg = p[:-1, None, :] + s[None, :, None] * (p[1:] - p[:-1])[:, None, :]
        out.append(np.vstack([seg.reshape(-1, p.shape[1]), p[-1:]]))
    return np.vstack(out)


def tightest_bounds(grid, samples, skip=()):
    """The tightest consistent :class:`Bound` per coordinate and side (module docstring), from the recorded
    ``samples`` (n, d); none where it would forbid nothing in the box; ``skip``: (dim, side) pairs to leave out."""
    out = []
    for i in range(grid.ndim):
        span = grid.high[i] - grid.low[i]
        for side, value, room in (("upper", samples[:, i].max(), grid.high[i] - samples[:, i].max()),
                                  ("lower", samples[:, i].min(), samples[:, i].min() - grid.low[i])):
            if (i, side) not in skip and room > 1e-9 * span:
                out.append(Bound(i, side, float(value)))
    return out


def largest_obstacles(kind, plane, centres, path, largest, smallest):
    """The largest ``kind`` ("disk" or "box") at each centre (K, 2) that the ``path`` (n, d) never enters,
    capped at ``largest``; centres that allow less than ``smallest``, or whose obstacle the path touches
    from one side only (module docstring), are dropped."""
    xy = path[:, list(plane)]
    out = []
    for c in np.atleast_2d(centres):
        d = xy - c
        dist = np.sqrt((d ** 2).sum(axis=1)) if kind == "disk" else np.abs(d).max(axis=1)
        size = min(float(dist.min()), largest) * (1 - 1e-9)
        if size >= smallest and size < largest * (1 - 1e-6) and enclosed(d[dist <= size * (1 + TOUCH)]):
            out.append(Disk(tuple(plane), (float(c[0]), float(c[1])), size) if kind == "disk" else
                       Box(tuple(plane), (float(c[0] - size), float(c[1] - size)), (float(c[0] + size), float(c[1] + size))))
    return out


def enclosed(directions):
    """Whether vectors (n, 2) from a centre do not all lie in one half-plane through it (the largest
    angular gap between them is below pi)."""
    if len(directions) < 2:
        return False
    angles = np.sort(np.arctan2(directions[:, 1], directions[:, 0]))
    gaps = np.diff(np.r_[angles, angles[0] + 2 * np.pi])
    return bool(gaps.max() < np.pi)


def centre_of(region):
    return np.asarray(region.center) if isinstance(region, Disk) else 0.5 * (np.asarray(region.low) + np.asarray(region.high))


def lattice(low, high, n):
    """n x n centres spread evenly over the box [low, high] of the plane (cell centres of an n x n split)."""
    axes = [lo + (np.arange(n) + 0.5) * (hi - lo) / n for lo, hi in zip(low, high)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)


def search_obstacle(kind, plane, grid, path, score, largest=None, smallest=None):
    """The most likely ``kind`` obstacle in ``plane``: ``score(regions)`` returns the gains (K,) of a list
    of regions; the best lattice centre, then a finer lattice around it (module docstring). Returns
    (region or None, gain, number of regions scored)."""
    low, high = grid.low[list(plane)], grid.high[list(plane)]
    width = min(grid.widths_1d(i).min() for i in plane)
    largest = 0.25 * float(np.min(high - low)) if largest is None else float(largest)
    smallest = width if smallest is None else float(smallest)
    best, gain, tried = None, -np.inf, 0
    regions = largest_obstacles(kind, plane, lattice(low, high, LATTICE), path, largest, smallest)
    step = (high - low) / LATTICE
    for level in range(REFINE[1] + 1):
        if regions:
            gains = np.asarray(score(regions), dtype=float)
            tried += len(regions)
            k = int(np.nanargmax(np.where(np.isfinite(gains), gains, -np.inf))) if np.isfinite(gains).any() else None
            if k is not None and gains[k] > gain:
                best, gain = regions[k], float(gains[k])
        if best is None or level == REFINE[1]:
            break
        step = step / 2.5
        n = REFINE[0]
        offsets = (np.arange(n) - (n - 1) / 2)
        grid_c = centre_of(best) + np.stack(np.meshgrid(offsets * step[0], offsets * step[1], indexing="ij"),
                                             axis=-1).reshape(-1, 2)
        regions = largest_obstacles(kind, plane, grid_c, path, largest, smallest)
    return best, gain, tried


def profile_interval(values, gains, level):
    """The likelihood interval of a one-parameter family from its profile: ``values`` (n,) ordered from the
    most likely (``gains[0]``, total log-likelihood gain) outwards; the values whose gain is within
    ``level`` nats of the best. Returns (nearest, farthest) with the farthest found by linear
    interpolation where the profile crosses ``best - level`` (the last value if it never does)."""
    values, gains = np.asarray(values, dtype=float), np.asarray(gains, dtype=float)
    drop = gains[0] - gains
    beyond = np.flatnonzero(drop > level)
    if not beyond.size:
        return float(values[0]), float(values[-1])
    k = int(beyond[0])
    if k == 0:
        return float(values[0]), float(values[0])
    a, b = drop[k - 1], drop[k]
    s = (level - a) / (b - a) if b > a else 1.0
    return float(values[0]), float(values[k - 1] + s * (values[k] - values[k - 1]))


def widened(region, amount):
    """``region`` loosened by ``amount`` (>= 0, in its units): a bound moved outwards, an obstacle shrunk."""
    return region.inflated(-amount)


def size_of(region):
    """The parameter a profile moves: a bound's value, a disk's radius, a square box's half-width."""
    if isinstance(region, Bound):
        return region.value
    if isinstance(region, Disk):
        return region.radius
    return 0.5 * (region.high[0] - region.low[0])
