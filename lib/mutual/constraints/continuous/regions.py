"""Constraints a user thinks in, as regions of the continuous state space to stay out of.

* :class:`Bound` -- a limit on one coordinate: ``side="upper"`` allows x_i <= value (forbids
  x_i > value), ``"lower"`` allows x_i >= value;
* :class:`Disk` -- a round obstacle in a plane of two coordinates (a car's x and y);
* :class:`Box` -- an axis-aligned rectangular obstacle in such a plane.

Each region answers whether continuous points lie in it (the truth a demonstrator respects) and
which cells of a grid it covers (a cell belongs when its centre lies in the region: the
candidate's state set on the MDP). :func:`parse_region` reads the text form used on the
command line (``"theta_dot <= 5"``, ``"disk 0 0 0.8"``, ``"box -1 1 -0.5 0.5"``);
:func:`boundary_distance` is the error of an inferred boundary against a true one.
"""

import math
import re
from dataclasses import dataclass

import numpy as np


def _unit(grid, i):
    return f" {grid.units[i]}" if grid.units[i] else ""


@dataclass(frozen=True)
class Bound:
    """A limit on coordinate ``dim``: ``side`` "upper" (x <= value allowed) or "lower" (x >= value)."""

    dim: int
    side: str
    value: float

    kind = "bound"

    def inside(self, x):
        """Whether points (N, d) lie in the forbidden region."""
        v = np.asarray(x, dtype=float)[:, self.dim]
        return v > self.value if self.side == "upper" else v < self.value

    def describe(self, grid):
        return f"{grid.names[self.dim]} {'<=' if self.side == 'upper' else '>='} {self.value:.4g}{_unit(grid, self.dim)}"

    def inflated(self, margin):
        """The region grown by ``margin`` (in its units): a bound moved ``margin`` into the allowed side."""
        return Bound(self.dim, self.side, self.value - margin if self.side == "upper" else self.value + margin)

    def fields(self, grid):
        return {"name": grid.names[self.dim], "side": self.side, "value": float(self.value),
                "units": grid.units[self.dim]}


@dataclass(frozen=True)
class Disk:
    """A disk obstacle of ``radius`` around ``center`` in the plane of coordinates ``dims``."""

    dims: tuple
    center: tuple
    radius: float

    kind = "disk"

    def inside(self, x):
        x = np.asarray(x, dtype=float)
        d = x[:, list(self.dims)] - np.asarray(self.center)
        return np.einsum("ij,ij->i", d, d) < self.radius ** 2

    def inflated(self, margin):
        return Disk(self.dims, self.center, self.radius + margin)

    def describe(self, grid):
        i, j = self.dims
        return (f"disk at ({grid.names[i]}, {grid.names[j]}) = ({self.center[0]:.3g}, {self.center[1]:.3g}), "
                f"radius {self.radius:.3g}{_unit(grid, i)}")

    def fields(self, grid):
        return {"name": f"{grid.names[self.dims[0]]},{grid.names[self.dims[1]]}", "center_0": float(self.center[0]),
                "center_1": float(self.center[1]), "radius": float(self.radius), "units": grid.units[self.dims[0]]}


@dataclass(frozen=True)
class Box:
    """A rectangular obstacle [low_0, high_0] x [low_1, high_1] in the plane of coordinates ``dims``."""

    dims: tuple
    low: tuple
    high: tuple

    kind = "box"

    def inside(self, x):
        x = np.asarray(x, dtype=float)[:, list(self.dims)]
        return np.all((x > np.asarray(self.low)) & (x < np.asarray(self.high)), axis=1)

    def inflated(self, margin):
        return Box(self.dims, tuple(v - margin for v in self.low), tuple(v + margin for v in self.high))

    def describe(self, grid):
        i, j = self.dims
        return (f"box {grid.names[i]} {self.low[0]:.3g}..{self.high[0]:.3g}, {grid.names[j]} "
                f"{self.low[1]:.3g}..{self.high[1]:.3g}{_unit(grid, i)}")

    def fields(self, grid):
        return {"name": f"{grid.names[self.dims[0]]},{grid.names[self.dims[1]]}",
                "center_0": 0.5 * (self.low[0] + self.high[0]), "center_1": 0.5 * (self.low[1] + self.high[1]),
                "half_width_0": 0.5 * (self.high[0] - self.low[0]), "half_width_1": 0.5 * (self.high[1] - self.low[1]),
                "units": grid.units[self.dims[0]]}


def cells_in(region, grid):
    """Booleans (X,): the cells whose centre lies in ``region``."""
    return region.inside(grid.centers())


def _numbers(parts, n, text):
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != n or not all(math.isfinite(v) for v in values):
        raise ValueError(f"constraint {text!r}: expected {n} numbers after {text.split()[0]!r}")
    return values


def parse_region(text, names, plane=(0, 1)):
    """A region from text: ``"NAME <= VALUE"`` / ``"NAME >= VALUE"`` (a bound on the coordinate
    NAME), ``"disk X Y R"`` or ``"box XMIN XMAX YMIN YMAX"`` in the coordinates ``plane``."""
    if not isinstance(text, str):
        raise ValueError(f"constraint: must be text, got {text!r}")
    words = text.split()
    if words and words[0] in ("disk", "box"):
        if words[0] == "disk":
            x, y, r = _numbers(words[1:], 3, text)
            if r <= 0:
                raise ValueError(f"constraint {text!r}: the radius must be positive")
            return Disk(tuple(plane), (x, y), r)
        x0, x1, y0, y1 = _numbers(words[1:], 4, text)
        if x1 <= x0 or y1 <= y0:
            raise ValueError(f"constraint {text!r}: needs XMIN < XMAX and YMIN < YMAX")
        return Box(tuple(plane), (x0, y0), (x1, y1))
    match = re.fullmatch(r"\s*([A-Za-z_][\w.-]*)\s*(<=|>=|<|>)\s*(\S+)\s*", text)
    if not match:
        raise ValueError(f"constraint {text!r}: write 'NAME <= VALUE', 'NAME >= VALUE', 'disk X Y R' or "
                         "'box XMIN XMAX YMIN YMAX'")
    name, op, value = match.groups()
    if name not in names:
        raise ValueError(f"constraint {text!r}: {name!r} is not a state coordinate; the coordinates are {list(names)}")
    (v,) = _numbers([value], 1, "bound " + value)
    return Bound(list(names).index(name), "upper" if op.startswith("<") else "lower", v)


def boundary_distance(inferred, truth):
    """How far the inferred region's boundary lies from the true one, in the constraint's units:
    |value difference| for bounds on the same coordinate and side; for disks the Hausdorff
    distance between the circles |c - c'| + |r - r'|; for boxes the largest edge displacement;
    nan when the two are not of the same kind (on the same coordinates)."""
    if isinstance(inferred, Bound) and isinstance(truth, Bound):
        same = inferred.dim == truth.dim and inferred.side == truth.side
        return abs(inferred.value - truth.value) if same else math.nan
    if isinstance(inferred, Disk) and isinstance(truth, Disk) and tuple(inferred.dims) == tuple(truth.dims):
        return float(np.hypot(*np.subtract(inferred.center, truth.center)) + abs(inferred.radius - truth.radius))
    if isinstance(inferred, Box) and isinstance(truth, Box) and tuple(inferred.dims) == tuple(truth.dims):
        return float(np.max(np.abs(np.r_[np.subtract(inferred.low, truth.low), np.subtract(inferred.high, truth.high)])))
    return math.nan
