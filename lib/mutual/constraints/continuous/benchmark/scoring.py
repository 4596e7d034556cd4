"""How an answer is scored against a case's truth, the same for every method.

An :class:`Answer` is what a method accepted, in order: regions (:class:`~..regions.Bound`,
:class:`~..regions.Disk`, :class:`~..regions.Box`) and, where the method says it, the exact
log-likelihood gain per demonstration of each. :func:`score` compares it with the true regions:

* ``kind right`` -- the first accepted constraint is of the truth's kind and coordinate(s) (a bound
  on the same coordinate and side; a disk or box in the same plane); on an unconstrained case,
  right means nothing was accepted;
* ``error`` -- bounds: |inferred - true| value of the tightest accepted bound of the truth's
  coordinate and side (several such bounds are one constraint: their intersection); obstacles: the
  distance between the centres of the truth and of the first accepted obstacle of its kind, with
  ``size error`` |r - r'| (disks) or the largest half-width difference (boxes); nan where none;
* ``false positives`` -- accepted constraints that are not the truth's: every one on an
  unconstrained case; other coordinates, sides or kinds, and obstacles after the first, otherwise;
* ``lowered likelihood`` -- how many accepted constraints had an exact gain <= 0 (None where the
  method reports no gains).
"""

import math
from dataclasses import dataclass, field

import numpy as np

from ..regions import Bound, Box, Disk


@dataclass(frozen=True)
class Answer:
    """What a method accepted: ``regions`` in order, their exact ``gains`` (nats per demonstration)
    or None, the ``seconds`` it took and a ``note`` (how it stopped, what it could not do)."""

    regions: tuple = ()
    gains: tuple = None
    seconds: float = math.nan
    note: str = ""
    extra: dict = field(default_factory=dict)


def same_kind(region, truth):
    """Whether ``region`` is of the truth's kind on the truth's coordinate(s) (and side)."""
    if isinstance(truth, Bound):
        return isinstance(region, Bound) and region.dim == truth.dim and region.side == truth.side
    return type(region) is type(truth) and tuple(region.dims) == tuple(truth.dims)


def _centre(region):
    if isinstance(region, Disk):
        return np.asarray(region.center, dtype=float)
    return 0.5 * (np.asarray(region.low, dtype=float) + np.asarray(region.high, dtype=float))


def _size_error(region, truth):
    if isinstance(truth, Disk):
        return abs(region.radius - truth.radius)
    half = 0.5 * (np.asarray(region.high) - np.asarray(region.low))
    return float(np.max(np.abs(half - 0.5 * (np.asarray(truth.high) - np.asarray(truth.low)))))


def errors(regions, truth):
    """(error, size error, number of accepted regions that match the truth) of ``regions`` against the
    region ``truth`` (module docstring)."""
    matching = [r for r in regions if r is not None and same_kind(r, truth)]
    if not matching:
        return math.nan, math.nan, 0
    if isinstance(truth, Bound):
        pick = min if truth.side == "upper" else max
        return abs(pick(r.value for r in matching) - truth.value), math.nan, len(matching)
    first = matching[0]
    return float(np.linalg.norm(_centre(first) - _centre(truth))), _size_error(first, truth), 1


def score(answer, truth):
    """A dict of the numbers of the module docstring for ``answer`` against the true regions ``truth``
    (a list of at most one region; empty for an unconstrained case)."""
    regions = [r for r in answer.regions]
    if truth:
        error, size, matched = errors(regions, truth[0])
        kind_right = bool(regions) and regions[0] is not None and same_kind(regions[0], truth[0])
    else:
        error, size, matched, kind_right = math.nan, math.nan, 0, not regions
    lowered = None if answer.gains is None else int(np.sum(np.asarray(answer.gains, dtype=float) <= 0))
    return {"first": describe(regions[0]) if regions else "none", "kind right": kind_right, "error": error,
            "size error": size, "false positives": len(regions) - matched, "accepted": len(regions),
            "lowered likelihood": lowered}


def describe(region, names=None):
    """A short text of a region (coordinate numbers unless ``names`` are given)."""
    if region is None:
        return "a cell"
    name = (lambda i: names[i]) if names is not None else (lambda i: f"x{i}")
    if isinstance(region, Bound):
        return f"{name(region.dim)} {'<=' if region.side == 'upper' else '>='} {region.value:.3f}"
    if isinstance(region, Disk):
        return f"disk ({region.center[0]:.2f}, {region.center[1]:.2f}) r {region.radius:.2f}"
    if isinstance(region, Box):
        return (f"box {region.low[0]:.2f}..{region.high[0]:.2f} x {region.low[1]:.2f}..{region.high[1]:.2f}")
    return str(region)
