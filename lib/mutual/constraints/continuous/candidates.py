"""Candidate constraints on a discretized continuous system, with chapter 3's chance thresholds.

Chapter 3's chance constraint on a state (eq. 3.1) extends to a set R of cells as a limit on the
chance of *entering* R: in a state x outside R, action a is allowed only if
S(x, a, R) = sum_{x' in R} S(x, a, x') <= psi(R); inside R the constraint asks nothing. (Asking it
inside too would leave every cell deep in R without an allowed action -- all of them stay in R --
so any demonstration with the least chance of reaching R's interior would be impossible, whatever
psi.) A region that holds a demonstrated state (at the grid's resolution) is no candidate: the
demonstrations entered it. The threshold is the maximum-likelihood one of Lemma 3.2.1
(:mod:`.thresholds`: eq. 3.3 for the set, or the lemma taken exactly). The families (:mod:`.regions`):

* ``"bound"`` -- every interior cell edge of every coordinate, both sides (x_i <= edge, x_i >= edge);
* ``"disk"`` / ``"box"`` -- obstacles in a plane of two coordinates, centred every ``every`` cells,
  of the given radii / half-widths;
* ``"cell"`` -- one chance constraint per cell, chapter 3's own candidates: with
  ``thresholds="eq3.3"`` exactly :func:`mutual.constraints.candidates.constraint_candidates`'s
  state candidates (psi* from :func:`mutual.constraints.chance.max_likelihood_thresholds`).

A candidate that forbids nothing the MDP offers, or exactly what an earlier one forbids, is dropped.
The result is one :class:`mutual.constraints.Candidates` for :func:`mutual.constraints.greedy_inference`
and a table describing each candidate in its units.
"""

import hashlib
from dataclasses import dataclass

import numpy as np
import pandas as pd
import scipy.sparse as sp

from ..candidates import Candidates
from ..chance import max_likelihood_thresholds
from . import thresholds as th
from .regions import Box, Bound, Disk, cells_in

FAMILIES = ("bound", "disk", "box", "cell")


@dataclass(frozen=True, eq=False)
class RegionCandidates:
    """``candidates`` (chapters 2-3's :class:`Candidates`), ``regions[k]`` the region of candidate k
    (None for a cell candidate: its cell is ``candidates.index[k]``), the ``grid``, and ``raised``:
    how many thresholds Lemma 3.2.1 raised above eq. (3.3)."""

    candidates: Candidates
    regions: list
    grid: object
    raised: int = 0

    def __len__(self):
        return len(self.regions)

    def label(self, k):
        region = self.regions[k]
        return region.describe(self.grid) if region is not None else \
            f"cell {int(self.candidates.index[k])} ({self.grid.describe_cell(int(self.candidates.index[k]))})"

    def table(self):
        """One row per candidate: kind, the constraint in words, its numbers and units, psi."""
        rows = []
        for k, region in enumerate(self.regions):
            fields = region.fields(self.grid) if region is not None else {"cell": int(self.candidates.index[k])}
            rows.append({"candidate": k, "kind": region.kind if region is not None else "cell",
                         "constraint": self.label(k), **fields, "psi": float(self.candidates.psi[k])})
        return pd.DataFrame(rows)


def bound_regions(grid, dims=None, sides=("upper", "lower")):
    """A :class:`Bound` at every interior cell edge of the coordinates ``dims`` (default all)."""
    dims = range(grid.ndim) if dims is None else dims
    return [Bound(int(i), side, float(v)) for i in dims for side in sides for v in grid.edges[i][1:-1]]


def _plane_centres(grid, plane, every):
    (i, j), every = plane, max(1, int(every))
    ci, cj = grid.centers_1d(i)[::every], grid.centers_1d(j)[::every]
    return [(float(a), float(b)) for a in ci for b in cj]


def disk_regions(grid, plane=(0, 1), every=2, radii=None):
    """Disks centred every ``every`` cells of the plane ``plane``; ``radii`` default to 1, 2 and 3
    times the plane's largest cell width."""
    width = max(grid.widths_1d(plane[0]).max(), grid.widths_1d(plane[1]).max())
    radii = [width, 2 * width, 3 * width] if radii is None else radii
    return [Disk(tuple(plane), c, float(r)) for c in _plane_centres(grid, plane, every) for r in radii]


def box_regions(grid, plane=(0, 1), every=2, half_widths=None):
    """Square boxes centred every ``every`` cells of ``plane``, of the given half-widths
    (default 1 and 2 times the plane's largest cell width)."""
    width = max(grid.widths_1d(plane[0]).max(), grid.widths_1d(plane[1]).max())
    half_widths = [width, 2 * width] if half_widths is None else half_widths
    return [Box(tuple(plane), (c[0] - h, c[1] - h), (c[0] + h, c[1] + h))
            for c in _plane_centres(grid, plane, every) for h in half_widths]


def _bound_columns(mdp, grid, dim, bounds):
    """S(x, a, R) (X*A, K) of bounds on coordinate ``dim``: per bound, the probabilities of the entries
    of S that lead from outside R into R, summed per row (entering R only; no (X*A, X) x (X, K) product)."""
    coords = grid.coords(np.arange(grid.n_cells))[:, dim]
    S = sp.csr_matrix(mdp.transitions)
    row = np.repeat(np.arange(S.shape[0]), np.diff(S.indptr))
    to, at = coords[S.indices], coords[row // mdp.n_actions]          # successor's and state's index
    moves = {"upper": to > at, "lower": to < at}                     # only these entries can enter R
    moves = {side: (row[m], to[m], at[m], S.data[m]) for side, m in moves.items()}
    rows, cols, data = [], [], []
    for k, r in enumerate(bounds):
        j = int(np.searchsorted(grid.centers_1d(dim), r.value, side="right"))   # cells above the bound: j..n-1
        row_, to_, at_, p_ = moves[r.side]
        enters = (to_ >= j) & (at_ < j) if r.side == "upper" else (to_ < j) & (at_ >= j)
        rows.append(row_[enters])
        cols.append(np.full(rows[-1].size, k))
        data.append(p_[enters])
    return sp.csc_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(S.shape[0], len(bounds)))


def _obstacle_columns(mdp, grid, obstacles):
    """S(x, a, R) (X*A, K) of obstacle regions, 0 in the rows of states inside R (entering R only)."""
    inside = sp.csr_matrix(np.stack([cells_in(r, grid) for r in obstacles], axis=1).astype(float))
    SR = sp.csc_matrix(mdp.transitions @ inside)
    rows_inside = sp.csc_matrix(sp.kron(inside, np.ones((mdp.n_actions, 1))))
    return sp.csc_matrix(SR - SR.multiply(rows_inside))


def _groups(mdp, grid, regions, cells):
    """The candidate numbers of the blocks in order, and functions that build the S(x, a, R) (X*A, k)
    blocks: one per bounded coordinate, one for the obstacles, one for the cells (S itself)."""
    order, blocks = [], []
    for dim in sorted({r.dim for r in regions if isinstance(r, Bound)}):
        ks = [k for k, r in enumerate(regions) if isinstance(r, Bound) and r.dim == dim]
        order += ks
        blocks.append(lambda ks=ks, dim=dim: _bound_columns(mdp, grid, dim, [regions[k] for k in ks]))
    others = [k for k, r in enumerate(regions) if not isinstance(r, Bound)]
    if others:
        order += others
        blocks.append(lambda: _obstacle_columns(mdp, grid, [regions[k] for k in others]))
    if cells:
        order += list(range(len(regions), len(regions) + grid.n_cells))
        blocks.append(lambda: sp.csc_matrix(mdp.transitions))
    return np.array(order, dtype=np.int64), blocks


def region_candidates(mdp, demos, grid, regions=(), cells=False, thresholds="lemma"):
    """Candidates (module docstring) for those of ``regions`` (from :func:`bound_regions`,
    :func:`disk_regions`, :func:`box_regions`) that hold no demonstrated cell and, with ``cells``, one
    per cell, on the discretized ``mdp`` with the ``demos`` mapped onto it; ``thresholds``: "lemma"
    or "eq3.3" (:mod:`.thresholds`)."""
    visited = grid.centers(np.unique(demos.states))
    regions = [r for r in regions if not r.inside(visited).any()]     # the demonstrations entered it
    listed = regions + ([None] * grid.n_cells if cells else [])
    if not listed:
        raise ValueError("candidates: no candidate families chosen")
    order, blocks = _groups(mdp, grid, regions, cells)
    psi_o, forbidden_o, raised = th.chance_columns(mdp, demos, blocks, thresholds)
    back = np.argsort(order)                                          # block order -> candidate order
    psi, forbidden = psi_o[back], forbidden_o[:, back]
    if cells and thresholds == "eq3.3":                                # chapter 3's own (the same numbers)
        psi[len(regions):] = max_likelihood_thresholds(mdp, demos)
    keep = _useful(forbidden, mdp)
    index = np.array([k if r is not None else k - len(regions) for k, r in enumerate(listed)])
    kind = np.array(["region" if r is not None else "state" for r in listed])
    cand = Candidates(kind[keep], index[keep], psi[keep], forbidden[:, keep], np.ones(int(keep.sum()), dtype=bool),
                      (mdp.n_states, mdp.n_actions))
    return RegionCandidates(cand, [listed[k] for k in np.flatnonzero(keep)], grid, int(raised.size))


def _useful(forbidden, mdp):
    """Columns that forbid some offered action, without duplicates (the first kept)."""
    F = sp.csc_matrix(forbidden.multiply(sp.csr_matrix(mdp.allowed.reshape(-1, 1))), dtype=bool)
    F.eliminate_zeros()
    F.sort_indices()
    seen, keep = set(), np.zeros(F.shape[1], dtype=bool)
    for k in range(F.shape[1]):
        rows = F.indices[F.indptr[k]:F.indptr[k + 1]]
        key = hashlib.sha256(rows.tobytes()).digest()
        if rows.size and key not in seen:
            seen.add(key)
            keep[k] = True
    return keep


def families_regions(grid, families, plane=(0, 1), every=2, radii=None, half_widths=None):
    """The regions of the chosen ``families`` (module docstring) and whether cells are candidates."""
    unknown = [f for f in families if f not in FAMILIES]
    if unknown:
        raise ValueError(f"candidates: unknown family {unknown[0]!r}; choose from {list(FAMILIES)}")
    regions = []
    if "bound" in families:
        regions += bound_regions(grid)
    if "disk" in families:
        regions += disk_regions(grid, plane, every, radii)
    if "box" in families:
        regions += box_regions(grid, plane, every, half_widths)
    return regions, "cell" in families


def threshold_table(mdp, demos, grid, bounds):
    """Where the cells model loses a bound (module docstring), one row per :class:`~.regions.Bound` of
    ``bounds`` (one coordinate): psi* of eq. (3.3), whether the demonstrations stay feasible at it, the
    lowest feasible psi (Lemma 3.2.1 taken exactly) and how many offered state-actions that threshold still
    forbids (0: the candidate forbids nothing and is dropped)."""
    dims = {b.dim for b in bounds}
    if len(dims) != 1:
        raise ValueError("bounds: need bounds on one coordinate")
    SR = _bound_columns(mdp, grid, dims.pop(), list(bounds))
    rows = th.demonstrated_rows(mdp, demos)
    star = th.eq33(SR, rows)
    bad = th.infeasible_at(mdp, demos, SR, star)
    psi = star.copy()
    if bad.any():
        psi[bad] = th.lemma(mdp, demos, sp.csc_matrix(SR)[:, np.flatnonzero(bad)], star[bad])
    offered = mdp.allowed.reshape(-1)
    forbids = np.asarray((th.forbidden_by(SR, psi).multiply(sp.csr_matrix(offered.reshape(-1, 1)))).sum(axis=0)).ravel()
    return pd.DataFrame({"bound": [b.describe(grid) for b in bounds], "value": [b.value for b in bounds],
                         "psi eq. 3.3": star, "feasible at eq. 3.3": ~bad, "psi Lemma 3.2.1": psi,
                         "state-actions forbidden": forbids.astype(int)})
