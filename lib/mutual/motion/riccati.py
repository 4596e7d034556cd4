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

(Tassa et al.'s eqs. (5), (10), (11) with ``l_x = q``, ``l_uu = R``, ``l_ux = S``, ``f_x = A``, ``f_u = B``),
computed in ``z = (x, u)`` at once: ``Q_z = l_z + F'v~`` and ``Q_zz = l_zz + F'V F`` with ``F = [A B]``, whose
blocks are the lines above (in NumPy a third of the calls of block by block).
With regularisation ``rho`` (Tassa et al., section II-F) the gains solve ``(Q_uu + rho)[k K] = -[Q_u Q_ux]``
and the cost-to-go is updated with the unregularised ``Q_uu`` (their eq. (11))::

    V <- Q_xx + Q_ux'K + K'Q_ux + K'Q_uu K      v <- Q_x + K'(Q_uu k + Q_u) + Q_ux'k

which equals the short form above when ``rho = 0``. DDP adds the dynamics' curvature ``v'f_zz`` to
``Q_zz`` (their eq. (6)): pass it as ``curvature``.

The same definition serves NumPy and JAX (``xp``: ``numpy`` or ``jax.numpy``). NumPy multiplies with
``matmul`` over any leading batch axes (several problems at once); under JAX a product is a broadcast
multiply-and-sum, which XLA fuses with its neighbours inside a ``scan`` (on a CPU far cheaper than a
``dot`` per 3 x 3 product). :func:`spd_solve` factorises ``Q_uu = L L'``: under JAX by unrolled scalar
arithmetic for ``m <= UNROLLED_MAX_M`` controls (several times faster inside a compiled scan than LAPACK's
opaque calls), in NumPy by one batched LAPACK call per stage. It never raises: a ``Q_uu`` that is not
positive definite shows in its factor (:func:`positive_definite`), which each caller reports in its own words.
"""

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
        return np.matvec(a, x)
    return (a * x[..., None, :]).sum(-1)


def spd_solve(S, rhs, xp=np, factor=True):
    """``(X, L)``: ``X = S^-1 rhs`` by the Cholesky factorisation ``S = L L'`` of a symmetric ``S`` (..., m, m),
    for ``rhs`` (..., m, k). Never raises: ``S`` is positive definite exactly when every diagonal entry of
    ``L`` is > 0; otherwise one is <= 0 or NaN, and so are ``X`` and ``L`` from there on. In NumPy,
    ``factor=False`` skips the factorisation (``L`` is None, ``X`` takes one LU call) for a caller that tests
    definiteness its own way; under JAX the parts not used cost nothing.

    Under JAX with ``m <= UNROLLED_MAX_M`` the factorisation and both triangular substitutions are unrolled
    into scalar arithmetic at trace time (reading the lower triangle of ``S``; one ``S`` (m, m), batch with
    ``jax.vmap``); otherwise, and always in NumPy (one batched call for any number of problems), LAPACK."""
    m = S.shape[-1]
    if xp is np or m > UNROLLED_MAX_M:
        return _lapack_solve(S, rhs, xp, factor)
    if m == 1:
        return rhs / S[0, 0], xp.sqrt(S)
    L = []
    for i in range(m):
        row = []
        for j in range(i):
            row.append((S[i, j] - sum(row[p] * L[j][p] for p in range(j))) / L[j][j])
        row.append(xp.sqrt(S[i, i] - sum(r * r for r in row)))  # the pivot's root: NaN for a negative pivot
        L.append(row)
    Y = []                                                      # L Y = rhs, then L'X = Y, row by row
    for i in range(m):
        Y.append((rhs[i] - sum(L[i][p] * Y[p] for p in range(i))) / L[i][i])
    X = [None] * m
    for i in reversed(range(m)):
        X[i] = (Y[i] - sum(L[p][i] * X[p] for p in range(i + 1, m))) / L[i][i]
    zero = xp.zeros_like(L[0][0])
    return xp.stack(X), xp.stack([xp.stack(row + [zero] * (m - 1 - i)) for i, row in enumerate(L)])


def _lapack_solve(S, rhs, xp, factor):
    """:func:`spd_solve` by LAPACK (NumPy, or JAX with ``m > UNROLLED_MAX_M``)."""
    if xp is np:
        try:
            L = np.linalg.cholesky(S) if factor else None
            return np.linalg.solve(S, rhs), L
        except np.linalg.LinAlgError:                           # some S is not positive definite (or singular)
            return np.full(rhs.shape, np.nan), np.full(S.shape, np.nan) if factor else None
    from jax.scipy.linalg import cho_solve
    L = xp.linalg.cholesky(S)                                   # NaN unless positive definite
    return cho_solve((L, True), rhs), L


def positive_definite(L):
    """Whether the Cholesky factor ``L`` (..., m, m) of :func:`spd_solve` comes from a positive definite
    matrix (every diagonal entry > 0; NaN fails), for each matrix of a batch."""
    return (L.diagonal(0, -2, -1) > 0).all(-1)


class LQStage(NamedTuple):
    """One stage of an LQ problem (module docstring) in ``z = (x, u)``: the dynamics ``x' = F z + c`` with
    ``F = [A B]`` (n, n+m) (``c`` may be None) and the cost ``1/2 z'H z + g'z`` with ``H = [[Q, S'], [S, R]]``
    (n+m, n+m) and ``g = (q, r)`` (Tassa et al.'s ``f_z``, ``l_zz``, ``l_z``). Any field may carry leading
    batch axes."""

    F: Any
    H: Any
    g: Any
    c: Any = None


class RiccatiStep(NamedTuple):
    """What one step returns: the policy ``u = K x + k`` (also as ``gains = [k K]``, (..., m, 1+n)), the
    cost-to-go ``(V, v)`` before the stage, the model's ``Q_u`` and unregularised ``Q_uu``, and the Cholesky
    factor ``L`` of the (regularised) ``Q_uu`` (:func:`spd_solve`; :func:`positive_definite`)."""

    K: Any
    k: Any
    gains: Any
    V: Any
    v: Any
    Q_u: Any
    Q_uu: Any
    L: Any


def riccati_step(V, v, stage, xp=np, reg=None, curvature=None, factor=True):
    """The cost-to-go before ``stage`` (an :class:`LQStage`) from ``(V, v)`` after it, and the stage's
    optimal policy: one step of the Riccati recursion (module docstring; Tassa et al. 2012, eqs. (5)-(11)).

    ``reg`` (m, m), e.g. ``mu I``: solve with ``Q_uu + reg`` and update with eq. (11)'s full form (None:
    unregularised, the short form). ``curvature`` (n+m, n+m): DDP's ``v'f_zz``, added to ``Q_zz``
    (eq. (6)). ``factor``: see :func:`spd_solve`. Returns a :class:`RiccatiStep`; a ``Q_uu`` that is not
    positive definite leaves a factor ``L`` with a diagonal entry <= 0 or NaN (:func:`positive_definite`),
    never an exception."""
    F, H, g, c = stage
    n, F_T = F.shape[-2], T(F)
    Q_z = g + mv(xp, F_T, v if c is None else v + mv(xp, V, c))    # (Q_x, Q_u) = (q + A'v~, r + B'v~)
    Q_zz = H + mm(xp, F_T, mm(xp, V, F))       # [[Q_xx, Q_xu], [Q_ux, Q_uu]]: Q_uu = R + B'VB, Q_ux = S + B'VA
    if curvature is not None:
        Q_zz = Q_zz + curvature
    Q_x, Q_u = Q_z[..., :n], Q_z[..., n:]
    Q_xx, Q_ux, Q_uu = Q_zz[..., :n, :n], Q_zz[..., n:, :n], Q_zz[..., n:, n:]
    G, L = spd_solve(Q_uu if reg is None else Q_uu + reg, -xp.concatenate([Q_u[..., None], Q_ux], axis=-1), xp,
                     factor)                                          # [k K] = -Q_uu^-1 [Q_u Q_ux]
    k, K, Q_xu = G[..., 0], G[..., 1:], T(Q_ux)
    if reg is None:
        V = Q_xx + mm(xp, Q_xu, K)
        v = Q_x + mv(xp, Q_xu, k)
    else:                                      # eq. (11), with the unregularised Q_uu
        Q_xuK = mm(xp, Q_xu, K)
        V = Q_xx + Q_xuK + T(Q_xuK) + mm(xp, T(K), mm(xp, Q_uu, K))
        v = Q_x + mv(xp, T(K), mv(xp, Q_uu, k) + Q_u) + mv(xp, Q_xu, k)
    return RiccatiStep(K, k, G, 0.5 * (V + T(V)), v, Q_u, Q_uu, L)
