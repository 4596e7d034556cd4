"""A box over a continuous state space cut into cells: the states of the tabular MDP (Section 3.4).

A :class:`Grid` holds, for every coordinate, its increasing cell edges -- uniform, or refined
near a boundary (:meth:`Grid.refine`) -- and whether it wraps around (an angle: period
high - low). Cells are numbered in C order (the last coordinate fastest). A continuous state
belongs to the cell whose edges enclose it; successors that leave the box along a coordinate
that does not wrap are clipped into its outermost cell.
"""

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True, eq=False)
class Grid:
    """Cells over a box: ``edges[i]`` the cell edges of coordinate i (at least 2 cells),
    ``periodic[i]`` whether it wraps around, ``names`` and ``units`` of the coordinates."""

    edges: tuple
    periodic: tuple
    names: tuple
    units: tuple

    def __post_init__(self):
        edges = tuple(np.asarray(e, dtype=float) for e in self.edges)
        for name, e in zip(self.names, edges):
            if e.ndim != 1 or e.size < 3 or not np.all(np.isfinite(e)) or np.any(np.diff(e) <= 0):
                raise ValueError(f"grid: coordinate {name!r} needs at least 2 cells with increasing, finite edges")
        if not (len(edges) == len(self.periodic) == len(self.names) == len(self.units)) or not edges:
            raise ValueError("grid: edges, periodic, names and units need one entry per coordinate")
        for e in edges:
            e.setflags(write=False)
        object.__setattr__(self, "edges", edges)
        object.__setattr__(self, "periodic", tuple(bool(p) for p in self.periodic))
        object.__setattr__(self, "names", tuple(str(n) for n in self.names))
        object.__setattr__(self, "units", tuple(str(u) for u in self.units))

    @classmethod
    def uniform(cls, low, high, cells, periodic, names, units):
        """Equal cells: ``cells[i]`` of them between ``low[i]`` and ``high[i]``."""
        edges = [np.linspace(lo, hi, int(n) + 1) for lo, hi, n in zip(low, high, cells)]
        return cls(tuple(edges), tuple(periodic), tuple(names), tuple(units))

    def __repr__(self):
        return f"Grid({' x '.join(str(n) for n in self.shape)} cells over ({', '.join(self.names)}))"

    @property
    def shape(self):
        return tuple(e.size - 1 for e in self.edges)

    @property
    def ndim(self):
        return len(self.edges)

    @property
    def n_cells(self):
        return int(np.prod(self.shape))

    @property
    def low(self):
        return np.array([e[0] for e in self.edges])

    @property
    def high(self):
        return np.array([e[-1] for e in self.edges])

    def centers_1d(self, i):
        return 0.5 * (self.edges[i][:-1] + self.edges[i][1:])

    def widths_1d(self, i):
        return np.diff(self.edges[i])

    def wrap(self, x):
        """``x`` (N, d) with every periodic coordinate brought into [low, high)."""
        x = np.array(x, dtype=float, copy=True)
        for i in np.flatnonzero(self.periodic):
            lo, period = self.edges[i][0], self.edges[i][-1] - self.edges[i][0]
            x[:, i] = lo + np.mod(x[:, i] - lo, period)
        return x

    def outside(self, x):
        """(N, d) booleans: coordinate j of point n lies outside the box (never for periodic ones)."""
        x = np.asarray(x, dtype=float)
        out = (x < self.low) | (x > self.high)
        out[:, np.array(self.periodic)] = False
        return out

    def locate(self, x):
        """Per-coordinate cell indices (N, d) of (wrapped) points, clipped into the box."""
        x = self.wrap(np.atleast_2d(x))
        idx = np.empty(x.shape, dtype=np.int64)
        for i, e in enumerate(self.edges):
            idx[:, i] = np.clip(np.searchsorted(e, x[:, i], side="right") - 1, 0, e.size - 2)
        return idx

    def flat(self, idx):
        """Flat cell numbers of per-coordinate indices (N, d)."""
        return np.ravel_multi_index(tuple(np.asarray(idx).T), self.shape)

    def cell_of(self, x):
        """Flat cell numbers (N,) of points (N, d), clipped into the box."""
        return self.flat(self.locate(x))

    def coords(self, cells):
        """Per-coordinate indices (N, d) of flat cell numbers."""
        return np.stack(np.unravel_index(np.asarray(cells), self.shape), axis=-1)

    def centers(self, cells=None):
        """Cell centres (N, d) (all cells when ``cells`` is None)."""
        idx = self.coords(np.arange(self.n_cells) if cells is None else cells)
        return np.stack([self.centers_1d(i)[idx[:, i]] for i in range(self.ndim)], axis=1)

    def cell_boxes(self, cells):
        """Lower corners and widths (N, d), (N, d) of flat cells."""
        idx = self.coords(cells)
        low = np.stack([self.edges[i][idx[:, i]] for i in range(self.ndim)], axis=1)
        width = np.stack([self.widths_1d(i)[idx[:, i]] for i in range(self.ndim)], axis=1)
        return low, width

    def index_of(self, name):
        """The coordinate number of ``name`` (a ValueError naming the known ones otherwise)."""
        if name not in self.names:
            raise ValueError(f"{name!r} is not a state coordinate; the coordinates are {list(self.names)}")
        return self.names.index(name)

    def refine(self, dim, lo, hi, factor=2):
        """This grid with every cell of coordinate ``dim`` that overlaps [lo, hi] split into
        ``factor`` equal cells (the others kept): finer near a boundary, as coarse elsewhere."""
        if isinstance(factor, bool) or int(factor) != factor or factor < 2:
            raise ValueError(f"factor: must be an integer >= 2, got {factor!r}")
        e = self.edges[dim]
        pieces = [e[:1]]
        for a, b in zip(e[:-1], e[1:]):
            n = int(factor) if (b > lo and a < hi) else 1
            pieces.append(np.linspace(a, b, n + 1)[1:])
        edges = list(self.edges)
        edges[dim] = np.concatenate(pieces)
        return Grid(tuple(edges), self.periodic, self.names, self.units)

    def describe_cell(self, cell):
        """A cell as text: each coordinate's interval with its unit."""
        low, width = self.cell_boxes([cell])
        return ", ".join(f"{n} {a:.3g}..{a + w:.3g}{' ' + u if u else ''}"
                         for n, u, a, w in zip(self.names, self.units, low[0], width[0]))
