"""Value functions of many Phase III trials evaluated together (:mod:`.teaming`): trial ``b`` uses
``functions[which[b]]``, on the grid (trilinear, one gather of the eight corners for every state) or, for
exact value functions (:class:`mutual.supervision.exact.ExactValueFunction`), by the closed form with each
trial's turning and obstacle radius. :meth:`_Stack.reach` bounds where a value can lie below a level, so
that a simulation evaluates only the states where it can matter."""

import numpy as np

from ..supervision import closed_form_dtheta, closed_form_values

REACH_SLACK = 1e-6   # metres: far above the round-off of a value or a distance, far below a grid cell


class _Stack:
    """Value functions on one grid, interpolated together: trial ``b`` uses ``functions[which[b]]``.

    The same trilinear interpolation as :meth:`ValueFunction.interp` (periodic in theta,
    ``fill_value`` off the (x, y) domain), done for every trial in one gather.
    """

    def __init__(self, functions, which, role):
        specs = {f.grid_spec for f in functions}
        if len(specs) != 1:
            raise ValueError(f"all {role} value functions must share one grid_spec, got {len(specs)} different grids")
        kinds = {bool(f.exact) for f in functions}
        if len(kinds) != 1:
            raise ValueError(f"the {role} value functions must be all exact or all on the grid")
        self.spec = specs.pop()
        self.exact = kinds.pop()
        self.size = int(np.prod(self.spec.shape))
        self.half_width = self.spec.half_width
        if self.exact:      # the closed form per trial: turning radius v / w_max and obstacle radius
            self.turn = np.array([f.speed / f.w_max for f in functions])[np.asarray(which)]
            self.radius = np.array([f.obstacle_radius for f in functions])[np.asarray(which)]
        else:
            self.values = np.concatenate([f.values.ravel() for f in functions])
            self.dtheta = np.concatenate([f.dvalues_dtheta.ravel() for f in functions])
            _, ny, nt = self.spec.shape
            self.corners = np.array([0, nt, ny * nt, (ny + 1) * nt])   # (dx, dy) = (0, 0), (0, 1), (1, 0), (1, 1)
            self.lo, self.spacings = tuple(self.spec.lo), tuple(self.spec.spacings)
            self.levels = [_cell_reach(f.values, self.spec) for f in functions]
        self.which = np.asarray(which)
        self.offset = self.which * self.size

    def reach(self, level):
        """Per trial, a distance from the obstacle's centre beyond which the trial's V is at least
        ``level[b]`` (a 1-D array of levels, one per trial; -1 where V is nowhere below it; a little wider
        than exact, for round-off). Exact functions: V >= sqrt(d^2 + R^2) - R - r at distance d (turning
        radius R, obstacle radius r: the farther turning circle's centre is at least sqrt(d^2 + R^2) away).
        On the grid: the farthest corner of every cell whose eight corners' smallest value (over all
        headings) is below the level (trilinear values are averages of their corners)."""
        level = np.asarray(level, dtype=float) + REACH_SLACK
        if self.exact:
            big = level + self.radius + self.turn
            return np.where(big > self.turn, np.sqrt(np.maximum(big ** 2 - self.turn ** 2, 0.0)) + REACH_SLACK, -1.0)
        out = np.empty(len(level))
        for f, (minima, farthest) in enumerate(self.levels):
            rows = self.which == f
            below = np.searchsorted(minima, level[rows], side="left")   # cells whose minimum is below the level
            out[rows] = np.where(below > 0, farthest[np.maximum(below - 1, 0)] + REACH_SLACK, -1.0)
        return out

    def interp(self, states, fill_value=np.inf, derivative=False):
        """V (or dV/dtheta) of each trial's function at ``states`` (B, ..., 3)."""
        trial = np.arange(len(self.offset))
        trial = np.broadcast_to(trial.reshape(trial.shape + (1,) * (states.ndim - 2)), states.shape[:-1])
        x, y, theta = states[..., 0], states[..., 1], states[..., 2]
        return self.values_at(x, y, theta, trial, fill_value, derivative)

    def values_at(self, x, y, theta, trial, fill_value=np.inf, derivative=False):
        """V (or dV/dtheta) at states given by their coordinates relative to the obstacle, each of trial
        ``trial`` (arrays of one shape); ``fill_value`` off the grid's (x, y) domain."""
        inside = (np.abs(x) <= self.half_width) & (np.abs(y) <= self.half_width)
        out = np.full(inside.shape, fill_value, dtype=float)
        where = np.nonzero(inside)          # only states on the grid (most robot-obstacle pairs are far apart)
        out[where] = self.on_grid(x[where], y[where], theta[where], trial[where], derivative)
        return out

    def on_grid(self, x, y, theta, trial, derivative=False):
        """V (or dV/dtheta) at states (1-D arrays) that lie on the grid's (x, y) domain, each of trial ``trial``."""
        if self.exact:
            f = closed_form_dtheta if derivative else closed_form_values
            return f(x, y, theta, self.turn[trial], self.radius[trial])
        nx, ny, nt = self.spec.shape
        (lx, ly, lt), (sx, sy, st) = self.lo, self.spacings
        px, py, pt = (x - lx) / sx, (y - ly) / sy, (theta - lt) / st
        ix = np.minimum(np.maximum(px.astype(np.intp), 0), nx - 2)
        iy = np.minimum(np.maximum(py.astype(np.intp), 0), ny - 2)
        it = np.floor(pt).astype(np.intp)
        wx, wy, wt = px - ix, py - iy, pt - it
        corner = (self.offset[trial] + (ix * ny + iy) * nt)[:, None] + self.corners
        table = self.dtheta if derivative else self.values
        # per corner (1 - wt) V(theta_k) + wt V(theta_k+1), weighted by fx fy and summed in the corners' order
        along = ((1 - wt)[:, None] * table[corner + (it % nt)[:, None]]
                 + wt[:, None] * table[corner + ((it + 1) % nt)[:, None]])
        fx, fy = (1 - wx, wx), (1 - wy, wy)
        result = 0.0
        for k, (dx, dy) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            result = result + fx[dx] * fy[dy] * along[:, k]
        return result


def _cell_reach(values, spec):
    """The grid cells' smallest corner values over every heading, sorted, and the running largest distance
    of those cells' farthest corners from the obstacle's centre (for :meth:`_Stack.reach`)."""
    v = np.asarray(values, dtype=float).min(axis=2)
    cell = np.minimum(np.minimum(v[:-1, :-1], v[1:, :-1]), np.minimum(v[:-1, 1:], v[1:, 1:]))
    xs, ys, _ = spec.coordinate_vectors
    far_x, far_y = np.maximum(np.abs(xs[:-1]), np.abs(xs[1:])), np.maximum(np.abs(ys[:-1]), np.abs(ys[1:]))
    order = np.argsort(cell, axis=None, kind="stable")
    return cell.ravel()[order], np.maximum.accumulate(np.hypot(far_x[:, None], far_y[None, :]).ravel()[order])


def _unique(objects):
    """Distinct objects (by identity) and each item's index among them."""
    uniq, index = [], []
    for o in objects:
        for i, u in enumerate(uniq):
            if u is o:
                index.append(i)
                break
        else:
            uniq.append(o)
            index.append(len(uniq) - 1)
    return uniq, np.array(index)
