"""Discretizing x' = f(x, u) into the transition probabilities S(x, a, x') of a tabular MDP.

Two schemes (``Problem.scheme``):

* ``"sample"`` -- Monte Carlo within each cell, as Stocking, McPherson, Matthew and Tomlin
  (2021, the thesis's reference [67]) do: ``samples`` states drawn uniformly in the cell are
  integrated for ``dt`` under control a, and S(x, a, x') is the share that lands in cell x'.
* ``"barycentric"`` -- interpolation on a Kuhn triangulation of the lattice of cell centres
  (Munos and Moore 1999-2002): the centre of x is integrated for ``dt``, and S(x, a, .) puts the
  barycentric weights of that point on the d + 1 centres of the simplex around it. Its
  expectation E_{x'} V(x') is linear interpolation of V: the soft backup on this MDP is a
  semi-Lagrangian scheme for the soft HJB equation of Section 3.4 (:mod:`.soft_hjb`).

Every row of S sums to 1 and S is a sparse (X*A, X) matrix. The cells are cut into fixed
chunks of ``CHUNK_CELLS``; each chunk is one task, seeded by (``seed``, chunk number), so the
result is the same in one process or on a Dask cluster of any size (:func:`discretize`, :mod:`mutual.parallel`).
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ... import budget
from ...parallel import INLINE, map_tasks

CHUNK_CELLS = 2048
#: integrations (cells x controls x samples) above which ``scheduler="auto"`` uses Dask
DASK_THRESHOLD = 4_000_000


@dataclass(frozen=True)
class Chunk:
    """Cells ``start``..``stop - 1``, the ``number``-th chunk (its random stream)."""
    number: int
    start: int
    stop: int

    def params(self):
        return {"number": self.number, "start": self.start, "stop": self.stop}


def chunks(n_cells):
    """The fixed chunks of ``n_cells`` cells (independent of where they run)."""
    return [Chunk(k, s, min(s + CHUNK_CELLS, n_cells)) for k, s in enumerate(range(0, n_cells, CHUNK_CELLS))]


def chunk_transitions(chunk, problem):
    """(rows x*A + a, successor cells, probabilities) of the cells of one ``chunk``."""
    cells = np.arange(chunk.start, chunk.stop)
    if problem.scheme == "sample":
        return _sampled(problem, cells, np.random.default_rng([problem.seed, chunk.number]))
    return _barycentric(problem, cells)


def _rows(cells, A, repeat):
    return np.repeat((cells[:, None] * A + np.arange(A)[None, :]).ravel(), repeat)


def _merge(rows, cols, weights, n_cols):
    """Sum the weights of equal (row, col) pairs and drop zeros."""
    key = rows.astype(np.int64) * n_cols + cols
    unique, inverse = np.unique(key, return_inverse=True)
    total = np.bincount(inverse, weights=weights)
    keep = total > 0
    return unique[keep] // n_cols, (unique[keep] % n_cols).astype(np.int64), total[keep]


def _sampled(problem, cells, rng):
    grid, A, M = problem.grid, problem.n_actions, problem.samples
    low, width = grid.cell_boxes(cells)
    points = low[:, None, :] + rng.random((cells.size, M, grid.ndim)) * width[:, None, :]
    x = np.broadcast_to(points[:, None], (cells.size, A, M, grid.ndim)).reshape(-1, grid.ndim)
    u = np.broadcast_to(problem.controls[None, :, None, :], (cells.size, A, M, problem.controls.shape[1]))
    successors = grid.cell_of(problem.step(x, u.reshape(-1, problem.controls.shape[1])))
    return _merge(_rows(cells, A, M), successors, np.full(successors.size, 1.0 / M), grid.n_cells)


def kuhn_weights(grid, points):
    """Vertices (N, d+1) -- flat cells whose centres span the Kuhn simplex around each point --
    and barycentric weights (N, d+1) of ``points`` (N, d) on the lattice of cell centres.
    Points beyond the outermost centres are clipped onto them; periodic coordinates wrap."""
    points = grid.wrap(np.atleast_2d(points))
    N, d = points.shape
    lower, upper, frac = (np.empty((N, d), dtype=np.int64), np.empty((N, d), dtype=np.int64), np.empty((N, d)))
    for i in range(d):
        c, v = grid.centers_1d(i), points[:, i]
        n = c.size
        if grid.periodic[i]:
            ext = np.append(c, c[0] + grid.high[i] - grid.low[i])
            v = np.where(v < c[0], v + grid.high[i] - grid.low[i], v)
            j = np.clip(np.searchsorted(ext, v, side="right") - 1, 0, n - 1)
            lower[:, i], upper[:, i] = j, (j + 1) % n
        else:
            ext, v = c, np.clip(v, c[0], c[-1])
            j = np.clip(np.searchsorted(c, v, side="right") - 1, 0, n - 2)
            lower[:, i], upper[:, i] = j, j + 1
        frac[:, i] = np.clip((v - ext[j]) / (ext[j + 1] - ext[j]), 0.0, 1.0)
    order = np.argsort(-frac, axis=1, kind="stable")
    f = np.take_along_axis(frac, order, axis=1)
    weights = np.empty((N, d + 1))
    weights[:, 0], weights[:, d] = 1.0 - f[:, 0], f[:, d - 1]
    weights[:, 1:d] = f[:, :-1] - f[:, 1:]
    vertex = lower.copy()
    vertices = np.empty((N, d + 1), dtype=np.int64)
    vertices[:, 0] = grid.flat(vertex)
    rows = np.arange(N)
    for k in range(1, d + 1):
        dim = order[:, k - 1]
        vertex[rows, dim] = upper[rows, dim]
        vertices[:, k] = grid.flat(vertex)
    return vertices, weights


def _barycentric(problem, cells):
    grid, A = problem.grid, problem.n_actions
    x = np.repeat(grid.centers(cells), A, axis=0)
    u = np.tile(problem.controls, (cells.size, 1))
    vertices, weights = kuhn_weights(grid, problem.step(x, u))
    return _merge(_rows(cells, A, grid.ndim + 1), vertices.ravel(), weights.ravel(), grid.n_cells)


def work(problem):
    """The number of integrations a discretization performs (cells x controls x points per cell)."""
    points = problem.samples if problem.scheme == "sample" else 1
    return problem.grid.n_cells * problem.n_actions * points


def discretize(problem, scheduler="auto", workers=None, progress=False, allow_large=None):
    """S(x, a, x') of ``problem`` as a CSR matrix (X*A, X) (module docstring).

    ``scheduler``: "inline" (this process), "auto" (inline for small problems -- fewer than
    ``DASK_THRESHOLD`` integrations -- else as below), None (Dask: ``$MUTUAL_DASK_SCHEDULER`` or
    an embedded private cluster of ``workers`` processes; :mod:`mutual.parallel`) or the address of a running
    Dask scheduler. The result does not depend on where it ran (the chunks and their seeds are fixed).
    ``allow_large``: as :func:`mutual.budget.check` (memory and time estimated before any integration).
    ``progress``: a tqdm bar when True, or a function ``progress(done, total)`` called as chunks finish.
    """
    budget.check(budget.discretization(problem.grid.shape, problem.n_actions, problem.samples, problem.scheme,
                                       problem.substeps), allow_large)
    tasks = chunks(problem.grid.n_cells)
    if scheduler == "auto":
        scheduler = INLINE if work(problem) < DASK_THRESHOLD or len(tasks) < 2 else None
    bar = _progress(len(tasks), progress)
    parts, _ = map_tasks(chunk_transitions, tasks, (problem,), scheduler, workers, on_result=lambda i, part: bar.update(1))
    bar.close()
    rows, cols, probs = (np.concatenate(p) for p in zip(*parts))
    X, A = problem.grid.n_cells, problem.n_actions
    S = sp.csr_matrix((probs, (rows, cols)), shape=(X * A, X))
    S.sort_indices()
    sums = np.asarray(S.sum(axis=1)).ravel()
    return sp.csr_matrix(sp.diags(1.0 / sums) @ S)   # exact row sums (rounding in the weights)


def _progress(total, progress):
    """A tqdm bar (``progress`` True), or a counter that calls ``progress(done, total)`` (a function)."""
    if callable(progress):
        return _Counter(total, progress)
    from tqdm.auto import tqdm
    return tqdm(total=total, desc="discretizing", disable=not progress)


class _Counter:
    """Counts finished chunks and reports ``(done, total)``."""

    def __init__(self, total, report):
        self.total, self.report, self.done = total, report, 0

    def update(self, n):
        self.done += n
        self.report(self.done, self.total)

    def close(self):
        pass
