"""Continuous demonstrations onto the grid MDP: cells, actions, and the support of S.

:func:`to_demonstrations` turns an aligned recording (:func:`.recordings.align`) into chapter 2's
:class:`~mutual.constraints.Demonstrations`: each state to its cell, each step to an action --

* where the control was recorded: the nearest control of the set (each control coordinate
  scaled by the set's range), the recorded value averaged over the step;
* where it was not: **inferred** -- the control whose one-step prediction (the true dynamics,
  integrated for dt from the recorded state) lands nearest the next recorded state, distances in
  cell widths. The result says how many steps were inferred and how far the best prediction missed.

A recorded step can land in a cell that the discretized S gives probability 0 (the samples
missed it, or the control was snapped). Chapter 2's likelihood needs every demonstrated
transition possible, so such a step is added to S with weight ``SUPPORT_WEIGHT``:
S(x, a, .) <- (1 - w) S(x, a, .) + w (its observed successors). The result counts them: a large
count says the grid or the control set is too coarse for the recordings.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..demonstrations import Demonstrations
from .misses import step_misses
from .plausible import check_plausible
from .recordings import align

SUPPORT_WEIGHT = 1e-3


@dataclass(frozen=True, eq=False)
class Mapped:
    """Demonstrations on the grid: ``demos``, the ``transitions`` S with the recorded steps made
    possible, and what was done: ``snapped`` / ``inferred`` step counts, ``miss`` (the mean distance,
    in cell widths, of the inferred steps' best prediction), ``added`` (recorded steps S gave
    probability 0), ``states`` (N, L+1, n) the aligned continuous states."""

    demos: Demonstrations
    transitions: object
    snapped: int
    inferred: int
    miss: float
    added: int
    states: np.ndarray

    def notes(self):
        """What the mapping did, in words."""
        total = self.snapped + self.inferred
        parts = [f"{total} steps of {self.demos.n} demonstrations"]
        if self.snapped:
            parts.append(f"{self.snapped} with recorded controls (snapped to the nearest of the control set)")
        if self.inferred:
            parts.append(f"{self.inferred} with controls INFERRED from the next state (best one-step prediction "
                         f"missed by {self.miss:.2f} cell widths on average)")
        parts.append(f"{self.added} recorded steps had probability 0 under the discretized dynamics and were added "
                     f"with weight {SUPPORT_WEIGHT:g}")
        return "; ".join(parts)


def check_box(grid, recording, states, index):
    """A ValueError naming the file, line and column of the first recorded state outside the box."""
    out = grid.outside(states.reshape(-1, grid.ndim)).reshape(states.shape)
    if out.any():
        d, k, i = np.argwhere(out)[0]
        value = states[d, k, i]
        raise ValueError(f"{recording.where(d, index[d, k], grid.names[i])}: {value:g} is outside the box "
                         f"[{grid.low[i]:g}, {grid.high[i]:g}] of the system; widen the box or drop the sample")


def _snap(problem, controls):
    span = np.ptp(problem.controls, axis=0)
    span[span == 0] = 1.0
    d = ((controls[:, None, :] - problem.controls[None]) / span) ** 2
    return np.argmin(d.sum(axis=2), axis=1)


def _infer(problem, x, nxt):
    """The action whose one-step prediction from x lands nearest nxt, and that distance in widths of nxt's cell."""
    grid = problem.grid
    at = grid.locate(nxt)
    widths = np.stack([grid.widths_1d(i)[at[:, i]] for i in range(grid.ndim)], axis=1)
    dist = step_misses(problem, x, nxt, widths[:, None, :])
    best = np.argmin(dist, axis=1)
    return best, dist[np.arange(len(x)), best]


def _with_support(transitions, rows, cols, n_actions):
    """S with the observed (row, col) transitions that S gives probability 0 added with SUPPORT_WEIGHT."""
    S = sp.csr_matrix(transitions)
    zero = np.asarray(S[rows, cols]).ravel() <= 0
    if not zero.any():
        return S, 0
    r, c = rows[zero], cols[zero]
    counts = sp.csr_matrix((np.ones(r.size), (r, c)), shape=S.shape)
    totals = np.asarray(counts.sum(axis=1)).ravel()
    touched = totals > 0
    scale = np.where(touched, 1.0 - SUPPORT_WEIGHT, 1.0)
    added = sp.diags(np.where(touched, SUPPORT_WEIGHT / np.where(touched, totals, 1.0), 0.0)) @ counts
    out = sp.csr_matrix(sp.diags(scale) @ S + added)
    out.sort_indices()
    return out, int(zero.sum())


def check_recording(problem, recording, truncate=False):
    """Align ``recording`` to the time step and check its states lie in the box and are plausible
    (:func:`.plausible.check_plausible`): the errors of :func:`to_demonstrations` that need no
    discretization, for an early report."""
    states, controls, index = align(recording, problem.dt, truncate)
    check_box(problem.grid, recording, states, index)
    check_plausible(problem, recording, states, controls, index)


def to_demonstrations(problem, recording, transitions, truncate=False):
    """:class:`Mapped` demonstrations of ``recording`` on the grid MDP of ``problem`` whose
    discretized dynamics are ``transitions`` (module docstring)."""
    states, controls, index = align(recording, problem.dt, truncate)
    check_box(problem.grid, recording, states, index)
    check_plausible(problem, recording, states, controls, index)
    N, L1, n = states.shape
    grid = problem.grid
    flat = grid.wrap(states.reshape(-1, n))
    cells = grid.cell_of(flat).reshape(N, L1)
    actions = np.empty((N, L1 - 1), dtype=np.int64)
    recorded = np.zeros((N, L1 - 1), dtype=bool) if controls is None else np.isfinite(controls).all(axis=2)
    if recorded.any():
        actions[recorded] = _snap(problem, controls[recorded])
    miss = np.nan
    if (~recorded).any():
        x, nxt = flat.reshape(N, L1, n)[:, :-1][~recorded], flat.reshape(N, L1, n)[:, 1:][~recorded]
        actions[~recorded], dist = _infer(problem, x, nxt)
        miss = float(dist.mean())
    rows = (cells[:, :-1] * problem.n_actions + actions).ravel()
    S, added = _with_support(transitions, rows, cells[:, 1:].ravel(), problem.n_actions)
    return Mapped(Demonstrations(cells, actions), S, int(recorded.sum()), int((~recorded).sum()), miss, added, states)
