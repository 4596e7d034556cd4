"""Sums in log space for the point model's backups (:mod:`.pointwise`): log with log 0 = -inf, log sum exp
(-inf for an empty sum), the probabilities and ratios that may be undefined (0 there).

NumPy reduces a short last axis (the d + 1 vertices of a barycentric successor, a point's controls) several
times slower than it adds whole arrays, and (NumPy 2's pairwise summation, an implementation detail that
tests/constraints/continuous/test_logspace.py pins) it sums fewer than 8 entries one after another: such an axis
is summed here array by array in the same order, so the numbers are the same, bit for bit.
"""

import numpy as np

SHORT = 8   # a last axis of fewer entries is summed array by array (:func:`logsumexp_rows`)


def log0(x):
    """log x, with log 0 = -inf and no warning."""
    with np.errstate(divide="ignore"):
        return np.log(x)


def logsumexp(v, axis):
    """log sum exp along ``axis`` (-inf where every entry is -inf); a short last axis array by array (module
    docstring)."""
    if v.ndim == 2 and axis in (1, -1) and 0 < v.shape[1] < SHORT:
        return logsumexp_rows([v[:, j] for j in range(v.shape[1])])
    m = np.max(v, axis=axis, keepdims=True)
    shift = np.where(np.isfinite(m), m, 0.0)
    return log0(np.exp(v - shift).sum(axis=axis)) + np.squeeze(shift, axis=axis)


def logsumexp_rows(rows):
    """log sum exp of the arrays ``rows`` (k >= 1 of them, one shape), summed in their order."""
    m = rows[0].copy()
    for row in rows[1:]:
        np.maximum(m, row, out=m)
    shift = np.where(np.isfinite(m), m, 0.0)
    total = np.exp(rows[0] - shift)
    for row in rows[1:]:
        total += np.exp(row - shift)
    return log0(total) + shift


def ratio(a, b):
    """a / b, with 0 where it is not finite."""
    with np.errstate(divide="ignore", invalid="ignore"):
        r = a / b
    r[~np.isfinite(r)] = 0.0
    return r


def probabilities(q, total):
    """exp(q - total) row by row (rows, k) with 0 where undefined: each move's probability within its owner, or
    each vertex's share of a successor's value."""
    with np.errstate(invalid="ignore"):
        p = np.exp(q - total[:, None])
    p[~np.isfinite(p)] = 0.0
    return p
