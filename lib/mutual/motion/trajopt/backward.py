"""The backward pass of iLQR/DDP (Tassa, Erez & Todorov 2012, eqs. (5)-(11); Todorov & Li 2005,
section 3): from the terminal cost back to the start, the quadratic model of the cost-to-go

    Q_z = g + F'v,    Q_zz = H + F'V F  (+ sum_i v_i f_i'' for DDP, eq. (6)),

the regularised policy ``du = k + K dx`` with ``(Q_uu + mu c I) [k K] = -[Q_u Q_ux]`` (eq. (10),
the control-space regularisation of section II-F) and the cost-to-go update with the
unregularised ``Q_uu`` (eq. (11)). ``d1 = sum k'Q_u`` and ``d2 = sum 1/2 k'Q_uu k`` give the
model's predicted decrease ``-(a d1 + a^2 d2)`` for a step of size ``a`` (eq. (13)).
"""

import jax
import jax.numpy as jnp
from jax.scipy.linalg import cho_solve

UNROLLED_CHOLESKY_MAX_M = 4  # up to this many controls, Q_uu is factorised by unrolled arithmetic
BACKWARD_UNROLL = 4  # stages per iteration of the backward scan (fewer loop trips; measured on a CPU)


def spd_solve(A, B):
    """``(A^-1 B, ok)`` by the Cholesky factorisation ``A = L L'``; ``ok`` is False (and the
    solution not finite) unless ``A`` (m, m) is positive definite, i.e. every pivot is > 0.

    For ``m <= UNROLLED_CHOLESKY_MAX_M`` the recursion and both triangular substitutions are
    unrolled into plain arithmetic at trace time (inside the backward scan several times faster
    on a CPU than LAPACK's opaque calls); larger ``m`` use LAPACK.
    """
    m = A.shape[-1]
    if m > UNROLLED_CHOLESKY_MAX_M:
        L = jnp.linalg.cholesky(A)  # NaN unless positive definite
        return cho_solve((L, True), B), jnp.all(jnp.isfinite(L))
    if m == 1:
        return B / A[0, 0], A[0, 0] > 0
    L, pivots = [], []
    for i in range(m):
        row = []
        for j in range(i):
            row.append((A[i, j] - sum(row[p] * L[j][p] for p in range(j))) / L[j][j])
        pivots.append(A[i, i] - sum(r * r for r in row))
        row.append(jnp.sqrt(pivots[-1]))  # NaN for a negative pivot
        L.append(row)
    Y = []
    for i in range(m):
        Y.append((B[i] - sum(L[i][p] * Y[p] for p in range(i))) / L[i][i])
    X = [None] * m
    for i in reversed(range(m)):
        X[i] = (Y[i] - sum(L[p][i] * X[p] for p in range(i + 1, m))) / L[i][i]
    return jnp.stack(X), jnp.all(jnp.stack(pivots) > 0)


def _stage(carry, stage, reg, n, curvature_weight):
    """One stage of the recursion: ``(V, v)`` at ``k + 1`` to ``(V, v)`` at ``k`` and the gains ``[k K]``.

    Small products are written as broadcast multiply-and-sum, which XLA fuses inside the scan (on
    a CPU fewer kernels per stage than ``dot``s of 3x3 matrices)."""
    V, v, d1, d2, every_ok = carry
    Fk, gk, Hk = stage[:3]
    VF = jnp.sum(V[:, :, None] * Fk[None, :, :], axis=1)  # V F (n, n+m)
    Z = Hk + jnp.sum(Fk[:, :, None] * VF[:, None, :], axis=0)  # Q_zz = H + F'V F
    q = gk + jnp.sum(Fk * v[:, None], axis=0)  # Q_z = g + F'v
    if len(stage) > 3:  # DDP: + sum_i v_i f_i''
        Z = Z + curvature_weight * jnp.sum(v[:, None, None] * stage[3], axis=0)
    Qxx, Qux, Quu = Z[:n, :n], Z[n:, :n], Z[n:, n:]
    Qx, Qu = q[:n], q[n:]
    G, ok = spd_solve(Quu + reg, -jnp.concatenate([Qu[:, None], Qux], axis=1))
    k, K = G[:, 0], G[:, 1:]
    QuuK = jnp.sum(Quu[:, :, None] * K[None, :, :], axis=1)  # (m, n)
    QuxK = jnp.sum(Qux[:, :, None] * K[:, None, :], axis=0)  # Qux'K (n, n)
    V = Qxx + QuxK + QuxK.T + jnp.sum(K[:, :, None] * QuuK[:, None, :], axis=0)
    V = 0.5 * (V + V.T)
    Quuk = jnp.sum(Quu * k[None, :], axis=1)
    v = Qx + jnp.sum(K * (Quuk + Qu)[:, None], axis=0) + jnp.sum(Qux * k[:, None], axis=0)
    return (V, v, d1 + jnp.sum(k * Qu), d2 + 0.5 * jnp.sum(k * Quuk), every_ok & ok), G


def backward_pass(model, mu, curvature_weight=1.0):
    """Gains ``G = [k K]`` (N, m, 1+n), the predicted terms ``d1`` and ``d2``, and whether every
    ``Q_uu + mu c I`` was positive definite, for the :class:`.model.Model` ``model``."""
    n = model.VN.shape[0]
    m = model.H.shape[-1] - n
    reg = mu * model.c * jnp.eye(m)
    stages = (model.F, model.g, model.H) if model.curvature is None else (model.F, model.g, model.H, model.curvature)
    zero = jnp.zeros(())
    (_, _, d1, d2, ok), G = jax.lax.scan(lambda carry, stage: _stage(carry, stage, reg, n, curvature_weight),
                                         (model.VN, model.vN, zero, zero, jnp.ones((), bool)), stages, reverse=True,
                                         unroll=BACKWARD_UNROLL)
    return G, d1, d2, ok
