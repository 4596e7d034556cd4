"""Maximum-likelihood chance thresholds of set constraints: eq. (3.3), and Lemma 3.2.1 taken exactly.

For a set R of cells, action a is allowed in x only if S(x, a, R) <= psi(R) (eq. 3.1 for a set).
Lemma 3.2.1: the likelihood is maximized by the lowest psi that does not rule out any
demonstration. Eq. (3.3),

    psi*(R) = max over demonstrated (x_t, a_t) of S(x_t, a_t, R),

is the lowest psi that keeps every *demonstrated action* allowed. A demonstration can also be
ruled out another way: a state none of whose actions is allowed has V = -inf (eq. 2.21), and any
action that reaches such a state with positive probability has Q = -inf. On a discretized
continuous system probability leaks into neighbouring cells, so psi*(R) = 0 often leaves the cells
next to R without an allowed action, and a demonstration that passes near them becomes impossible.

This is where the cells model (:mod:`.cells`) loses what continuous demonstrations say: a bound between
the demonstrations and the truth has the demonstrated cell next to it, whose points leak into it under
the demonstrated actions, so psi*(R) is large; the cells next to R whose every action leaks are left
without an allowed action; the lemma raises psi until none is -- on the pendulum often to the largest
chance in the column, where the bound forbids nothing and is dropped (:func:`threshold_table` shows it
per bound). The closer the demonstrator comes to its limit, the less findable the limit. The default
model (:mod:`.pointwise`) evaluates the constraint per point, where psi* = 0 exactly.

``thresholds="lemma"`` takes the lemma exactly: for every candidate that eq. (3.3) makes
infeasible, the lowest psi >= psi* that keeps all demonstrations feasible, found by bisection over
the candidate's distinct values of S(x, a, R) (feasibility is monotone in psi: a larger psi forbids
less). Feasibility is the exact -inf pattern of Algorithm 4, computed by the boolean backup of
:mod:`mutual.constraints.feasibility`. ``thresholds="eq3.3"`` keeps psi* (the thesis's formula;
such candidates are then infeasible and never chosen).
"""

import numpy as np
import scipy.sparse as sp

from ..feasibility import infeasible_candidates

THRESHOLDS = ("lemma", "eq3.3")
TOLERANCE = 1e-12   # S(x, a, R) is a sum: values equal to psi up to rounding stay allowed


def demonstrated_rows(mdp, demos):
    """The distinct demonstrated state-action rows x*A + a."""
    x, a = demos.pairs()
    return np.unique(x * mdp.n_actions + a)


def eq33(SR, rows):
    """psi*(R) (K,) of eq. (3.3) for the columns S(x, a, R) (X*A, K) and the demonstrated ``rows``."""
    SR = sp.csc_matrix(SR)
    return np.asarray(SR[rows].max(axis=0).toarray()).ravel() if rows.size else np.zeros(SR.shape[1])


def forbidden_by(SR, psi):
    """The boolean CSC matrix [S(x, a, R_k) > psi_k] (X*A, K)."""
    SR = sp.csc_matrix(SR)
    col = np.repeat(np.arange(SR.shape[1]), np.diff(SR.indptr))
    hit = SR.data > np.asarray(psi)[col] + TOLERANCE
    return sp.csc_matrix((np.ones(int(hit.sum()), dtype=bool), (SR.indices[hit], col[hit])), shape=SR.shape)


def infeasible_at(mdp, demos, SR, psi):
    """(K,) booleans: the demonstrations are infeasible under [S(x, a, R_k) > psi_k] alone."""
    base = np.ones((mdp.n_states, mdp.n_actions), dtype=bool)
    return infeasible_candidates(mdp, demos, base, forbidden_by(SR, psi))


def lemma(mdp, demos, SR, psi_star, columns_per_call=128):
    """Lemma 3.2.1 exactly (module docstring) for columns S(x, a, R) (X*A, K) that are infeasible
    at eq. (3.3)'s ``psi_star``: the lowest threshold of each that keeps every demonstration
    feasible, by a many-way search over the column's distinct values (feasibility is monotone: a
    larger threshold forbids less), as many split points per boolean backup as ``columns_per_call``
    allows (one compiled call of the gather form holds 128)."""
    SR = sp.csc_matrix(SR)
    psi = np.asarray(psi_star, dtype=float).copy()
    values = []
    for k in range(SR.shape[1]):
        column = SR.data[SR.indptr[k]:SR.indptr[k + 1]]
        values.append(np.unique(column[column > psi[k] + TOLERANCE]))   # the largest forbids nothing: feasible
    lo, hi = np.full(len(values), -1), np.array([v.size - 1 for v in values])
    while (hi - lo > 1).any():
        open_ = np.flatnonzero(hi - lo > 1)
        ways = max(2, min(64, columns_per_call // open_.size + 1))
        columns, splits = [], []
        for i in open_:
            points = np.unique(np.linspace(lo[i], hi[i], ways + 1).round().astype(int)[1:-1])
            points = points[(points > lo[i]) & (points < hi[i])]
            columns += [i] * points.size
            splits += list(points)
        columns, splits = np.array(columns), np.array(splits)
        bad = infeasible_at(mdp, demos, SR[:, columns], [values[i][m] for i, m in zip(columns, splits)])
        for i in np.unique(columns):
            mine = columns == i
            feasible = splits[mine][~bad[mine]]
            infeasible = splits[mine][bad[mine]]
            hi[i] = feasible.min() if feasible.size else hi[i]
            lo[i] = infeasible[infeasible < hi[i]].max() if (infeasible < hi[i]).any() else lo[i]
    for k, (v, h) in enumerate(zip(values, hi)):
        if v.size:
            psi[k] = v[h]
    return psi


def chance_columns(mdp, demos, groups, rule="lemma"):
    """``(psi, forbidden, raised)`` for candidate groups: ``groups`` is a list of functions that
    build S(x, a, R) (X*A, k) column blocks, one at a time, so that only the few columns that need
    raising are kept in memory. psi (K,) by ``rule`` ("lemma" or "eq3.3"; module docstring),
    ``forbidden`` the boolean CSC matrix [S(x, a, R_k) > psi_k] (X*A, K), ``raised`` the candidates
    Lemma 3.2.1 raised above eq. (3.3)."""
    if rule not in THRESHOLDS:
        raise ValueError(f"thresholds: must be one of {list(THRESHOLDS)}, got {rule!r}")
    rows = demonstrated_rows(mdp, demos)
    psi, forbidden, sizes = [], [], []
    for build in groups:
        SR = sp.csc_matrix(build())
        psi.append(eq33(SR, rows))
        forbidden.append(forbidden_by(SR, psi[-1]))
        sizes.append(SR.shape[1])
        del SR
    psi, forbidden = np.concatenate(psi), sp.hstack(forbidden, format="csc")
    if rule == "eq3.3":
        return psi, forbidden, np.zeros(0, dtype=np.int64)
    base = np.ones((mdp.n_states, mdp.n_actions), dtype=bool)
    raised = np.flatnonzero(infeasible_candidates(mdp, demos, base, forbidden))    # all groups in one backup
    if raised.size:
        starts = np.cumsum([0] + sizes)
        kept = [sp.csc_matrix(build())[:, raised[(raised >= a) & (raised < b)] - a]            # rebuilt, the few kept
                for build, a, b in zip(groups, starts[:-1], starts[1:]) if ((raised >= a) & (raised < b)).any()]
        kept = sp.hstack(kept, format="csc")
        psi[raised] = lemma(mdp, demos, kept, psi[raised])
        old, new = forbidden.tocoo(), forbidden_by(kept, psi[raised]).tocoo()
        stay = ~np.isin(old.col, raised)
        rows_, cols = np.r_[old.row[stay], new.row], np.r_[old.col[stay], raised[new.col]]
        forbidden = sp.csc_matrix((np.ones(rows_.size, dtype=bool), (rows_, cols)), shape=forbidden.shape)
    return psi, forbidden, raised


def threshold_table(mdp, demos, grid, bounds):
    """Where the cells model loses a bound (module docstring), one row per :class:`~.regions.Bound` of
    ``bounds`` (one coordinate): psi* of eq. (3.3), whether the demonstrations stay feasible at it, the
    lowest feasible psi (Lemma 3.2.1 taken exactly) and how many offered state-actions that threshold still
    forbids (0: the candidate forbids nothing and is dropped)."""
    import pandas as pd
    from .candidates import _bound_columns
    dims = {b.dim for b in bounds}
    if len(dims) != 1:
        raise ValueError("bounds: need bounds on one coordinate")
    SR = _bound_columns(mdp, grid, dims.pop(), list(bounds))
    rows = demonstrated_rows(mdp, demos)
    star = eq33(SR, rows)
    bad = infeasible_at(mdp, demos, SR, star)
    psi = star.copy()
    if bad.any():
        psi[bad] = lemma(mdp, demos, sp.csc_matrix(SR)[:, np.flatnonzero(bad)], star[bad])
    offered = mdp.allowed.reshape(-1)
    forbids = np.asarray((forbidden_by(SR, psi).multiply(sp.csr_matrix(offered.reshape(-1, 1)))).sum(axis=0)).ravel()
    return pd.DataFrame({"bound": [b.describe(grid) for b in bounds], "value": [b.value for b in bounds],
                         "psi eq. 3.3": star, "feasible at eq. 3.3": ~bad, "psi Lemma 3.2.1": psi,
                         "state-actions forbidden": forbids.astype(int)})
