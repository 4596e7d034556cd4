"""Value functions of many Phase III trials evaluated together (:mod:`.teaming`): trial ``b`` uses
``functions[which[b]]``, on the grid (trilinear, one gather for every trial) or, for exact value functions
(:class:`mutual.supervision.exact.ExactValueFunction`), by the closed form with each trial's turning and
obstacle radius."""

import numpy as np

from ..supervision.dubins import closed_form_dtheta, closed_form_values


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
        if self.exact:      # the closed form per trial: turning radius v / w_max and obstacle radius
            self.turn = np.array([f.speed / f.w_max for f in functions])[np.asarray(which)]
            self.radius = np.array([f.obstacle_radius for f in functions])[np.asarray(which)]
        else:
            self.values = np.concatenate([f.values.ravel() for f in functions])
            self.dtheta = np.concatenate([f.dvalues_dtheta.ravel() for f in functions])
        self.offset = np.asarray(which) * self.size

    def _exact(self, states, fill_value, derivative, rows):
        """The closed form (exact value functions) of each trial's function at ``states`` (B, ..., 3)."""
        pick = (lambda a: a) if rows is None else (lambda a: a[rows])
        shape = (-1,) + (1,) * (states.ndim - 2)
        turn, radius = pick(self.turn).reshape(shape), pick(self.radius).reshape(shape)
        turn, radius = np.broadcast_to(turn, states.shape[:-1]), np.broadcast_to(radius, states.shape[:-1])
        inside = (np.abs(states[..., 0]) <= self.spec.half_width) & (np.abs(states[..., 1]) <= self.spec.half_width)
        out = np.full(states.shape[:-1], fill_value, dtype=float)
        where = np.nonzero(inside)
        s = states[where]
        f = closed_form_dtheta if derivative else closed_form_values
        out[where] = f(s[:, 0], s[:, 1], s[:, 2], turn[where], radius[where])
        return out

    def interp(self, states, fill_value=np.inf, derivative=False, rows=None):
        """V (or dV/dtheta) of each trial's function at ``states`` (B, ..., 3); ``rows`` selects trials."""
        if self.exact:
            return self._exact(states, fill_value, derivative, rows)
        offset = self.offset if rows is None else self.offset[rows]
        offset = np.broadcast_to(offset.reshape(offset.shape + (1,) * (states.ndim - 2)), states.shape[:-1])
        inside = (np.abs(states[..., 0]) <= self.spec.half_width) & (np.abs(states[..., 1]) <= self.spec.half_width)
        out = np.full(states.shape[:-1], fill_value, dtype=float)
        where = np.nonzero(inside)          # only states on the grid (most robot-obstacle pairs are far apart)
        s, offset = states[where], offset[where]
        nx, ny, nt = self.spec.shape
        pos = (s - self.spec.lo) / self.spec.spacings
        ix = np.clip(pos[:, 0].astype(np.intp), 0, nx - 2)
        iy = np.clip(pos[:, 1].astype(np.intp), 0, ny - 2)
        it = np.floor(pos[:, 2]).astype(np.intp)
        wx, wy, wt = pos[:, 0] - ix, pos[:, 1] - iy, pos[:, 2] - it
        it0, it1 = it % nt, (it + 1) % nt
        table = self.dtheta if derivative else self.values
        result = 0.0
        for dx, fx in ((0, 1 - wx), (1, wx)):
            for dy, fy in ((0, 1 - wy), (1, wy)):
                base = offset + ((ix + dx) * ny + iy + dy) * nt
                result = result + fx * fy * ((1 - wt) * table[base + it0] + wt * table[base + it1])
        out[where] = result
        return out


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
