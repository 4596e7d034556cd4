"""One stage of the Riccati recursion, and the small positive definite solve inside it.

Every backward pass of the package repeats :func:`riccati_step` from the last stage to the first:
chapter 6's exact LQ solver (:mod:`.legible.lqr`, the LQ case of eqs. (6.1), (6.3)-(6.4), used for the
legible objective (6.15), its replans (6.16) and the reaching costs (6.17)) and its compiled twin
(:mod:`.legible.lqr_compiled`), the observer's Gaussians ``P(u | H)`` of eq. (6.8) (:mod:`.chain`) and
the iLQR/DDP backward pass (:mod:`.trajopt.backward`; Todorov & Li 2005, section 3; Tassa, Erez &
Todorov 2012, eqs. (5)-(11)). For a stage ``x' = A x + B u + c`` with the cost
``1/2 x'Q x + 1/2 u'R u + u'S x + q'x + r'u`` and the cost-to-go ``1/2 x'V x + v'x`` after it::

    v~   = v + V c
    Q_x  = q + A'v~            Q_u  = r + B'v~
    Q_xx = Q + A'V A           Q_ux = S + B'V A           Q_uu = R + B'V B
    [k K] = -Q_uu^-1 [Q_u Q_ux]                                          (u = K x + k)
    V <- Q_xx + Q_ux'K         v <- Q_x + Q_ux'k

(Tassa et al.'s eqs. (5), (10), (11) with ``l_x = q``, ``l_uu = R``, ``l_ux = S``, ``f_x = A``, ``f_u = B``).
With regularisation ``rho`` (Tassa et al., section II-F) the gains solve ``(Q_uu + rho)[k K] = -[Q_u Q_ux]``
and the cost-to-go is updated with the unregularised ``Q_uu`` (their eq. (11))::

    V <- Q_xx + Q_ux'K + K'Q_ux + K'Q_uu K      v <- Q_x + K'(Q_uu k + Q_u) + Q_ux'k

which equals the short form above when ``rho = 0``. DDP adds the dynamics' curvature ``v'f_zz`` to the
``Q_zz`` blocks (their eq. (6)): pass it as ``curvature``.

The same definition serves NumPy and JAX (``xp``: ``numpy`` or ``jax.numpy``). NumPy multiplies with
``matmul`` over any leading batch axes (several problems at once); under JAX a product is a broadcast
multiply-and-sum, which XLA fuses with its neighbours inside a ``scan`` (on a CPU far cheaper than a
``dot`` per 3 x 3 product). :func:`spd_solve` factorises ``Q_uu = L L'`` by unrolled scalar arithmetic for
``m <= UNROLLED_MAX_M`` controls (several times faster inside a compiled scan than LAPACK's opaque calls,
and in NumPy no slower for a handful of problems), by LAPACK beyond. It never raises: a ``Q_uu`` that
is not positive definite shows as a pivot <= 0 or NaN, which each caller reports in its own words.
"""

import contextlib
from typing import Any, NamedTuple

import numpy as np

UNROLLED_MAX_M = 4  # up to this many controls, Q_uu is factorised by unrolled arithmetic (measured on a CPU)


def T(a):
    """``a'``: the transpose of the last two axes."""
    return a.swapaxes(-1, -2)


def mm(xp, a, b):
    """``a @ b`` over leading batch axes (NumPy's ``matmul``; under JAX a fused multiply-and-sum)."""
    if xp is np:
        return a @ b
    return (a[..., :, :, None] * b[..., None, :, :]).sum(-2)


def mv(xp, a, x):
    """``a x`` for a matrix ``a`` (..., i, j) and a vector ``x`` (..., j)."""
    if xp is np:
        return (a @ x[..., None])[..., 0]
    return (a * x[..., None, :]).sum(-1)


def _quiet(xp):
    """NumPy: no warnings from the NaN a matrix that is not positive definite leaves (reported by the caller)."""
    return np.errstate(invalid="ignore", divide="ignore", over="ignore") if xp is np else contextlib.nullcontext()


def spd_solve(S, rhs, xp=np):
    """``(X, L, pivots)``: ``X = S^-1 rhs`` by the Cholesky factorisation ``S = L L'`` of a symmetric
    ``S`` (..., m, m), for ``rhs`` (..., m, k); ``pivots`` (..., m) are the factorisation's pivots (the
    squares of ``L``'s diagonal). Only the lower triangle of ``S`` is read. Never raises: ``S`` is positive
    definite exactly when every pivot is > 0; otherwise some pivot is <= 0 or NaN, and so are ``X`` and ``L``
    from there on."""
    m = S.shape[-1]
    with _quiet(xp):
        if m > UNROLLED_MAX_M:
            return _lapack_solve(S, rhs, xp)
        if m == 1:
            s = S[..., 0, 0]
            return rhs / s[..., None, None], xp.sqrt(S), s[..., None]
        L, pivots = [], []
        for i in range(m):
            row = []
            for j in range(i):
                row.append((S[..., i, j] - sum(row[p] * L[j][p] for p in range(j))) / L[j][j])
            pivots.append(S[..., i, i] - sum(r * r for r in row))
            row.append(xp.sqrt(pivots[-1]))                     # NaN for a negative pivot
            L.append(row)
        Y = []                                                  # L Y = rhs, then L'X = Y, row by row
        for i in range(m):
            Y.append((rhs[..., i, :] - sum(L[i][p][..., None] * Y[p] for p in range(i))) / L[i][i][..., None])
        X = [None] * m
        for i in reversed(range(m)):
            X[i] = (Y[i] - sum(L[p][i][..., None] * X[p] for p in range(i + 1, m))) / L[i][i][..., None]
        zero = xp.zeros_like(L[0][0])
        factor = xp.stack([xp.stack(row + [zero] * (m - 1 - i), axis=-1) for i, row in enumerate(L)], axis=-2)
        return xp.stack(X, axis=-2), factor, xp.stack(pivots, axis=-1)


def _lapack_solve(S, rhs, xp):
    """:func:`spd_solve` by LAPACK (``m > UNROLLED_MAX_M``)."""
    if xp is np:
        try:
            L = np.linalg.cholesky(S)
        except np.linalg.LinAlgError:                           # some S is not positive definite
            nan = np.full(S.shape, np.nan)
            return np.full(rhs.shape, np.nan), nan, nan[..., 0]
        return np.linalg.solve(S, rhs), L, np.diagonal(L, axis1=-2, axis2=-1) ** 2
    from jax.scipy.linalg import cho_solve
    L = xp.linalg.cholesky(S)                                   # NaN unless positive definite
    return cho_solve((L, True), rhs), L, xp.diagonal(L, axis1=-2, axis2=-1) ** 2


class LQStage(NamedTuple):
    """One stage of an LQ problem (module docstring): dynamics ``x' = A x + B u + c`` (``c`` may be None)
    and cost ``1/2 x'Q x + 1/2 u'R u + u'S x + q'x + r'u``; ``S`` (m, n) is the control-state block of the
    cost's Hessian (``M'`` for a cost written ``x'M u``). Any field may carry leading batch axes."""

    A: Any
    B: Any
    Q: Any
    R: Any
    S: Any
    q: Any
    r: Any
    c: Any = None


class RiccatiStep(NamedTuple):
    """What one step returns: the policy ``u = K x + k`` (``gains = [k K]``, (..., m, 1+n)), the cost-to-go
    ``(V, v)`` before the stage, the model's ``Q_u`` and unregularised ``Q_uu``, and the Cholesky factor ``L``
    and ``pivots`` of the (regularised) ``Q_uu`` (:func:`spd_solve`)."""

    gains: Any
    V: Any
    v: Any
    Q_u: Any
    Q_uu: Any
    L: Any
    pivots: Any

    @property
    def k(self):
        return self.gains[..., 0]

    @property
    def K(self):
        return self.gains[..., 1:]


def riccati_step(V, v, stage, xp=np, reg=None, curvature=None):
    """The cost-to-go before ``stage`` (an :class:`LQStage`) from ``(V, v)`` after it, and the stage's
    optimal policy: one step of the Riccati recursion (module docstring; Tassa et al. 2012, eqs. (5)-(11)).

    ``reg`` (m, m), e.g. ``mu I``: solve with ``Q_uu + reg`` and update with eq. (11)'s full form (None:
    unregularised, the short form). ``curvature`` (n+m, n+m): DDP's ``v'f_zz``, added to the ``Q_zz`` blocks
    (eq. (6)). Returns a :class:`RiccatiStep`; a ``Q_uu`` that is not positive definite leaves pivots
    <= 0 or NaN (see :func:`spd_solve`), never an exception."""
    A, B, Q, R, S, q, r, c = stage
    n = A.shape[-1]
    VA, VB = mm(xp, V, A), mm(xp, V, B)
    v_c = v if c is None else v + mv(xp, V, c)
    Q_xx = Q + mm(xp, T(A), VA)
    Q_ux = S + mm(xp, T(B), VA)
    Q_uu = R + mm(xp, T(B), VB)
    Q_x, Q_u = q + mv(xp, T(A), v_c), r + mv(xp, T(B), v_c)
    if curvature is not None:
        Q_xx, Q_ux, Q_uu = Q_xx + curvature[..., :n, :n], Q_ux + curvature[..., n:, :n], Q_uu + curvature[..., n:, n:]
    G, L, pivots = spd_solve(Q_uu if reg is None else Q_uu + reg, -xp.concatenate([Q_u[..., None], Q_ux], axis=-1), xp)
    k, K = G[..., 0], G[..., 1:]
    if reg is None:
        V = Q_xx + mm(xp, T(Q_ux), K)
        v = Q_x + mv(xp, T(Q_ux), k)
    else:
        Q_uxK = mm(xp, T(Q_ux), K)
        V = Q_xx + Q_uxK + T(Q_uxK) + mm(xp, T(K), mm(xp, Q_uu, K))
        v = Q_x + mv(xp, T(K), mv(xp, Q_uu, k) + Q_u) + mv(xp, T(Q_ux), k)
    return RiccatiStep(G, 0.5 * (V + T(V)), v, Q_u, Q_uu, L, pivots)
